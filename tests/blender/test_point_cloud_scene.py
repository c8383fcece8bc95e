"""scenes/make_point_cloud.py (issue 13's point cloud in Blender) and its run in
bench/showcase_vs_cycles.py: a geometry-nodes point cloud in the slab, a plane, a sun with shadows."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

import durer.blender
from durer.blender import engine
from durer.blender.export.depsgraph import export_depsgraph
from helpers import ROOT

pytestmark = pytest.mark.blender

POINTS = 3000


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("showcase_vs_cycles", ROOT / "bench" / "showcase_vs_cycles.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def blend(bench, tmp_path_factory):
    return bench.make_point_cloud(tmp_path_factory.mktemp("cloud"), POINTS)


def test_the_cloud_is_spheres_in_the_slab_over_a_plane_under_a_sun(blend):
    durer.blender.register()
    bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
    s = bpy.context.scene
    assert s.render.engine == "DURER" and s.durer.samples == 1 and s.cycles.samples == 1
    cloud = bpy.data.objects["Cloud"]
    assert cloud.type == "MESH" and [m.type for m in cloud.modifiers] == ["NODES"]
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert data.sphere_count == POINTS
    np.testing.assert_allclose(data.sphere_radii, 0.02, rtol=1e-6)
    low, high = data.sphere_centers.min(axis=0), data.sphere_centers.max(axis=0)
    assert np.all(low >= (-10, -10, 0)) and np.all(high <= (10, 10, 4))
    assert np.all(low < (-9.9, -9.9, 0.1)) and np.all(high > (9.9, 9.9, 3.9))  # filled, not a corner of it
    s.render.resolution_percentage = 5
    assert bpy.ops.render.render() == {"FINISHED"}
    info = engine.last_render
    assert info.error is None and info.warnings == []
    assert (info.spheres, info.planes) == (POINTS, 1)
    assert "shadows" in info.stats["effects"] and info.stats["shadow_rays"] > 0.9 * info.stats["rays"]


def test_bench_renders_it_with_both_engines(bench, blend):
    out = bench.compare_engines(blend, 64, 36, samples=1, repeats=1)
    assert out["durer"]["spheres"] == POINTS and out["durer"]["shadow_rays"] > 0
    assert out["cycles"]["seconds"] > 0 and out["speedup"] == out["cycles"]["seconds"] / out["durer"]["seconds"]
    lines = bench.report(out, bench.POINT_CLOUD_TARGET)
    assert lines[-1].startswith(f"  Cycles / Dürer: {out['speedup']:.1f}x (issue 13's target >= 5x")


def test_the_point_light_variant_casts_its_shadows_from_a_point(bench, tmp_path):
    blend = bench.make_point_cloud(tmp_path, POINTS, "point")
    durer.blender.register()
    bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert [(light.kind, light.shadows) for light in data.lights] == [("point", True)]
    np.testing.assert_allclose(data.lights[0].position, (4.0, -4.0, 14.0))
    bpy.context.scene.render.resolution_percentage = 5
    assert bpy.ops.render.render() == {"FINISHED"}
    info = engine.last_render
    assert info.error is None and info.warnings == [] and info.spheres == POINTS
    assert 0.3 * info.stats["rays"] < info.stats["shadow_rays"] <= info.stats["rays"]


def test_the_particle_variant_fills_the_slab_with_instances_of_a_sphere(bench, tmp_path):
    """--made-by particles: a particle system's instances of a UV sphere, the emitter hidden; each
    instance is one exact sphere of radius 0.02 in the slab, as many as particles."""
    blend = bench.make_point_cloud(tmp_path, POINTS, made_by="particles")
    durer.blender.register()
    bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
    emitter = bpy.data.objects["Emitter"]
    assert [m.type for m in emitter.modifiers] == ["PARTICLE_SYSTEM"] and not emitter.show_instancer_for_render
    bpy.context.scene.render.resolution_percentage = 5
    assert bpy.ops.render.render() == {"FINISHED"}
    info = engine.last_render
    assert info.error is None and info.warnings == [] and (info.spheres, info.planes) == (POINTS, 1)
    emitter.particle_systems[0].settings.display_percentage = 100  # the viewport's depsgraph: all of them too
    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert data.sphere_count == POINTS
    np.testing.assert_allclose(data.sphere_radii, 0.02, rtol=1e-5)
    low, high = data.sphere_centers.min(axis=0), data.sphere_centers.max(axis=0)
    assert np.all(low >= (-10, -10, 0)) and np.all(high <= (10, 10, 4))
    assert np.all(low < (-9.8, -9.8, 0.1)) and np.all(high > (9.8, 9.8, 3.9))
