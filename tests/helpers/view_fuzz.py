"""Random cases for the views of the spheres (cpp/include/durer/accel/SphereView.h): sphere clouds
at scales from 1e-3 to 1e4 and offsets to 1e6, seen by orthographic and perspective cameras from
inside and outside, at odd image sizes and regions, in both precisions; a render's camera rays must
find exactly what a cast of the same rays finds (tests/core/test_sphere_view.py runs a fixed number,
bench/fuzz_traversal.py --views as many as time allows, docs/reliability.md)."""

from __future__ import annotations

import math
from typing import Any

import durer
import numpy as np
from hypothesis import strategies as st

PASSES = ("depth", "normal", "object_id")


def assert_render_matches_cast(scene, camera, width, height, precision, region=None):
    res = durer.render(scene, camera, width=width, height=height, spp=1, passes=PASSES, precision=precision,
                       region=region, threads=2)
    origins, directions = camera.rays(width, height, precision)
    if region is not None:
        x, y, w, h = region
        origins, directions = origins[y:y + h, x:x + w], directions[y:y + h, x:x + w]
    shape = origins.shape[:2]
    cast = durer.cast(scene, origins.reshape(-1, 3), directions.reshape(-1, 3), t_min=camera.t_min,
                      t_max=camera.t_max, precision=precision, threads=1)
    np.testing.assert_array_equal(res.object_id, cast.object_id.reshape(shape))
    hit = cast.object_id.reshape(shape) >= 0
    np.testing.assert_array_equal(res.depth[hit], cast.t.reshape(shape)[hit].astype(np.float32))
    np.testing.assert_array_equal(res.normal[hit], cast.normal.reshape(*shape, 3)[hit].astype(np.float32))
    return res, hit


def cloud(rng, n, scale, offset, radius):
    scene = durer.Scene()
    material = scene.add_material(diffuse=(0.5, 0.5, 0.5))
    centers = offset + scale * rng.uniform(-1, 1, (n, 3))
    radii = radius * scale * rng.uniform(0.2, 1.0, n)
    scene.add_spheres(centers, radii, material=material)
    return scene


@st.composite
def view_cases(draw):
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    n = draw(st.integers(16, 400))
    scale = 10.0 ** draw(st.floats(-3, 4))
    offset = 10.0 ** draw(st.floats(-2, 6)) * rng.normal(size=3) if draw(st.booleans()) else np.zeros(3)
    radius = 10.0 ** draw(st.floats(-3, -0.3))
    perspective = draw(st.booleans())
    inside = draw(st.booleans())  # the eye among the spheres, else looking at them from outside
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    center = offset + (0.3 * scale * rng.uniform(-1, 1, 3) if inside else -3 * scale * direction)
    up = rng.normal(size=3)
    shift = tuple(draw(st.sampled_from([(0.0, 0.0), (0.3, -0.2)])))
    aspect = draw(st.sampled_from([1.0, 0.75]))
    if perspective:
        camera = durer.PerspectiveCamera(tuple(center), tuple(direction), tuple(up),
                                         fov_degrees=draw(st.floats(5, 150)), shift=shift, pixel_aspect=aspect)
    else:
        camera = durer.OrthographicCamera(tuple(center), tuple(direction), tuple(up), size=2.5 * scale,
                                          shift=shift, pixel_aspect=aspect,
                                          t_min=draw(st.sampled_from([-math.inf, 0.0])))
    width, height = draw(st.integers(1, 40)), draw(st.integers(1, 40))
    region = None
    if draw(st.booleans()):
        x, y = draw(st.integers(0, width - 1)), draw(st.integers(0, height - 1))
        region = (x, y, draw(st.integers(1, width - x)), draw(st.integers(1, height - y)))
    precision = draw(st.sampled_from(["float", "double"]))
    return cloud(rng, n, scale, offset, radius), camera, width, height, precision, region




def check(case: tuple[Any, ...]) -> None:
    """One case of view_cases(): raises AssertionError where the render and the cast differ."""
    scene, camera, width, height, precision, region = case
    assert_render_matches_cast(scene, camera, width, height, precision, region)


def fuzz(cfg: Any, seed: int | None = None) -> int:
    """Runs hypothesis with settings `cfg` (and `seed`, if given) over view_cases(); returns the
    cases run. On a difference hypothesis raises its shrunk case's AssertionError."""
    import hypothesis

    ran = 0

    @cfg
    @hypothesis.given(view_cases())
    def one(case: tuple[Any, ...]) -> None:
        nonlocal ran
        ran += 1
        check(case)

    if seed is not None:
        one = hypothesis.seed(seed)(one)
    one()
    return ran
