"""Regions and tiles: parts of an image render bit for bit as in the whole image."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import durer
from durer.distributed import tile_regions

from helpers.distributed import assert_same_image, every_kind_scene, orbit_cameras

SCENE = every_kind_scene()
CAMERA = orbit_cameras(5)[2]
W, H = 45, 37  # not multiples of the core's 8-pixel tiles


def crop(result, x, y, w, h):
    return durer.RenderResult(stats={}, **{name: None if getattr(result, name) is None else
                                           getattr(result, name)[y : y + h, x : x + w]
                                           for name in durer.RenderResult.ARRAYS})


@pytest.mark.parametrize("options", [
    {"spp": 4}, {"spp": 3, "sampler": "random"}, {"spp": 8, "sampler": "sobol", "precision": "float"},
    {"spp": 1, "sampler": "center", "passes": ("depth",)}, {"spp": 4, "passes": ("depth", "object_id", "material_id")},
])
def test_any_region_equals_that_part_of_the_whole_render(options):
    whole = durer.render(SCENE, CAMERA, W, H, **options)
    assert len(np.unique(whole.depth)) > 100  # a busy image
    for region in ((0, 0, W, H), (3, 5, 13, 7), (40, 30, 5, 7), (9, 0, 1, 37), (0, 36, 45, 1)):
        part = durer.render(SCENE, CAMERA, W, H, region=region, **options)
        assert part.stats["region"] == region  # the whole image given as a region too
        assert part.stats["rays"] == region[2] * region[3] * options["spp"]
        assert_same_image(part, crop(whole, *region))


def test_adaptive_regions_anywhere_match():
    options = {"spp": 16, "sampler": "adaptive", "target_error": 0.002}
    whole = durer.render(SCENE, CAMERA, W, H, **options)
    assert len(np.unique(whole.samples)) > 2  # the sampler did adapt
    for region in ((8, 16, 16, 8), (40, 32, 5, 5), (0, 0, 45, 37), (3, 0, 8, 8), (0, 8, 8, 9)):
        part = durer.render(SCENE, CAMERA, W, H, region=region, **options)
        assert_same_image(part, crop(whole, *region))
        # The margin the region is sampled with is traced too.
        assert part.stats["rays"] >= part.samples.sum()


@pytest.mark.parametrize("region, error, message", [
    ((0, 0, 46, 1), ValueError, "region width must be <= 45"), ((45, 0, 1, 1), ValueError, "region x must be <= 44"),
    ((0, -1, 1, 1), ValueError, "region y must be >= 0"), ((0, 0, 0, 1), ValueError, "region width must be >= 1"),
    ((0, 0, 1), ValueError, r"region must be \(x, y, width, height\) or None, got 3 items"),
    (7, TypeError, r"region must be \(x, y, width, height\) or None, got int"),
    ((0, 0, 1.5, 1), TypeError, "region width must be an integer"),
])
def test_bad_regions_name_the_field(region, error, message):
    with pytest.raises(error, match="^" + message):
        durer.render(SCENE, CAMERA, W, H, region=region)


def test_tile_regions_cover_the_image_once():
    regions = tile_regions(45, 37, 16)
    assert regions[0] == (0, 0, 16, 16) and regions[-1] == (32, 32, 13, 5) and len(regions) == 9
    covered = np.zeros((37, 45), int)
    for x, y, w, h in regions:
        covered[y : y + h, x : x + w] += 1
    assert (covered == 1).all()
    assert tile_regions(45, 37, 12)[1] == (12, 0, 12, 12)
    with pytest.raises(ValueError, match="tile must be >= 1"):
        tile_regions(45, 37, 0)


def test_render_tiles_checks_its_options_before_any_tile(monkeypatch):
    # The image limit is render's (durer._checks.MAX_IMAGE_SIDE), not a copy: a changed one is seen here.
    monkeypatch.setattr(durer._checks, "MAX_IMAGE_SIDE", 64)
    with pytest.raises(ValueError, match="width must be <= 64, got 65"):
        tile_regions(65, 1)
    with pytest.raises(TypeError, match="progress must be True or False"):
        durer.render_tiles(SCENE, CAMERA, 16, 16, progress="yes")
    with pytest.raises(ValueError, match="sampler must be"):
        durer.render_tiles(SCENE, CAMERA, 16, 16, sampler="bogus", client=object())  # before any task is sent


@pytest.mark.parametrize("options", [{"spp": 4}, {"spp": 16, "sampler": "adaptive", "target_error": 0.002},
                                     {"spp": 2, "passes": ("color", "object_id", "material_id")}])
def test_render_tiles_locally_equals_one_render(options):
    whole = durer.render(SCENE, CAMERA, W, H, **options)
    tiled = durer.render_tiles(SCENE, CAMERA, W, H, tile=16, **options)
    assert_same_image(tiled, whole)
    assert tiled.stats["tiles"] == 9 and tiled.stats["samples"] == whole.stats["samples"]
    # Adaptive tiles also trace the margin their refinement reads.
    assert (tiled.stats["rays"] == whole.stats["rays"]) == (options.get("sampler") != "adaptive")
    assert tiled.stats["workers"] == {"local": 9}


def test_render_tiles_on_a_cluster_equals_one_render(client):
    options = {"spp": 16, "sampler": "adaptive", "target_error": 0.002}
    whole = durer.render(SCENE, CAMERA, 100, 75, **options)
    tiled = durer.render_tiles(SCENE, CAMERA, 100, 75, tile=24, client=client, **options)
    assert_same_image(tiled, whole)
    assert sum(tiled.stats["workers"].values()) == 20 and "local" not in tiled.stats["workers"]
    assert tiled.stats["samples"] == whole.stats["samples"]
    assert tiled.stats["estimated_rmse"] == pytest.approx(whole.stats["estimated_rmse"], rel=1e-6)


@settings(max_examples=40, deadline=None)
@given(x=st.integers(0, W - 1), y=st.integers(0, H - 1), data=st.data(),
       sampler=st.sampled_from(["stratified", "random", "sobol", "center"]), spp=st.integers(1, 6),
       seed=st.integers(0, 2**64 - 1), precision=st.sampled_from(["float", "double"]))
def test_random_regions_equal_the_whole_render(x, y, data, sampler, spp, seed, precision):
    w = data.draw(st.integers(1, W - x))
    h = data.draw(st.integers(1, H - y))
    options = dict(spp=spp, seed=seed, sampler=sampler, precision=precision)
    whole = durer.render(SCENE, CAMERA, W, H, **options)
    assert_same_image(durer.render(SCENE, CAMERA, W, H, region=(x, y, w, h), **options), crop(whole, x, y, w, h))
