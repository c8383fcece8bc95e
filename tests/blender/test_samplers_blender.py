"""Samplers and quality presets in Blender: scene.durer's Sampler / Target Error / Preset settings,
the Render panel's rows, the settings reaching durer.render through bpy.ops.render.render."""

from __future__ import annotations

import inspect

import numpy as np
import pytest
from helpers.blender import ball_scene

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

import durer
from durer.blender import engine, properties, ui
from durer.render import PRECISIONS, SAMPLERS, SPHERE_METHODS

pytestmark = pytest.mark.blender

PRESETS = tuple(name.upper() for name in durer.PRESETS)


def enum_ids(settings, name):
    return [item.identifier for item in settings.bl_rna.properties[name].enum_items]


def direct_render(**kwargs):
    """The core's render of the exported scene (what the engine should have produced)."""
    from durer.blender import build
    from durer.blender.export.depsgraph import export_depsgraph

    data = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    cam = data.camera
    return durer.render(build.make_scene(data), build.make_camera(cam), cam.width, cam.height, passes=("color",),
                        shade_back=True, **kwargs)


def image_pixels(width, height):
    image = bpy.data.images[engine.IMAGE_NAME]
    pixels = np.empty(width * height * 4, np.float32)
    image.pixels.foreach_get(pixels)
    return pixels.reshape(height, width, 4)[::-1]  # top row first, like durer


# --- the settings ---------------------------------------------------------------------------------


def test_sampler_target_error_and_preset_settings(scene):
    settings = scene.durer
    assert sorted(enum_ids(settings, "sampler")) == sorted(name.upper() for name in SAMPLERS)
    assert enum_ids(settings, "preset") == ["CUSTOM", *PRESETS]
    assert settings.sampler == "STRATIFIED" and settings.preset == "CUSTOM"
    assert settings.target_error == pytest.approx(0.01)
    # Blender's defaults are the core's.
    assert engine.render_kwargs(settings)["target_error"] == _default("target_error")
    assert settings.sampler.lower() == _default("sampler")
    with pytest.raises(TypeError):
        settings.sampler = "HALTON"
    settings.target_error = 0.0  # clamped to the property's minimum: the core needs > 0
    assert settings.target_error > 0


def _default(name):
    return inspect.signature(durer.render).parameters[name].default


def test_render_kwargs_pass_sampler_and_target_error(scene):
    settings = scene.durer
    settings.target_error = 0.005
    for sampler in SAMPLERS:
        settings.sampler = sampler.upper()
        kwargs = engine.render_kwargs(settings)
        assert kwargs["sampler"] == sampler
        assert kwargs["target_error"] == 0.005  # the decimal, not float32's 0.004999999888
    # Every setting is a keyword durer.render takes.
    assert set(kwargs) <= set(inspect.signature(durer.render).parameters)


@pytest.mark.parametrize(("names", "text", "setting"), [
    (SAMPLERS, properties.SAMPLER_TEXT, "sampler"),
    (PRECISIONS, properties.PRECISION_TEXT, "precision"),
    (SPHERE_METHODS, properties.SPHERE_METHOD_TEXT, "sphere_method"),
], ids=["sampler", "precision", "sphere_method"])
def test_option_menus_are_the_core_names(scene, names, text, setting):
    # Every core name has a label and a tooltip, and no label names an option the core lacks.
    assert set(text) == set(names)
    items = scene.durer.bl_rna.properties[setting].enum_items
    assert {item.identifier.lower() for item in items} == set(names)
    for item in items:
        assert (item.name, item.description) == text[item.identifier.lower()]
    with pytest.raises(ValueError, match="no label for halton"):
        properties.enum_items((*names, "halton"), text)


def test_presets_set_samples_sampler_target_error_and_precision(scene):
    settings = scene.durer
    settings.sphere_method = "GEOMETRIC"
    settings.seed = 7
    for name in PRESETS:
        settings.preset = name
        preset = durer.preset(name.lower())
        assert settings.preset == name  # applying it does not flip it back to Custom
        assert settings.samples == preset["spp"]
        assert settings.sampler == preset.get("sampler", _default("sampler")).upper()
        assert settings.precision == preset.get("precision", _default("precision")).upper()
        assert np.float32(settings.target_error) == np.float32(preset.get("target_error", _default("target_error")))
        assert settings.min_samples == preset.get("min_spp", _default("min_spp"))
        assert settings.seed == 7  # not a preset's business
        if "sphere_method" not in preset:
            assert settings.sphere_method == "GEOMETRIC"
        # Blender then renders exactly what durer.render(..., **durer.preset(name)) renders.
        kwargs = engine.render_kwargs(settings)
        for key, value in preset.items():
            if key in kwargs:
                assert kwargs[key] == value, (name, key)
        # The tooltip says what the preset is.
        item = settings.bl_rna.properties["preset"].enum_items[name]
        assert str(preset["spp"]) in item.description


def test_editing_a_preset_setting_makes_it_custom(scene):
    settings = scene.durer
    for field in ("samples", "sampler", "target_error", "precision"):
        settings.preset = "FINAL"
        final = {f: getattr(settings, f) for f in ("samples", "sampler", "target_error", "precision")}
        if field == "samples":
            settings.samples = final["samples"] + 1
        elif field == "sampler":
            settings.sampler = "CENTER" if final["sampler"] != "CENTER" else "RANDOM"
        elif field == "target_error":
            if final["sampler"] != "ADAPTIVE":
                continue  # the preset sets it, but it only matters for Adaptive
            settings.target_error = final["target_error"] * 2
        else:
            settings.precision = "FLOAT" if final["precision"] == "DOUBLE" else "DOUBLE"
        assert settings.preset == "CUSTOM", field
    # Setting a field to the value it has, or a field no preset sets, keeps the preset.
    settings.preset = "DRAFT"
    settings.samples = settings.samples
    settings.seed = 3
    settings.max_bounces = 1
    assert settings.preset == "DRAFT"
    # Custom changes nothing; choosing the preset again re-applies it.
    settings.samples = 3
    before = (settings.samples, settings.sampler, settings.precision)
    settings.preset = "CUSTOM"
    assert (settings.samples, settings.sampler, settings.precision) == before
    settings.preset = "DRAFT"
    assert settings.samples == durer.preset("draft")["spp"]


def test_render_panel_rows(scene):
    settings = scene.durer
    for sampler in (name.upper() for name in SAMPLERS):
        settings.sampler = sampler
        rows = {name: (label, active) for name, label, active in ui.sampling_rows(settings)}
        assert list(rows)[:3] == ["preset", "samples", "sampler"]
        for adaptive_only in ("min_samples", "target_error", "time_limit"):
            assert (adaptive_only in rows) == (sampler == "ADAPTIVE")
        assert rows["samples"][0] == ("Max Samples" if sampler == "ADAPTIVE" else "Samples")
        assert rows["seed"][1] == (sampler != "CENTER")
        for name in rows:
            assert name in settings.bl_rna.properties
    assert ui.DURER_PT_render.bl_context == "render"


def test_stats_line_names_the_sampler():
    assert engine.stats_line(8, 4, 16, {"sampler": "sobol"}) == "Dürer | 8x4 | 16 spp sobol"
    line = engine.stats_line(8, 4, 64, {"sampler": "adaptive", "samples": 8 * 4 * 6, "mrays_per_s": 2.0})
    assert line == "Dürer | 8x4 | adaptive ≤ 64 spp (mean 6.0) | 2.0 Mrays/s"
    assert engine.stats_line(8, 4, 2, {}) == "Dürer | 8x4 | 2 spp"  # a core that does not say
    adaptive = {"sampler": "adaptive", "samples": 8 * 4 * 6, "estimated_rmse": 0.0012, "time_limit_reached": True}
    assert engine.stats_line(8, 4, 64, adaptive) == "Dürer | 8x4 | adaptive ≤ 64 spp (mean 6.0) | est. error 1.2e-03 (time limit)"


def test_min_samples_and_time_limit_reach_the_render(scene):
    settings = scene.durer
    settings.sampler = "ADAPTIVE"
    assert engine.render_kwargs(settings)["time_limit"] is None  # 0: no limit
    assert engine.render_kwargs(settings)["min_spp"] == _default("min_spp")
    settings.min_samples, settings.time_limit = 16, 2.5
    kwargs = engine.render_kwargs(settings)
    assert (kwargs["min_spp"], kwargs["time_limit"]) == (16, 2.5)
    settings.time_limit = -1.0  # clamped: a budget is never negative
    assert settings.time_limit == 0.0


def test_settings_survive_save_and_reload(scene, tmp_path):
    settings = scene.durer
    settings.sampler = "ADAPTIVE"
    settings.target_error = 0.02
    settings.samples = 32
    path = tmp_path / "samplers.blend"
    assert bpy.ops.wm.save_as_mainfile(filepath=str(path)) == {"FINISHED"}
    assert bpy.ops.wm.open_mainfile(filepath=str(path)) == {"FINISHED"}
    loaded = bpy.context.scene.durer
    assert (loaded.sampler, loaded.samples, loaded.preset) == ("ADAPTIVE", 32, "CUSTOM")
    assert loaded.target_error == pytest.approx(0.02)


# --- through the Render button ----------------------------------------------------------------


def test_adaptive_render_through_the_render_button(scene):
    ball_scene(scene)
    settings = scene.durer
    settings.sampler = "ADAPTIVE"
    settings.samples = 16
    settings.target_error = 0.05
    settings.seed = 3
    assert bpy.ops.render.render() == {"FINISHED"}
    info = engine.last_render
    assert info.error is None, info.error
    stats = info.stats
    assert stats["sampler"] == "adaptive" and stats["spp"] == 16
    counts = info.sample_counts
    assert counts.shape == (48, 64) and counts.dtype == np.int32
    assert counts.min() == 4 and counts.max() == 16  # world pixels stop early, the silhouette does not
    assert int(counts.sum()) == stats["samples"] == stats["rays"] - stats["probes"] < 64 * 48 * 16
    assert "adaptive ≤ 16 spp (mean " in info.stats_line
    direct = direct_render(spp=16, seed=3, sampler="adaptive", target_error=0.05)
    np.testing.assert_array_equal(direct.samples, counts)
    np.testing.assert_allclose(image_pixels(64, 48), direct.color, atol=1e-6)


def test_every_sampler_reaches_the_core(scene):
    ball_scene(scene, 24, 16)
    scene.durer.samples = 4
    images = {}
    for sampler in SAMPLERS:
        scene.durer.sampler = sampler.upper()
        assert bpy.ops.render.render() == {"FINISHED"}
        info = engine.last_render
        assert info.error is None, info.error
        assert info.stats["sampler"] == sampler
        assert (info.sample_counts is not None) == (sampler == "adaptive")
        if sampler != "adaptive":
            assert info.stats["samples"] == 24 * 16 * 4
        images[sampler] = image_pixels(24, 16).copy()
        np.testing.assert_allclose(images[sampler], direct_render(spp=4, sampler=sampler).color, atol=1e-6)
    assert not np.array_equal(images["center"], images["stratified"])
    assert not np.array_equal(images["random"], images["sobol"])


def test_a_preset_reaches_the_core(scene):
    ball_scene(scene, 24, 16)
    for name in ("DRAFT", "FINAL"):
        scene.durer.preset = name
        preset = durer.preset(name.lower())
        assert bpy.ops.render.render() == {"FINISHED"}
        stats = engine.last_render.stats
        assert engine.last_render.error is None
        assert stats["spp"] == preset["spp"]
        assert stats["sampler"] == preset.get("sampler", _default("sampler"))
        assert stats["precision"] == preset.get("precision", _default("precision"))
        direct = direct_render(**preset)
        np.testing.assert_allclose(image_pixels(24, 16), direct.color, atol=1e-6)
        assert stats["samples"] == direct.stats["samples"]
