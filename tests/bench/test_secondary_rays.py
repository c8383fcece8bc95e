"""bench/secondary_rays.py counts every ray the render traces: its rows are the core's own
counters, summed, for the scene it describes."""

from __future__ import annotations

import numpy as np
import pytest

import durer


@pytest.fixture
def bench(import_bench):
    return import_bench("secondary_rays")


def test_scene_is_the_issues(bench):
    scene = bench.secondary_scene(spheres=500, seed=1)
    assert scene.object_count == 501  # the spheres and the ground plane
    result = durer.render(scene, bench.CAMERA, 32, 18, passes=("color",))
    assert set(result.stats["effects"]) == {"diffuse", "shadows", "reflection"}


def test_a_point_light_lights_the_scene_with_shadows_as_the_sun_does(bench):
    """--light point: the same spheres under a point light with shadows, its shadow rays as many within
    a tenth, the image lit comparably (a light without falloff from the sun's side: within a half)."""
    sun, point = (bench.secondary_scene(spheres=500, seed=1, light=light) for light in bench.LIGHTS)
    assert point.object_count == sun.object_count == 501
    result = {light: durer.render(scene, bench.CAMERA, 64, 36, passes=("color",))
              for light, scene in (("sun", sun), ("point", point))}
    assert set(result["point"].stats["effects"]) == {"diffuse", "shadows", "reflection"}
    shadow = {light: result[light].stats["shadow_rays"] for light in result}
    assert shadow["point"] == pytest.approx(shadow["sun"], rel=0.1)
    lit = {light: result[light].color[..., :3].mean() for light in result}
    assert lit["point"] == pytest.approx(lit["sun"], rel=0.5)


def test_rows_sum_the_core_counters(bench):
    scene = bench.secondary_scene(spheres=2000, seed=1)
    rows, _ = bench.measure(scene, (48, 27), runs=1, threads=2)
    assert [(r.mode, r.precision) for r in rows] == [
        ("depth only", "double"), ("colour", "double"), ("depth only", "float"), ("colour", "float")]
    for row in rows:
        stats = durer.render(scene, bench.CAMERA, 48, 27, passes=bench.MODES[row.mode], precision=row.precision,
                             threads=2).stats
        assert row.counts == {k: stats[k] for k in (*bench.RAY_KINDS, "intersection_tests")}
        assert row.rays == stats["rays"] + stats["shadow_rays"] + stats["reflection_rays"] + stats["refraction_rays"]
        assert row.counts["rays"] == 48 * 27
        secondary = row.rays - row.counts["rays"]
        assert (secondary > 0) == (row.mode == "colour")
        assert row.mrays_per_s(row.median_ms) == pytest.approx(row.rays / (row.median_ms / 1000) / 1e6)
        cpu_seconds = row.milliseconds[0] / 1000 * row.cpu_use[0]
        assert row.mrays_per_cpu_second == pytest.approx(row.rays / cpu_seconds / 1e6)
        assert np.isclose(row.tests_per_ray, stats["intersection_tests"] / row.rays)


def _colour_row(bench, camera: int, shadow: int, reflection: int, ms: float):
    counts = {"rays": camera, "shadow_rays": shadow, "reflection_rays": reflection, "refraction_rays": 0,
              "intersection_tests": 0}
    return bench.Row("colour", "double", counts, (ms,), (2.0,))


def test_embree_lines_bound_the_render_by_embrees_speed_on_its_secondary_rays(bench):
    row = _colour_row(bench, camera=1000, shadow=1000, reflection=2000, ms=4.0)
    # Embree: 3,000 rays in a median 2 ms = 1.5 Mrays/s; durer.cast 4 ms (double) and 6 ms (float).
    embree = bench.EmbreeRays(3000, (1.0, 2.0, 5.0), {"double": (4.0, 4.0, 3.0), "float": (6.0, 6.0, 6.0)}, True)
    first, bound = bench.embree_lines(embree, [row], threads=2)
    assert "(3,000, the render's 3,000;" in first and "2.0 ms = 1.5 Mrays/s" in first
    assert "double 4.0 ms = 0.75 Mrays/s (0.50x Embree's)" in first
    assert "float 6.0 ms = 0.5 Mrays/s (0.33x Embree's)" in first
    # The render's 3,000 secondary rays at 1.5 Mrays/s take 2 ms: its 4,000 rays in 2 ms = 2 Mrays/s at most.
    assert "alone take 2.0 ms" in bound and "at most 2 Mrays/s counting all rays (the target: 10)" in bound


def test_embree_lines_say_why_there_is_no_comparison(bench):
    row = _colour_row(bench, camera=10, shadow=10, reflection=10, ms=1.0)
    assert bench.embree_lines("Intel Embree 3 not found", [row], threads=2) == ["Intel Embree 3 not found"]
    disagreeing = bench.EmbreeRays(20, (1.0,), {"double": (1.0,), "float": (1.0,)}, False)
    (line,) = bench.embree_lines(disagreeing, [row], threads=2)
    assert "DISAGREE" in line and "Mrays/s" not in line
