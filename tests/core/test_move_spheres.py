"""Scene.move_spheres: an animation's next frame refits the hierarchy, and what is traced then is
exactly what a scene built at the new positions traces."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import durer

N = 3000


def cloud(rng, n=N):
    return rng.uniform(-10, 10, (n, 3)), rng.uniform(0.05, 0.4, n)


def rays(rng, n=4000):
    origins = rng.uniform(-14, 14, (n, 3))
    targets = rng.uniform(-8, 8, (n, 3))
    return origins, targets - origins


def fresh(centers, radii, *extra):
    scene = durer.Scene()
    scene.add_spheres(centers, radii)
    for add in extra:
        add(scene)
    return scene


def assert_casts_equal(moved, built, origins, directions, precision):
    a = durer.cast(moved, origins, directions, precision=precision)
    b = durer.cast(built, origins, directions, precision=precision)
    assert (a.object_id >= 0).sum() > len(origins) // 10  # the rays meet spheres
    np.testing.assert_array_equal(a.object_id, b.object_id)
    np.testing.assert_array_equal(a.t, b.t)


def test_frames_of_small_moves_refit_and_trace_exactly_like_fresh_scenes(rng, precision):
    centers, radii = cloud(rng)
    origins, directions = rays(rng)
    scene = fresh(centers, radii)
    ids = np.arange(N)
    durer.cast(scene, origins, directions, precision=precision)
    for _ in range(5):
        centers = centers + rng.normal(0, 0.05, centers.shape)  # particles drifting between frames
        scene.move_spheres(ids, centers)
        assert_casts_equal(scene, fresh(centers, radii), origins, directions, precision)
    counts = scene.hierarchy_counts
    assert (counts["built"], counts["refitted"], counts["rebuilt"]) == (1, 5, 0)
    assert counts["milliseconds"] > 0


def test_scrambled_spheres_rebuild_instead_of_refitting_a_degraded_tree(rng, precision):
    centers, radii = cloud(rng)
    origins, directions = rays(rng)
    scene = fresh(centers, radii)
    durer.cast(scene, origins, directions, precision=precision)
    scrambled = centers[rng.permutation(N)]  # every sphere jumps across the cloud: refit boxes span it
    scene.move_spheres(np.arange(N), scrambled)
    assert_casts_equal(scene, fresh(scrambled, radii), origins, directions, precision)
    assert scene.hierarchy_counts["rebuilt"] == 1
    jittered = scrambled + 0.01  # the rebuilt tree refits again, its new order kept
    scene.move_spheres(np.arange(N), jittered)
    assert_casts_equal(scene, fresh(jittered, radii), origins, directions, precision)
    assert scene.hierarchy_counts["rebuilt"] == 1 and scene.hierarchy_counts["refitted"] == 2


def test_some_spheres_in_any_order_with_new_radii_among_other_objects(rng):
    centers, radii = cloud(rng)
    origins, directions = rays(rng)
    add_box = lambda s: s.add_boxes([[-1, -1, -1]], [[1, 1, 1]])  # noqa: E731
    add_plane = lambda s: s.add_plane((0, 0, 1), -12)  # noqa: E731
    scene = fresh(centers, radii, add_box, add_plane)
    durer.cast(scene, origins, directions)
    some = rng.choice(N, 700, replace=False)
    centers[some] = rng.uniform(-10, 10, (700, 3))
    radii[some] = rng.uniform(0.05, 0.4, 700)
    scene.move_spheres(some, centers[some], radii[some])
    assert_casts_equal(scene, fresh(centers, radii, add_box, add_plane), origins, directions, "double")
    scene.move_spheres(some[:3], centers[some[:3]] + 1)  # radii=None keeps the new radii
    centers[some[:3]] += 1
    assert_casts_equal(scene, fresh(centers, radii, add_box, add_plane), origins, directions, "double")
    scene.move_spheres(some[:5], centers[some[:5]], 0.3)  # one radius for all
    radii[some[:5]] = 0.3
    assert_casts_equal(scene, fresh(centers, radii, add_box, add_plane), origins, directions, "double")


def test_spheres_under_transforms_move_with_the_hierarchy_over_instances(rng, precision):
    """Twelve transformed groups (enough for the top-level hierarchy): moving the spheres of one
    changes its world box, which the top level must follow."""
    per = 200
    centers, radii = cloud(rng, 12 * per)
    transforms = []
    for g in range(12):
        m = np.eye(4)
        m[:3, :3] *= 0.5 + 0.1 * g
        m[:3, 3] = rng.uniform(-20, 20, 3)
        transforms.append(m)

    def build(cs):
        scene = durer.Scene()
        for g, m in enumerate(transforms):
            scene.add_spheres(cs[g * per:(g + 1) * per], radii[g * per:(g + 1) * per], transform=m)
        return scene

    origins = rng.uniform(-30, 30, (5000, 3))
    directions = rng.uniform(-25, 25, (5000, 3)) - origins
    scene = build(centers)
    durer.cast(scene, origins, directions, precision=precision)
    group = slice(5 * per, 6 * per)
    centers[group] += np.array([15.0, -10.0, 4.0])  # out of its old world box
    scene.move_spheres(np.arange(12 * per)[group], centers[group])
    assert_casts_equal(scene, build(centers), origins, directions, precision)
    assert scene.hierarchy_counts["refitted"] == 1
    order = rng.permutation(12 * per)  # every run's ids interleaved: each lookup leaves the run before it
    centers[order] += rng.normal(0, 0.05, (12 * per, 3))
    scene.move_spheres(order, centers[order])
    assert_casts_equal(scene, build(centers), origins, directions, precision)


def test_images_after_a_move_equal_a_fresh_scene_pixel_for_pixel(rng):
    centers, radii = cloud(rng, 1500)
    camera = durer.PerspectiveCamera(center=(0, -30, 6), direction=(0, 1, -0.2), up=(0, 0, 1), fov_degrees=40)

    def lit(scene):
        scene.add_plane((0, 0, 1), -11)
        scene.add_directional_light((0.3, 0.5, -1), (1, 1, 1), shadows=True)
        scene.ambient = (0.1, 0.1, 0.1)

    scene = fresh(centers, radii, lit)
    durer.render(scene, camera, 48, 32)
    centers = centers + rng.normal(0, 0.3, centers.shape)
    scene.move_spheres(np.arange(1500), centers)
    moved = durer.render(scene, camera, 48, 32, spp=4)
    built = durer.render(fresh(centers, radii, lit), camera, 48, 32, spp=4)
    for name in ("color", "depth", "normal"):
        np.testing.assert_array_equal(getattr(moved, name), getattr(built, name))


def test_a_move_during_a_render_leaves_that_render_alone_and_the_next_one_sees_it(rng):
    centers, radii = cloud(rng)
    scene = fresh(centers, radii)
    camera = durer.OrthographicCamera(center=(0, 0, 20), direction=(0, 0, -1), up=(0, 1, 0), size=24)
    depth = lambda s: durer.render(s, camera, 64, 64, passes=("depth",), threads=1).depth  # noqa: E731
    before = depth(scene)
    moved_centers = centers + np.array([3.0, 0, 0])
    expected = depth(fresh(moved_centers, radii))
    nested = []

    def move_and_render_again(fraction):  # called on this thread while the render's worker traces
        if not nested:
            scene.move_spheres(np.arange(N), moved_centers)
            nested.append(depth(scene))  # the first render still holds the old tree: this one builds

    during = durer.render(scene, camera, 64, 64, passes=("depth",), threads=1, progress=move_and_render_again)
    np.testing.assert_array_equal(during.depth, before)  # traced the geometry it started with
    np.testing.assert_array_equal(nested[0], expected)
    assert (scene.hierarchy_counts["built"], scene.hierarchy_counts["refitted"]) == (2, 0)
    scene.move_spheres(np.arange(N), centers)  # no render holds the tree now: refitted in place
    np.testing.assert_array_equal(depth(scene), before)
    assert (scene.hierarchy_counts["built"], scene.hierarchy_counts["refitted"]) == (2, 1)


def test_a_pickled_scene_replays_its_moves_and_keeps_only_the_last_of_the_same_spheres(rng):
    centers, radii = cloud(rng)
    scene = fresh(centers, radii)
    ids = np.arange(N)
    scene.move_spheres(ids[:10], centers[:10], 0.5)
    once = len(pickle.dumps(scene))
    for frame in range(30):
        centers = centers + 0.01
        scene.move_spheres(ids, centers)
    assert len(pickle.dumps(scene)) < once + centers.nbytes + ids.nbytes + 4096  # one move kept, not 30
    copy = pickle.loads(pickle.dumps(scene))
    radii[:10] = 0.5  # the radii set by the first move survive the later moves that kept radii
    origins, directions = rays(rng)
    assert_casts_equal(copy, fresh(centers, radii), origins, directions, "double")
    assert_casts_equal(scene, copy, origins, directions, "double")


@pytest.mark.parametrize("ids, centers, radii, error, match", [
    ([3000], [[0, 0, 0]], None, ValueError, r"ids\[0\] = 3000 is not the object id of a sphere"),
    ([0, 3001], [[0, 0, 0]] * 2, None, ValueError, r"ids\[1\] = 3001 is not the object id of a sphere"),
    ([-1], [[0, 0, 0]], None, ValueError, r"ids\[0\] = -1 is not the object id of a sphere"),
    ([2**31], [[0, 0, 0]], None, ValueError, "ids must fit in int32"),
    ([0.0], [[0, 0, 0]], None, TypeError, "ids must hold integers"),
    ([[0]], [[0, 0, 0]], None, ValueError, r"ids must have shape \(N,\)"),
    ([0, 1], [[0, 0, 0]], None, ValueError, r"centers must have shape \(2, 3\)"),
    ([0], [[0, np.nan, 0]], None, ValueError, "centers must be finite"),
    ([0], [[0, 0, 0]], [0.0], ValueError, r"radii\[0\] must be finite and > 0"),
    ([0], [[0, 0, 0]], [1, 2], ValueError, r"radii must have shape \(1,\)"),
    ([0], [[1e40, 0, 0]], None, ValueError, r"centers\[0\] ± radii\[0\] must lie within ±1e\+36"),
])
def test_bad_moves_name_the_argument_and_change_nothing(rng, ids, centers, radii, error, match):
    scene = fresh(*cloud(rng))
    scene.add_boxes([[20, 20, 20]], [[21, 21, 21]])  # object 3000 is a box
    origins, directions = rays(rng)
    before = durer.cast(scene, origins, directions)
    with pytest.raises(error, match=match):
        scene.move_spheres(ids, centers, radii)
    after = durer.cast(scene, origins, directions)
    np.testing.assert_array_equal(after.t, before.t)
    assert scene.hierarchy_counts["refitted"] == 0


def test_a_few_spheres_without_a_hierarchy_move_too(rng):
    centers, radii = rng.uniform(-6, 6, (5, 3)), rng.uniform(1, 3, 5)
    origins, directions = rays(rng, 500)
    scene = fresh(centers, radii)
    durer.cast(scene, origins, directions, precision="float")
    centers = centers[::-1].copy()
    scene.move_spheres(np.arange(5), centers)
    a = durer.cast(scene, origins, directions, precision="float")
    b = durer.cast(fresh(centers, radii), origins, directions, precision="float")
    assert (a.object_id >= 0).any()
    np.testing.assert_array_equal(a.object_id, b.object_id)
    np.testing.assert_array_equal(a.t, b.t)


def test_a_move_beyond_what_float_holds_is_refused_by_a_float_render_not_a_double_one(rng):
    centers, radii = cloud(rng, 100)
    scene = fresh(centers, radii)
    origins, directions = rays(rng, 200)
    durer.cast(scene, origins, directions, precision="float")
    scene.move_spheres([7], [[1e20, 0, 0]])
    durer.cast(scene, origins, directions, precision="double")
    with pytest.raises(ValueError, match=r"centers\[0\] ± radii\[0\] must lie within ±1e\+18 with precision='float'"):
        durer.cast(scene, origins, directions, precision="float")


def test_what_a_float_render_refuses_follows_the_spheres_where_they_are_now(rng):
    """The scene's reach is its spheres' where they are now: a sphere moved beyond float's range and
    back no longer stops a float render (it did, for good), nor does any sphere of several runs,
    transformed or not, once none is out there; one still out there does, named by its object id."""
    centers, radii = cloud(rng, 100)
    scene = fresh(centers, radii)
    scene.add_spheres(centers[:3], radii[:3], transform=np.diag([2.0, 2.0, 2.0, 1.0]))  # object ids 100-102
    origins, directions = rays(rng, 200)
    before = durer.cast(scene, origins, directions, precision="float")
    scene.move_spheres([7, 101], [[1e20, 0, 0], [0, 4e18, 0]])
    with pytest.raises(ValueError, match=r"centers\[0\] ± radii\[0\] must lie within ±1e\+18"):
        durer.cast(scene, origins, directions, precision="float")
    scene.move_spheres([7], [centers[7]])  # back: sphere 101 of that move is the farthest now
    with pytest.raises(ValueError, match=r"centers\[1\] ± radii\[1\] must lie within ±1e\+18"):
        durer.render(scene, durer.OrthographicCamera((0, 0, 30), (0, 0, -1), (0, 1, 0), 30), 8, 8,
                     precision="float", passes=("depth",))
    scene.move_spheres([101], [centers[1]])
    after = durer.cast(scene, origins, directions, precision="float")
    np.testing.assert_array_equal(after.t, before.t)
    np.testing.assert_array_equal(after.object_id, before.object_id)
    scene.move_spheres([5], [[0, 0, -2e18]])  # not the farthest before: the farthest now, by its own call's name
    with pytest.raises(ValueError, match=r"centers\[0\] ± radii\[0\] must lie within ±1e\+18"):
        durer.cast(scene, origins, directions, precision="float")
    scene.move_spheres([6], [[0, 3e18, 0]])
    scene.move_spheres([6], [centers[6]])  # the farthest back: the run measured again finds sphere 5
    with pytest.raises(ValueError, match=r"the sphere of object id 5 must lie within ±1e\+18"):
        durer.cast(scene, origins, directions, precision="float")
    scene.move_spheres(np.arange(100), centers)  # every sphere of the run at once, back where it was
    np.testing.assert_array_equal(durer.cast(scene, origins, directions, precision="float").t, before.t)


def test_moves_of_other_spheres_each_frame_do_not_pile_up_in_a_pickle(rng):
    """A different tenth of the spheres moved each frame (and the same ones in another order, some
    with radii): the records a pickle replays stay within a few times the spheres' own size (they
    grew with every frame: 550 MB after 200 frames of 1M spheres), and replay the same scene."""
    centers, radii = cloud(rng)
    scene = fresh(centers, radii)
    size = len(pickle.dumps(scene))
    for frame in range(60):
        chosen = np.sort(rng.choice(N, N // 10, replace=False))
        if frame % 3 == 1:
            chosen = chosen[::-1]
        centers[chosen] += rng.normal(0, 0.05, (len(chosen), 3))
        if frame % 7 == 3:
            radii[chosen] = rng.uniform(0.05, 0.4, len(chosen))
            scene.move_spheres(chosen, centers[chosen], radii[chosen])
        else:
            scene.move_spheres(chosen, centers[chosen])
    assert len(pickle.dumps(scene)) < 4 * size
    copy = pickle.loads(pickle.dumps(scene))
    origins, directions = rays(rng)
    assert_casts_equal(copy, fresh(centers, radii), origins, directions, "double")
    assert_casts_equal(scene, copy, origins, directions, "double")
