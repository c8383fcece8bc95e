"""The camera's view of the spheres (cpp/include/durer/accel/SphereView.h): camera rays search the
spheres listed under their part of the image, nearest first, instead of walking the hierarchy. It
must find exactly what a cast of the same rays finds (the hierarchy, itself fuzzed against a brute
force in test_traversal_fuzz.py): same t bit for bit, same sphere (or, in the fuzz, one tied at
that t), same normal, for any camera, inside or outside the spheres, near or far from the origin,
in both precisions, for regions, and after the spheres move."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import durer
import numpy as np
import pytest
from helpers.view_fuzz import (PASSES, assert_render_matches_cast, brute_force_shadows, check, check_lens, check_sun,
                               cloud, lens_cases, scene_of, sun_cases, view_cases)
from hypothesis import HealthCheck, given, settings


@settings(max_examples=150, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(view_cases())
def test_camera_rays_find_what_a_cast_finds(case):
    check(case)


@settings(max_examples=100, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(lens_cases())
def test_lens_rays_find_through_the_view_what_a_hierarchy_finds(case):
    check_lens(case)


def test_lens_check_sets_aside_an_exact_tie_between_overlapping_spheres():
    """A case the view fuzz failed on (bench/fuzz_sanitized.sh, 2026-12-04): 352 spheres, a lens; one
    pixel's nearest sample meets two overlapping spheres (47 and 214) at the same float t, bit for
    bit, and the view's order and the hierarchy's give it to different ones. The check passes it as
    a tie: each sphere alone reaches that pixel's depth."""
    data = np.load(Path(__file__).parents[1] / "fuzz_findings" / "view" / "lens-tie.npz")
    centers, radii = data["centers"], data["radii"]
    camera = durer.OrthographicCamera(
        tuple(data["center"]), tuple(data["direction"]), tuple(data["up"]), size=float(data["size"]), t_min=-math.inf,
        aperture_radius=float(data["aperture_radius"]), focus_distance=float(data["focus_distance"]),
        aperture_blades=int(data["aperture_blades"]), aperture_rotation=float(data["aperture_rotation"]),
        aperture_ratio=float(data["aperture_ratio"]))
    width, height = int(data["width"]), int(data["height"])
    check_lens((scene_of(centers, radii), (centers, radii, False), camera, width, height, "float", None))
    kwargs = dict(spp=4, sampler="random", passes=("depth",), precision="float", threads=2)
    depth = durer.render(scene_of(centers, radii), camera, width, height, **kwargs).depth[40, 3]
    for k in (47, 214):
        assert durer.render(scene_of(centers[k:k + 1], radii[k:k + 1]), camera, width, height, **kwargs).depth[40, 3] == depth


@pytest.mark.parametrize("precision", ["float", "double"])
def test_a_perspective_camera_searching_from_negative_t_sees_behind_its_eye(precision):
    # t_min < 0 runs each ray backwards from the eye too, where its image has no footprint: such a
    # camera's rays walk the hierarchy, and find the spheres behind the eye as a cast does.
    rng = np.random.default_rng(9)
    centers = np.vstack([rng.uniform(-3, 3, (2000, 3)) + (0, 0, -10), rng.uniform(-3, 3, (20, 3)) + (0, 0, 10)])
    radii = rng.uniform(0.05, 0.3, len(centers))
    camera = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), fov_degrees=50, t_min=-30.0)
    _, hit = assert_render_matches_cast(scene_of(centers, radii), camera, 48, 48, precision, spheres=(centers, radii))
    assert hit.mean() > 0.5


@pytest.mark.parametrize("precision", ["float", "double"])
def test_a_dense_cloud_seen_from_inside_and_outside(precision):
    """10,000 spheres filling a cube: perspective views from its centre (spheres all around the eye,
    some crossing the plane through it) and from outside, and an orthographic view that also sees
    the spheres behind its image plane (t_min = -inf)."""
    rng = np.random.default_rng(7)
    scene = cloud(rng, 10_000, 1.0, np.zeros(3), 0.04)
    cameras = [durer.PerspectiveCamera((0.01, -0.02, 0.03), (0.2, 0.1, -1), (0, 1, 0), fov_degrees=100),
               durer.PerspectiveCamera((0, 0, 4), (0, 0, -1), (0, 1, 0), fov_degrees=40),
               durer.OrthographicCamera((0, 0, 0), (1, 1, -1), (0, 1, 0), size=2.5)]
    for camera in cameras:
        _, hit = assert_render_matches_cast(scene, camera, 96, 64, precision)
        assert hit.mean() > 0.5


@pytest.mark.parametrize("precision", ["float", "double"])
def test_camera_rays_alone_need_no_hierarchy(precision):
    """A render of camera rays alone (no shadows, bounces or occlusion) prepares the spheres without
    their hierarchy, which a cast (or a render with other rays) then makes: the same image either way,
    bit for bit, moved spheres included."""
    rng = np.random.default_rng(23)
    centers = rng.uniform(-1, 1, (20_000, 3))

    def scene_of(at):
        made = durer.Scene()
        made.add_spheres(at, 0.02)
        return made

    scene = scene_of(centers)
    ids = np.arange(len(centers))
    camera = durer.PerspectiveCamera((0.2, 0.1, 3), (-0.05, -0.02, -1), (0, 1, 0), fov_degrees=45)

    def render():
        return durer.render(scene, camera, width=64, height=48, spp=2, passes=PASSES, precision=precision, threads=2)

    before = render()
    assert scene.hierarchy_counts["built"] == 1
    durer.cast(scene, [[0.0, 0.0, 5.0]], [[0.0, 0.0, -1.0]], precision=precision)
    assert scene.hierarchy_counts["built"] == 2  # made again, with the hierarchy
    after = render()
    assert scene.hierarchy_counts["built"] == 2  # which a render of camera rays uses as it is
    for name in PASSES:
        np.testing.assert_array_equal(getattr(before, name), getattr(after, name))
    assert (before.object_id >= 0).mean() > 0.5
    scene.move_spheres(ids, centers + 0.01)
    moved = render()
    fresh = scene_of(centers + 0.01)
    np.testing.assert_array_equal(moved.depth, durer.render(fresh, camera, width=64, height=48, spp=2, passes=PASSES,
                                                            precision=precision, threads=2).depth)
    # Moved while prepared without the hierarchy, then a cast: made anew with it, and nothing left
    # to refit for the next call.
    durer.render(fresh, camera, width=8, height=8, precision=precision)
    fresh.move_spheres(ids, centers)
    origins, directions = (a.reshape(-1, 3) for a in camera.rays(64, 48, precision))
    expected = durer.cast(scene_of(centers), origins, directions, precision=precision)
    for _ in range(2):
        cast = durer.cast(fresh, origins, directions, precision=precision)
        np.testing.assert_array_equal(cast.t, expected.t)
        np.testing.assert_array_equal(cast.object_id, expected.object_id)
    assert (fresh.hierarchy_counts["built"], fresh.hierarchy_counts["refitted"]) == (2, 0)


@pytest.mark.parametrize("precision", ["float", "double"])
def test_deep_cells_keep_their_spheres_nearest_first(precision):
    """Thousands of spheres behind each 8x8 cell (a dense column seen end on), in layers of equal
    depth (ties), at depths of every order of magnitude (lower bounds differing in every byte): a
    cell's list is sorted by bytes from 64 entries on, and the search stops at the first sphere
    beyond every ray's hit, so a misplaced entry shows as a hit missed or one too far."""
    rng = np.random.default_rng(17)
    layers = np.repeat(np.concatenate([-np.geomspace(1e-3, 50.0, 60), np.geomspace(1e-3, 50.0, 60)]), 60)
    centers = np.column_stack([rng.uniform(-0.1, 0.1, layers.size), rng.uniform(-0.1, 0.1, layers.size), layers])
    scene = durer.Scene()
    scene.add_spheres(centers, rng.choice([0.004, 0.01, 0.03], layers.size))
    camera = durer.OrthographicCamera((0, 0, 60), (0, 0, -1), (0, 1, 0), size=0.22)
    _, hit = assert_render_matches_cast(scene, camera, 32, 24, precision)
    assert hit.mean() > 0.5
    # The same through the far side (t_min = -inf: spheres behind the image plane, negative bounds).
    behind = durer.OrthographicCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), size=0.22, t_min=-np.inf)
    assert_render_matches_cast(scene, behind, 32, 24, precision)


@pytest.mark.parametrize("precision", ["float", "double"])
def test_spheres_a_pixel_across_or_less(precision):
    """50,000 spheres of 0.2 to 1.5 pixels across: each lists only the pixel rows it covers, and a
    ray must still meet every sphere over its own pixel, also with several samples per pixel."""
    rng = np.random.default_rng(11)
    scene = cloud(rng, 50_000, 1.0, np.zeros(3), 0.006)
    for camera in (durer.OrthographicCamera((0, 0, 3), (0.1, -0.2, -1), (0, 1, 0), size=2.2),
                   durer.PerspectiveCamera((0.3, 0.2, 3), (-0.1, -0.05, -1), (0, 1, 0), fov_degrees=45)):
        _, hit = assert_render_matches_cast(scene, camera, 200, 150, precision)
        assert 0.2 < hit.mean() < 0.99
    assert np.all(_spread_samples_agree(rng, 50_000, 0.006, precision))


def _spread_samples_agree(rng, n, radius, precision):
    """Renders with samples spread over each pixel equal, pass for pass, those of the same spheres
    traced without the view: halved inside a group scaled by 2 (exact in binary floating point, so the
    rays in the group's space meet its spheres at the same t bit for bit), which the view never serves."""
    centers = rng.uniform(-1, 1, (n, 3))
    radii = radius * rng.uniform(0.2, 1.0, n)
    direct, scaled = durer.Scene(), durer.Scene()
    direct.add_spheres(centers, radii)
    scaled.add_spheres(centers / 2, radii / 2, transform=np.diag([2.0, 2.0, 2.0, 1.0]))
    camera = durer.PerspectiveCamera((0.3, 0.2, 3), (-0.1, -0.05, -1), (0, 1, 0), fov_degrees=45)
    agree = []
    for sampler in ("stratified", "sobol", "adaptive"):
        a, b = (durer.render(s, camera, width=60, height=40, spp=16, sampler=sampler, passes=("depth", "object_id"),
                             precision=precision, threads=2) for s in (direct, scaled))
        # Adaptive sampling also asks the view where silhouettes cross pixels (more samples there):
        # the pixels that took as many samples in both.
        same = a.samples == b.samples if sampler == "adaptive" else np.ones(a.depth.shape, bool)
        agree += [same.mean() > 0.5, np.array_equal(a.depth[same], b.depth[same]),
                  np.array_equal(a.object_id[same], b.object_id[same])]
    return agree


def test_a_region_is_the_whole_render_cut_out():
    rng = np.random.default_rng(3)
    scene = cloud(rng, 3000, 1.0, np.zeros(3), 0.05)
    camera = durer.PerspectiveCamera((0, 0, 3), (0, 0, -1), (0, 1, 0), fov_degrees=50)
    whole = durer.render(scene, camera, width=70, height=50, spp=4, passes=PASSES + ("color",), threads=2)
    part = durer.render(scene, camera, width=70, height=50, spp=4, passes=PASSES + ("color",), threads=2,
                        region=(13, 7, 29, 31))
    for name in PASSES + ("color",):
        np.testing.assert_array_equal(getattr(part, name), getattr(whole, name)[7:38, 13:42])


def test_moved_spheres_are_seen_where_they_moved_to():
    """The view is kept for the next render of the same camera: moving the spheres must drop it."""
    rng = np.random.default_rng(5)
    centers = rng.uniform(-1, 1, (500, 3))
    scene = durer.Scene()
    ids = scene.add_spheres(centers, 0.08)
    camera = durer.OrthographicCamera((0, 0, 3), (0, 0, -1), (0, 1, 0), size=2.5)
    first = durer.render(scene, camera, width=48, height=48, passes=PASSES)
    moved = centers + np.array([0.3, -0.2, 0.1])
    scene.move_spheres(ids, moved)
    again = durer.render(scene, camera, width=48, height=48, passes=PASSES)
    fresh = durer.Scene()
    fresh.add_spheres(moved, 0.08)
    expected = durer.render(fresh, camera, width=48, height=48, passes=PASSES)
    assert not np.array_equal(first.depth, again.depth)
    for name in PASSES:
        np.testing.assert_array_equal(getattr(again, name), getattr(expected, name))
    assert_render_matches_cast(scene, camera, 48, 48, "double")


def test_camera_rays_test_the_front_spheres_only():
    """Forty layers of spheres, each hiding the ones behind it: a camera ray tests the spheres over its
    tile in the first layer or two, not the thousands behind (the ray-sphere tests counted)."""
    xs = np.arange(-1, 1, 0.1) + 0.05
    layer = np.array([(x, y) for x in xs for y in xs])  # 400 spheres of radius 0.08, overlapping
    centers = np.concatenate([np.column_stack([layer, np.full(len(layer), -0.2 * z)]) for z in range(40)])
    scene = durer.Scene()
    scene.add_spheres(centers, 0.08)
    camera = durer.OrthographicCamera((0, 0, 1), (0, 0, -1), (0, 1, 0), size=1.6)
    res = durer.render(scene, camera, width=64, height=64, passes=("depth",))
    assert np.all(np.isclose(res.depth, 1.0, atol=0.09))  # every pixel sees the first layer
    assert res.stats["intersection_tests"] / res.stats["rays"] < 32  # of 16,000 spheres


def _sun_scene(rng, n, direction=None, position=None, ground=0.0):
    """Spheres over a ground plane at height `ground`, lit with shadows by a sun along `direction`
    and/or a point light at `position`."""
    scene = durer.Scene()
    white = scene.add_material(diffuse=(1.0, 1.0, 1.0))
    centers = np.column_stack([rng.uniform(-1, 1, n), rng.uniform(0.0, 0.4, n), rng.uniform(-1, 1, n)])
    radii = rng.uniform(0.01, 0.04, n)
    scene.add_spheres(centers, radii, material=white)
    scene.add_plane((0, 1, 0), ground, material=white)
    if direction is not None:
        scene.add_directional_light(direction, (1, 1, 1), shadows=True)
    if position is not None:
        scene.add_point_light(position, (1, 1, 1), shadows=True)
    scene.ambient = (0.0, 0.0, 0.0)
    return scene, centers, radii


LIGHTS = [("sun", (1, -2, -1)), ("sun", (0.05, -1, 0.02)), ("sun", (-3, -1, 0.5)),  # direction
          ("point", (0.2, 1.5, -0.1)), ("point", (0.05, 0.2, 0.03)), ("point", (1.2, 1.2, 1.2))]  # position


@pytest.mark.parametrize("precision", ["float", "double"])
@pytest.mark.parametrize("light", LIGHTS, ids=lambda light: f"{light[0]}{light[1]}")
def test_shadows_are_where_a_brute_force_puts_them(precision, light):
    """Shadow rays toward a sun go through the sun's own view of the spheres, toward a point light
    through its six faces' views: a pixel is lit exactly where a brute force over every sphere finds
    nothing between its hit point and the light (pixels whose shadow ray grazes a sphere, or whose
    surface turns from the light, set aside: the two may round them either way); the point light
    above the spheres, among them, or on the edges of its faces (a cube's diagonal toward them)."""
    kind, where = light
    rng = np.random.default_rng(21 if kind == "sun" else 22)
    scene, centers, radii = _sun_scene(rng, 1500, **{"direction" if kind == "sun" else "position": where})
    camera = durer.OrthographicCamera((0, 3, 3), (0, -1, -1), (0, 1, 0), size=2.4)
    size = 96
    res = durer.render(scene, camera, width=size, height=size, passes=("color", "object_id"), precision=precision,
                       threads=2)
    assert scene.hierarchy_counts["built"] == 1
    origins, directions = camera.rays(size, size)
    cast = durer.cast(scene, origins.reshape(-1, 3), directions.reshape(-1, 3), t_min=camera.t_min)
    hit = cast.object_id >= 0
    np.testing.assert_array_equal(res.object_id.reshape(-1), cast.object_id)
    points = origins.reshape(-1, 3)[hit] + cast.t[hit, None] * directions.reshape(-1, 3)[hit]
    to_light = -np.asarray(where, float) if kind == "sun" else np.asarray(where, float) - points
    unit = np.broadcast_to(to_light / np.linalg.norm(to_light, axis=-1, keepdims=True), points.shape)
    cosine = np.einsum("ij,ij->i", cast.normal[hit], unit)
    blocked, unclear = brute_force_shadows(points, to_light if kind == "point" else unit[0], centers, radii,
                                           cast.object_id[hit], segment=kind == "point")
    unclear |= np.abs(cosine) < 1e-4
    expected_lit = (cosine > 0) & ~blocked
    lit = res.color.reshape(-1, 4)[hit, :3].sum(axis=1) > 0
    clear = ~unclear
    assert clear.mean() > 0.99
    assert 0.1 < expected_lit[clear].mean() < 0.9  # both lit and shadowed pixels
    np.testing.assert_array_equal(lit[clear], expected_lit[clear])


@pytest.mark.parametrize("precision", ["float", "double"])
def test_sun_shadows_cast_on_ground_far_below_the_spheres(precision):
    """A sun's shadow rays may start far beyond the spheres its view was made over: here on a ground
    plane 300 units below them, the spheres' shadows seen from above. A pixel is lit exactly where a
    brute force finds nothing between its hit point and the sun (pixels within the precision's
    rounding of the far points of a silhouette set aside)."""
    rng = np.random.default_rng(23)
    sun = np.array([0.3, -1.0, 0.2])
    depth = 300.0
    scene, centers, radii = _sun_scene(rng, 1500, direction=tuple(sun), ground=-depth)
    below = centers.mean(axis=0) + (depth + centers[:, 1].mean()) * sun / -sun[1]
    _assert_far_ground_shadows(scene, centers, radii, below, depth, precision, lambda points: -sun, height=3,
                               min_clear=0.8)


@pytest.mark.parametrize("precision", ["float", "double"])
def test_point_light_shadows_cast_on_ground_far_below_the_spheres(precision):
    """A point light's shadow rays from far beyond its spheres, which lie near it: seen from the
    light, such a ray passes a sphere off its place on the light's image by its direction's rounding
    over its whole way, an angle 500 times its own at a sphere 0.6 from the light (SphereView's
    drift, for which each disk grows and each core shrinks; the real drift lies far below that bound).
    The ground 300 units below a light just above the spheres, seen where the shadows of some of them
    fall; checked as the sun's."""
    rng = np.random.default_rng(24)
    light = np.array([0.0, 0.6, 0.0])
    depth = 300.0
    scene, centers, radii = _sun_scene(rng, 1500, position=tuple(light), ground=-depth)
    _assert_far_ground_shadows(scene, centers, radii, np.array([100.0, -depth, 0.0]), depth, precision,
                               lambda points: light - points, height=30, min_clear=0.7,
                               segment=True)


def _assert_far_ground_shadows(scene, centers, radii, spot, depth, precision, to_light, height, min_clear,
                               segment=False):
    """Seen from `height` above `spot` on the ground `depth` below the spheres: a pixel is lit exactly
    where a brute force finds nothing between its hit point and the light (`to_light(points)`: toward
    it), pixels within the precision's rounding of the far points of a silhouette set aside."""
    camera = durer.PerspectiveCamera(tuple(spot + (0, height, 0)), (0, -1, 0), (0, 0, 1), fov_degrees=45)
    size = 96
    res = durer.render(scene, camera, width=size, height=size, passes=("color", "object_id"), precision=precision,
                       threads=2)
    origins, directions = camera.rays(size, size)
    cast = durer.cast(scene, origins.reshape(-1, 3), directions.reshape(-1, 3), precision=precision)
    assert (cast.object_id == len(radii)).all()  # the ground everywhere
    points = origins.reshape(-1, 3) + cast.t[:, None] * directions.reshape(-1, 3)
    toward = to_light(points)
    if not segment:
        toward = toward / np.linalg.norm(toward)
    epsilon = float(np.finfo(np.float32 if precision == "float" else np.float64).eps)
    tolerance = 1e-4 + 16 * epsilon * depth / radii.min()  # the points' and the rays' rounding, in radii
    blocked, unclear = brute_force_shadows(points, toward, centers, radii, cast.object_id, tolerance, segment=segment)
    lit = res.color.reshape(-1, 4)[:, :3].sum(axis=1) > 0
    clear = ~unclear
    assert clear.mean() > min_clear
    assert 0.1 < blocked[clear].mean() < 0.9  # both lit and shadowed pixels
    np.testing.assert_array_equal(lit[clear], ~blocked[clear])


@pytest.mark.parametrize("precision", ["float", "double"])
def test_shadows_toward_suns_and_point_lights_need_no_hierarchy(precision):
    """Shadow rays toward a sun or a point light search the light's view, so a render whose only
    other rays they are prepares the spheres without their hierarchy, as a render of camera rays
    alone does; a light's view refused (a few spheres far larger than the rest would fill too many of
    its cells) needs it. The same image with the hierarchy, bit for bit."""
    rng = np.random.default_rng(31)
    camera = durer.PerspectiveCamera((0, 2, 3), (0, -0.6, -1), (0, 1, 0), fov_degrees=50)

    def render(of):
        return durer.render(of, camera, width=64, height=48, passes=("color", "depth"), precision=precision,
                            threads=2)

    def cast_one(of):
        durer.cast(of, [[0.0, 5.0, 0.0]], [[0.0, -1.0, 0.0]], precision=precision)

    sunlit, _, _ = _sun_scene(rng, 3000, (1, -2, -1))
    pointed, _, _ = _sun_scene(np.random.default_rng(31), 3000, (1, -2, -1), (0.3, 0.9, -0.2))
    for scene in (sunlit, pointed):
        before = render(scene)
        assert scene.hierarchy_counts["built"] == 1
        cast_one(scene)
        assert scene.hierarchy_counts["built"] == 2  # prepared again, now with the hierarchy
        after = render(scene)
        np.testing.assert_array_equal(before.color, after.color)
        np.testing.assert_array_equal(before.depth, after.depth)
        lit = before.color[..., :3].sum(axis=-1) > 0
        assert 0.1 < lit[before.depth < np.inf].mean() < 0.9  # lit and shadowed pixels both

    uneven, _, _ = _sun_scene(np.random.default_rng(31), 3000, (1, -2, -1))
    # Ten spheres of radius 100 far under the ground: the sun's cells, four mean radii across, are
    # small for them, and they would fill too many.
    uneven.add_spheres(np.column_stack([rng.uniform(-5, 5, 10), np.full(10, -300.0), rng.uniform(-5, 5, 10)]), 100.0)
    first = render(uneven)
    assert uneven.hierarchy_counts["built"] == 2  # the sun's view refused: prepared again, with it
    cast_one(uneven)
    assert uneven.hierarchy_counts["built"] == 2
    np.testing.assert_array_equal(first.color, render(uneven).color)


@pytest.mark.parametrize("precision", ["float", "double"])
@pytest.mark.parametrize("kind", ["point", "sun"])
def test_more_lights_than_views_walk_the_hierarchy(precision, kind):
    """Past three lights casting shadows (SphereSet::kMostLightViews), no light gets a view (each
    costs its making and ~30 bytes a sphere; one hierarchy serves them all): the first render
    prepares the spheres with their hierarchy at once, and each light's shadows are those a render of
    it alone, through its view (a sun's: the spheres' disks on it), finds."""
    places = {"point": [(0.3, 0.9, -0.2), (-0.8, 0.6, 0.4), (0.1, 1.5, 0.9), (0.9, 0.5, 0.8)],
              "sun": [(1, -2, -1), (0.05, -1, 0.02), (-3, -1, 0.5), (0.4, -0.7, 0.9)]}[kind]
    camera = durer.PerspectiveCamera((0, 2, 3), (0, -0.6, -1), (0, 1, 0), fov_degrees=50)

    def render(of):
        return durer.render(of, camera, width=64, height=48, passes="color", precision=precision, threads=2)

    def lit_by(place):
        return {"direction": place} if kind == "sun" else {"position": place}

    alone = []
    for place in places:
        scene, _, _ = _sun_scene(np.random.default_rng(31), 3000, **lit_by(place))
        alone.append(render(scene).color[..., :3])
        assert scene.hierarchy_counts["built"] == 1
        durer.cast(scene, [[0.0, 5.0, 0.0]], [[0.0, -1.0, 0.0]], precision=precision)
        assert scene.hierarchy_counts["built"] == 2  # rendered through the light's view, without it
    together, _, _ = _sun_scene(np.random.default_rng(31), 3000, **lit_by(places[0]))
    for place in places[1:]:
        if kind == "sun":
            together.add_directional_light(place, (1, 1, 1), shadows=True)
        else:
            together.add_point_light(place, (1, 1, 1), shadows=True)
    image = render(together).color[..., :3]
    assert together.hierarchy_counts["built"] == 1
    durer.cast(together, [[0.0, 5.0, 0.0]], [[0.0, -1.0, 0.0]], precision=precision)
    assert together.hierarchy_counts["built"] == 1  # prepared with it for the render
    np.testing.assert_allclose(image, sum(alone), rtol=1e-5, atol=1e-6)
    shadowed = [(light == 0).mean() for light in alone]
    assert all(0.05 < share < 0.95 for share in shadowed)


@settings(max_examples=40, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(sun_cases())
def test_sun_shadows_at_any_scale_find_what_a_brute_force_finds(case):
    check_sun(case)


def test_sun_views_with_other_lights_and_after_a_move():
    """Two suns and a point light, each with its view: the render equals the one of a fresh scene,
    also after the spheres move (every view of the old positions dropped)."""
    rng = np.random.default_rng(8)
    centers = rng.uniform(-1, 1, (800, 3))

    def build(points):
        scene = durer.Scene()
        ids = scene.add_spheres(points, 0.06)
        scene.add_directional_light((1, -2, -1), (0.5, 0.5, 0.5), shadows=True)
        scene.add_directional_light((-1, -1, 0.3), (0.3, 0.4, 0.5), shadows=True)
        scene.add_point_light((0, 3, 0), (2, 2, 2), shadows=True)
        return scene, ids

    camera = durer.PerspectiveCamera((0, 0, 4), (0, 0, -1), (0, 1, 0), fov_degrees=45)
    scene, ids = build(centers)
    before = durer.render(scene, camera, width=64, height=48, passes=("color",))
    again = durer.render(scene, camera, width=64, height=48, passes=("color",))
    np.testing.assert_array_equal(before.color, again.color)
    moved = centers * 0.9 + 0.05
    scene.move_spheres(ids, moved)
    after = durer.render(scene, camera, width=64, height=48, passes=("color",))
    fresh = durer.render(build(moved)[0], camera, width=64, height=48, passes=("color",))
    np.testing.assert_array_equal(after.color, fresh.color)
    assert not np.array_equal(before.color, after.color)


def test_two_spheres_tied_at_a_ray_are_either_sphere_at_the_same_depth():
    """Found by the view fuzz (a sun case, float): two spheres whose surfaces cross where a camera
    ray meets them, both at the same t bit for bit. The render (nearest first, through the camera's
    view) records one, the cast (in the spheres' order) the other: an exact tie, which either may
    win, as in the traversal fuzz. The fuzz's comparison accepts it given the spheres, and only then."""
    centers = np.array([[0.4414450096924656, -0.14444854798051576, -0.8655457671904427],
                        [0.37029998065428504, -0.17776438988746818, -0.8832917787163264]])
    radii = np.array([0.10896871159401635, 0.14594289582671727])
    scene = scene_of(centers, radii)
    scene.add_plane((0, 1, 0), -0.40986532321066005)
    camera = durer.OrthographicCamera((0.6912727608417593, 2.59013467678934, -0.9164723378891103),
                                      (0.0854163546594841, -0.9951789070061053, -0.048197400415568845), (0, 0, -1),
                                      size=2.4)
    origin, direction = (a.reshape(-1, 3)[730:731] for a in camera.rays(36, 36, "float"))
    alone = [durer.cast(scene_of(centers[i:i + 1], radii[i:i + 1]), origin, direction, precision="float").t[0]
             for i in range(2)]
    assert alone[0] == alone[1]
    res, _ = assert_render_matches_cast(scene, camera, 36, 36, "float", spheres=(centers, radii))
    cast = durer.cast(scene, origin, direction, precision="float")
    assert {int(res.object_id.reshape(-1)[730]), int(cast.object_id[0])} == {0, 1}
    assert res.depth.reshape(-1)[730] == np.float32(alone[0])
    with pytest.raises(AssertionError):
        assert_render_matches_cast(scene, camera, 36, 36, "float")


def ortho_rays(center, size, width, height, region):
    """The pixel-centre rays of an orthographic camera at `center` looking down -z (up +y) over a
    square `size` wide, for the pixels of `region` of a width x height image."""
    x, y, w, h = region
    px, py = np.meshgrid(np.arange(x, x + w) + 0.5, np.arange(y, y + h) + 0.5)
    origins = np.stack([center[0] + (px / width - 0.5) * size, center[1] + (0.5 - py / height) * size,
                        np.full(px.shape, center[2])], axis=-1)
    return origins, np.broadcast_to([0.0, 0.0, -1.0], origins.shape)


# A region of a huge image, rendered in a process of its own: its peak memory is the render's.
HUGE_REGION = """
import resource, sys, numpy as np, durer
side, x, y, w, h = (int(v) for v in sys.argv[1:6])
rng = np.random.default_rng(11)
centers = np.column_stack([rng.uniform(-0.01, 0.01, (400, 2)), rng.uniform(-1, 1, 400)])
scene = durer.Scene()
scene.add_spheres(centers, rng.uniform(1e-4, 4e-4, 400))  # 3-13 pixels
camera = durer.OrthographicCamera((0, 0, 3), (0, 0, -1), (0, 1, 0), size=2.0)
part = durer.render(scene, camera, side, side, region=(x, y, w, h), passes=("depth", "object_id"), threads=2)
np.save(sys.argv[6], np.stack([part.depth, part.object_id.astype(np.float32)]))
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024)
"""


def test_a_region_of_a_huge_image_sees_through_a_view_of_its_own(tmp_path):
    """A 65536 x 65536 image's view of the spheres would take ~0.6 GB whatever the region rendered
    (the whole image's cells): a region of an image that large sees through a view of its region,
    and finds what a cast of its rays finds."""
    camera = durer.OrthographicCamera((0, 0, 3), (0, 0, -1), (0, 1, 0), size=2.0)
    np.testing.assert_allclose(ortho_rays((0, 0, 3), 2.0, 40, 40, (0, 0, 40, 40))[0], camera.rays(40, 40)[0],
                               rtol=0, atol=1e-15)  # the rays as the camera's
    side, region = 65536, (32600, 32600, 336, 336)  # the cloud's middle, 0.02 across: ~650 pixels
    peaks = []
    for name, arguments in (("huge", (side, *region)), ("small", (64, 0, 0, 8, 8))):
        done = subprocess.run([sys.executable, "-c", HUGE_REGION, *map(str, arguments), str(tmp_path / name)],
                              capture_output=True, text=True, check=True)
        peaks.append(int(done.stdout))
    assert peaks[0] < peaks[1] + 100, f"peak memory {peaks[0]} MB against {peaks[1]} MB for a small image"
    depth, ids = np.load(tmp_path / "huge.npy")
    scene = durer.Scene()
    rng = np.random.default_rng(11)
    centers = np.column_stack([rng.uniform(-0.01, 0.01, (400, 2)), rng.uniform(-1, 1, 400)])
    scene.add_spheres(centers, rng.uniform(1e-4, 4e-4, 400))
    origins, directions = ortho_rays((0, 0, 3), 2.0, side, side, region)
    cast = durer.cast(scene, origins.reshape(-1, 3), np.ascontiguousarray(directions.reshape(-1, 3)), threads=2)
    cast_ids = cast.object_id.reshape(ids.shape)
    assert (cast_ids >= 0).mean() > 0.05
    np.testing.assert_array_equal(ids, cast_ids)
    hit = cast_ids >= 0
    np.testing.assert_allclose(depth[hit], cast.t.reshape(ids.shape)[hit], rtol=1e-6)


@pytest.mark.parametrize("sampler", ["stratified", "adaptive"])
def test_a_region_of_a_huge_image_is_that_part_of_a_larger_region(sampler):
    """Above 2^28 pixels each region sees through a view of the pixels it samples -- adaptive
    sampling's margin too, whose marking reads its neighbours: a region rendered alone equals the
    same pixels rendered inside a larger region (as tiles of a poster must), bit for bit."""
    side, size = 16392, 2.0  # just above 2^28 pixels
    rng = np.random.default_rng(3)
    px, py = rng.uniform(7950, 8090, 3000), rng.uniform(7950, 8090, 3000)
    radii = rng.uniform(0.1, 0.6, 3000) * size / side  # below a pixel: the first samples miss some
    centers = np.column_stack([(px / side - 0.5) * size, (0.5 - py / side) * size, rng.uniform(-1, 1, 3000)])
    scene = durer.Scene()
    scene.add_spheres(centers, radii, scene.add_material((0.9, 0.1, 0.1)))
    camera = durer.OrthographicCamera((0, 0, 3), (0, 0, -1), (0, 1, 0), size=size)
    options = dict(spp=64, sampler=sampler, threads=2, passes=("color", "depth", "object_id"), min_spp=4,
                   target_error=0.002)
    alone = durer.render(scene, camera, side, side, region=(8000, 8000, 40, 40), **options)
    inside = durer.render(scene, camera, side, side, region=(7960, 7960, 120, 120), **options)
    for name in ("color", "depth", "object_id") + (("samples",) if sampler == "adaptive" else ()):
        np.testing.assert_array_equal(getattr(alone, name), getattr(inside, name)[40:80, 40:80], err_msg=name)
    assert (alone.object_id >= 0).mean() > 0.2
