"""Random cases for the views of the spheres (cpp/include/durer/accel/SphereView.h): sphere clouds
at scales from 1e-3 to 1e4 and offsets to 1e6, seen by orthographic and perspective cameras from
inside and outside, at odd image sizes and regions, in both precisions; a render's camera rays must
find exactly what a cast of the same rays finds (through a lens: what a walk of a hierarchy finds),
and its shadow rays toward a sun or a point light
(through the light's view) what a brute force over every sphere finds
(tests/core/test_sphere_view.py runs a fixed number, bench/fuzz_traversal.py --views as many as time
allows, docs/reliability.md)."""

from __future__ import annotations

import math
from typing import Any

import durer
import numpy as np
from hypothesis import strategies as st

PASSES = ("depth", "normal", "object_id")


def assert_render_matches_cast(scene, camera, width, height, precision, region=None, spheres=None):
    """The render's camera rays find what a cast of the same rays finds: the object, its t (the
    depth) and its normal, bit for bit. Given the scene's `spheres` (centres, radii; object i is
    sphere i), a pixel where the two found different spheres passes if the ray meets both at the same
    t, bit for bit (an exact tie, which the search order decides, as in the traversal fuzz)."""
    res = durer.render(scene, camera, width=width, height=height, spp=1, passes=PASSES, precision=precision,
                       region=region, threads=2)
    origins, directions = camera.rays(width, height, precision)
    if region is not None:
        x, y, w, h = region
        origins, directions = origins[y:y + h, x:x + w], directions[y:y + h, x:x + w]
    shape = origins.shape[:2]
    cast = durer.cast(scene, origins.reshape(-1, 3), directions.reshape(-1, 3), t_min=camera.t_min,
                      t_max=camera.t_max, precision=precision, threads=1)
    cast_ids = cast.object_id.reshape(shape)
    tie = _exact_ties(spheres, origins.reshape(-1, 3), directions.reshape(-1, 3), camera, precision,
                      res.object_id.reshape(-1), cast.object_id, cast.t).reshape(shape)
    np.testing.assert_array_equal(res.object_id[~tie], cast_ids[~tie])
    hit = cast_ids >= 0
    np.testing.assert_array_equal(res.depth[hit], cast.t.reshape(shape)[hit].astype(np.float32))
    np.testing.assert_array_equal(res.normal[hit & ~tie], cast.normal.reshape(*shape, 3)[hit & ~tie].astype(np.float32))
    return res, hit


def _exact_ties(spheres, origins, directions, camera, precision, ids, cast_ids, cast_t):
    """For each ray, whether the render's object `ids` and the cast's `cast_ids` differ but are both
    spheres that the ray, cast against each alone, meets at cast_t bit for bit."""
    tie = np.zeros(len(ids), bool)
    if spheres is None:
        return tie
    centers, radii, *one_sided = spheres  # (centres, radii[, one_sided])
    for j in np.flatnonzero((ids != cast_ids) & (ids >= 0) & (cast_ids >= 0)):
        if max(ids[j], cast_ids[j]) >= len(radii):
            continue  # not a sphere
        alone = []
        for sphere in (ids[j], cast_ids[j]):
            one = durer.Scene()
            one.add_spheres(centers[sphere:sphere + 1], radii[sphere:sphere + 1], one_sided=bool(one_sided and one_sided[0]))
            alone.append(durer.cast(one, origins[j:j + 1], directions[j:j + 1], t_min=camera.t_min,
                                    t_max=camera.t_max, precision=precision).t[0])
        tie[j] = alone[0] == alone[1] == cast_t[j]
    return tie


def cloud_spheres(rng, n, scale, offset, radius):
    """n sphere centres and radii: uniform in a cube of half-side `scale` about `offset`."""
    centers = offset + scale * rng.uniform(-1, 1, (n, 3))
    radii = radius * scale * rng.uniform(0.2, 1.0, n)
    return centers, radii


def cloud(rng, n, scale, offset, radius):
    return scene_of(*cloud_spheres(rng, n, scale, offset, radius))


def scene_of(centers, radii, one_sided=False):
    scene = durer.Scene()
    material = scene.add_material(diffuse=(0.5, 0.5, 0.5))
    scene.add_spheres(centers, radii, material=material, one_sided=one_sided)
    return scene


@st.composite
def view_cases(draw):
    n = draw(st.one_of(st.integers(1, 15), st.integers(16, 400)))  # a camera's view serves from one sphere
    return _cloud_case(draw, n, (1, 40))


@st.composite
def lens_cases(draw):
    """Sphere clouds as view_cases() draws them, denser (200 to 3,000 spheres) and in larger images,
    seen through a lens (depth of field) focused before, in or beyond the cloud, any blades, turn and
    ratio, its aperture chosen for a mean blur of 0.01 to 4 pixels: mostly through the camera's view
    (which serves a lens up to 3), sometimes past it."""
    return _cloud_case(draw, draw(st.integers(200, 3000)), (16, 64), lens=True)


def _cloud_case(draw, n: int, sides: tuple[int, int], lens: bool = False):
    """n spheres in a cloud at scales 1e-3 to 1e4 and offsets to 1e6, a camera among them or outside
    (with a lens if asked), an image of `sides` pixels a side, perhaps a region, a precision, sidedness."""
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
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
    width, height = draw(st.integers(*sides)), draw(st.integers(*sides))
    fov = draw(st.floats(5, 150))
    spheres = cloud_spheres(rng, n, scale, offset, radius)
    common = dict(shift=shift, pixel_aspect=aspect)
    if lens:
        focus = (float(np.linalg.norm(offset - center)) + scale) * 10.0 ** draw(st.floats(-1.5, 1))
        # A pixel's width (at unit distance, or in world units) and each sphere's shift per unit of
        # aperture (the lens's blur, Camera::lensBlur, at the sphere's centre).
        extent = 2 * math.tan(math.radians(fov / 2)) if perspective else 2.5 * scale
        pixel = extent / max(width, height * aspect) * min(1.0, aspect)
        depth = (spheres[0] - center) @ direction
        shift_of = (np.where(depth - spheres[1] > 0, np.abs(1 / np.maximum(depth, 1e-300) - 1 / focus), 0.0)
                    if perspective else np.abs(1 - depth / focus))
        blur = 10.0 ** draw(st.floats(-2, 0.6))
        aperture = blur * pixel / max(float(np.mean(shift_of)), 1e-300)
        common.update(aperture_radius=min(aperture, 1e3 * scale), focus_distance=focus,
                      aperture_blades=draw(st.sampled_from([0, 3, 5, 8])),
                      aperture_rotation=draw(st.floats(0, 2 * math.pi)),
                      aperture_ratio=draw(st.sampled_from([1.0, 0.5, 2.0])))
    if perspective:
        camera = durer.PerspectiveCamera(tuple(center), tuple(direction), tuple(up), fov_degrees=fov, **common)
    else:
        camera = durer.OrthographicCamera(tuple(center), tuple(direction), tuple(up), size=2.5 * scale,
                                          t_min=draw(st.sampled_from([-math.inf, 0.0])), **common)
    region = None
    if draw(st.booleans()):
        x, y = draw(st.integers(0, width - 1)), draw(st.integers(0, height - 1))
        region = (x, y, draw(st.integers(1, width - x)), draw(st.integers(1, height - y)))
    precision = draw(st.sampled_from(["float", "double"]))
    # One-sided (a point cloud's): an eye among them passes the insides of those it starts in.
    one_sided = draw(st.booleans())
    return scene_of(*spheres, one_sided), (*spheres, one_sided), camera, width, height, precision, region


@st.composite
def sun_cases(draw):
    """Spheres resting over a ground plane, lit by a sun or a point light with shadows (their shadow
    rays search the light's view: the sun's image along it, the point light's six perspective faces
    around it), at scales from 1e-2 to 1e3 and offsets to 1e3 scales, seen from above. The point light
    hangs above the spheres, among them, or at a corner of their box (on the edges of its faces)."""
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    n = draw(st.integers(16, 400))
    scale = 10.0 ** draw(st.floats(-2, 3))
    offset = scale * 10.0 ** draw(st.floats(-1, 3)) * rng.normal(size=3) if draw(st.booleans()) else np.zeros(3)
    radius = 10.0 ** draw(st.floats(-1.7, -0.6))
    scene = durer.Scene()
    white = scene.add_material(diffuse=(1.0, 1.0, 1.0))
    centers = offset + scale * np.column_stack([rng.uniform(-1, 1, n), rng.uniform(0.0, 0.5, n), rng.uniform(-1, 1, n)])
    radii = scale * radius * rng.uniform(0.3, 1.0, n)
    scene.add_spheres(centers, radii, material=white)
    scene.add_plane((0, 1, 0), float(offset[1]), material=white)
    where = draw(st.sampled_from(["sun", "above", "among", "corner"]))
    if where == "sun":
        sun = rng.normal(size=3)
        sun[1] = -abs(sun[1]) - 0.05  # from above the plane
        scene.add_directional_light(tuple(sun), (1, 1, 1), shadows=True)
        light = ("sun", sun / np.linalg.norm(sun))
    else:
        at = {"above": [rng.uniform(-1, 1), rng.uniform(0.6, 2.0), rng.uniform(-1, 1)],
              "among": [rng.uniform(-0.8, 0.8), rng.uniform(0.05, 0.45), rng.uniform(-0.8, 0.8)],
              "corner": [1.0, 0.5, -1.0]}[where]
        position = offset + scale * np.asarray(at)
        scene.add_point_light(tuple(position), (1, 1, 1), shadows=True)
        light = ("point", position)
    scene.ambient = (0.0, 0.0, 0.0)
    eye = offset + scale * np.array([rng.uniform(-0.5, 0.5), 3.0, rng.uniform(-0.5, 0.5)])
    look = (offset - eye) / np.linalg.norm(offset - eye)
    if draw(st.booleans()):
        camera = durer.PerspectiveCamera(tuple(eye), tuple(look), (0, 0, -1), fov_degrees=draw(st.floats(20, 70)))
    else:
        camera = durer.OrthographicCamera(tuple(eye), tuple(look), (0, 0, -1), size=2.4 * scale)
    size = draw(st.integers(8, 48))
    precision = draw(st.sampled_from(["float", "double"]))
    return scene, centers, radii, light, camera, size, precision


def check_sun(case: tuple[Any, ...]) -> None:
    """One case of sun_cases(): a pixel is lit exactly where a brute force over every sphere finds
    nothing between its hit point and the light. Pixels the two may round either way are set aside:
    shadow rays grazing a sphere or starting on another, surfaces turned edge-on to the light, a
    sphere touching a point light (within the precision's rounding of the scene's coordinates)."""
    scene, centers, radii, (kind, light), camera, size, precision = case
    res = durer.render(scene, camera, width=size, height=size, passes=("color", "object_id"), precision=precision,
                       threads=2)
    origins, directions = camera.rays(size, size, precision)
    cast = durer.cast(scene, origins.reshape(-1, 3), directions.reshape(-1, 3), t_min=camera.t_min,
                      precision=precision, threads=1)
    tie = _exact_ties((centers, radii), origins.reshape(-1, 3), directions.reshape(-1, 3), camera, precision,
                      res.object_id.reshape(-1), cast.object_id, cast.t)
    np.testing.assert_array_equal(res.object_id.reshape(-1)[~tie], cast.object_id[~tie])
    hit = (cast.object_id >= 0) & ~tie  # a tie's render shades the other sphere
    if not hit.any():
        return
    points = origins.reshape(-1, 3)[hit].astype(float) + cast.t[hit, None] * directions.reshape(-1, 3)[hit]
    to_light = -np.asarray(light, float) if kind == "sun" else np.asarray(light, float) - points
    epsilon = float(np.finfo(np.float32 if precision == "float" else np.float64).eps)
    # How far the scene's rounding may move a shadow ray or a surface, relative to its size.
    rounding = 1e4 * epsilon * (np.abs(points).max() + np.abs(centers).max() + radii.max()) / radii.min()
    unit = to_light / np.linalg.norm(to_light, axis=-1, keepdims=True)
    cosine = np.einsum("ij,ij->i", cast.normal[hit], np.broadcast_to(unit, points.shape))
    blocked, unclear = brute_force_shadows(points, to_light, centers, radii, cast.object_id[hit], 1e-4 + rounding,
                                           segment=kind != "sun")
    unclear |= np.abs(cosine) < 1e-3 + rounding
    expected_lit = (cosine > 0) & ~blocked
    lit = res.color.reshape(-1, 4)[hit, :3].sum(axis=1) > 0
    clear = ~unclear
    np.testing.assert_array_equal(lit[clear], expected_lit[clear])


def brute_force_shadows(points, to_light, centers, radii, own_ids, tolerance=1e-4, chunk=500, segment=False):
    """Whether each point's ray toward the light meets a sphere other than its own past the point (its
    far root beyond it), and whether that is unclear (within `tolerance` radii: the ray grazes one,
    starts on another, or, toward a point light, one reaches the light). `to_light`: the unit
    direction toward a sun, or (segment) each point's vector to a point light, the ray ending there."""
    blocked = np.zeros(len(points), bool)
    unclear = np.zeros(len(points), bool)
    ids = np.arange(len(radii))
    to_light = np.broadcast_to(np.asarray(to_light, float), points.shape)
    for start in range(0, len(points), chunk):
        p, d = points[start:start + chunk], to_light[start:start + chunk]
        length = np.linalg.norm(d, axis=1)[:, None]
        f = p[:, None, :] - centers[None, :, :]
        b = np.einsum("ijk,ik->ij", f, d) / length  # along the unit direction: t in distance
        ff = np.einsum("ijk,ijk->ij", f, f)
        disc = b * b - (ff - radii ** 2)
        root = np.sqrt(np.maximum(disc, 0))
        far, near = -b + root, -b - root
        others = own_ids[start:start + chunk, None] != ids[None, :]
        line = np.sqrt(np.maximum(ff - b * b, 0))
        meets = (disc > 0) & (far > 1e-9 * radii) & others
        if segment:
            meets &= near < length
        blocked[start:start + chunk] = meets.any(axis=1)
        edge = (np.abs(line - radii) < tolerance * radii) | ((disc > 0) & (np.abs(far) < 1e-2 * tolerance * radii))
        if segment:
            edge |= (disc > 0) & (np.abs(near - length) < tolerance * radii)
        unclear[start:start + chunk] = (edge & others).any(axis=1)
    return blocked, unclear


def assert_lens_render_matches_hierarchy(scene, spheres, camera, width, height, precision, region=None):
    """A lens's camera rays find through the camera's view (its footprints widened by the lens) what
    they find walking a hierarchy: the same spheres, halved, in a group scaled by 2 (exact in binary:
    the rays in its space are the world's halved, and every t bit for bit the same), which no view
    serves. Depth bit for bit, object ids but at exact ties (_lens_ties)."""
    centers, radii, one_sided = spheres
    halved = durer.Scene()
    material = halved.add_material(diffuse=(0.5, 0.5, 0.5))
    halved.add_spheres(centers / 2, radii / 2, material=material, transform=np.hstack([2 * np.eye(3), np.zeros((3, 1))]),
                       one_sided=one_sided)
    kwargs = dict(spp=4, sampler="random", passes=("depth", "object_id"), precision=precision, region=region, threads=2)
    viewed = durer.render(scene, camera, width, height, **kwargs)
    walked = durer.render(halved, camera, width, height, **kwargs)
    np.testing.assert_array_equal(viewed.depth, walked.depth)
    tie = _lens_ties(spheres, camera, width, height, kwargs, viewed, walked)
    np.testing.assert_array_equal(viewed.object_id[~tie], walked.object_id[~tie])


def _lens_ties(spheres, camera, width, height, kwargs, viewed, walked):
    """Pixels where the two renders found different spheres that the pixel's samples, rendered
    against each sphere alone (the same samples: positions and seeds are the image's), both meet at
    the pixel's depth bit for bit: its nearest samples meet the two at the same t, an exact tie that
    each search's order decides (as _exact_ties does for one ray)."""
    centers, radii, one_sided = spheres
    tie = np.zeros(viewed.object_id.shape, bool)
    for y, x in zip(*np.nonzero(viewed.object_id != walked.object_id)):
        ids = (viewed.object_id[y, x], walked.object_id[y, x])
        if min(ids) < 0:
            continue
        alone = [durer.render(scene_of(centers[k:k + 1], radii[k:k + 1], one_sided), camera, width, height,
                              **kwargs).depth[y, x] for k in ids]
        tie[y, x] = alone[0] == alone[1] == viewed.depth[y, x]
    return tie


def check_lens(case: tuple[Any, ...]) -> None:
    """One case of lens_cases(): raises AssertionError where the view and the hierarchy differ."""
    assert_lens_render_matches_hierarchy(*case)


def check(case: tuple[Any, ...]) -> None:
    """One case of view_cases(): raises AssertionError where the render and the cast differ."""
    scene, spheres, camera, width, height, precision, region = case
    assert_render_matches_cast(scene, camera, width, height, precision, region, spheres)


def fuzz(cfg: Any, seed: int | None = None) -> int:
    """Runs hypothesis with settings `cfg` (and `seed`, if given) over view_cases(), then
    sun_cases(); returns the cases run. On a difference hypothesis raises its shrunk case's AssertionError."""
    import hypothesis

    ran = 0

    for cases, checker in ((view_cases(), check), (lens_cases(), check_lens), (sun_cases(), check_sun)):
        @cfg
        @hypothesis.given(cases)
        def one(case: tuple[Any, ...]) -> None:
            nonlocal ran
            ran += 1
            checker(case)  # noqa: B023 (called within its own iteration)

        (hypothesis.seed(seed)(one) if seed is not None else one)()
    return ran
