"""One-sided spheres (`Scene.add_spheres(one_sided=True)`: a point cloud's points, as Cycles meets
them): a ray that starts inside one passes through it. The search finds both sides and searches a
ray that met such a far side again past it (cpp/include/durer/accel/Group.h, passInsides); the
differential fuzz (test_traversal_fuzz.py) checks casts against a brute force over each primitive.
Here: the render's own searches (the camera's view, a light's view with its sure hits, the
hierarchy's packets) against casts of the same rays, shadows from inside, and the API around it."""

from __future__ import annotations

import pickle

import durer
import numpy as np
import pytest
from helpers.view_fuzz import PASSES, assert_render_matches_cast, cloud_spheres


def _cloud_scene(centers, radii, one_sided):
    scene = durer.Scene()
    scene.add_spheres(centers, radii, one_sided=one_sided)
    return scene


@pytest.mark.parametrize("precision", ["float", "double"])
def test_camera_rays_pass_the_inside_of_one_sided_spheres_as_a_cast_does(precision):
    """10,000 one-sided spheres filling a cube, seen from inside it (from the centre of a sphere, and
    through a clip start that cuts spheres) and through an orthographic image plane inside it: the
    render's camera rays find what a cast of the same rays finds, bit for bit, and many pass a
    sphere's inside where two-sided spheres stop them."""
    rng = np.random.default_rng(11)
    centers, radii = cloud_spheres(rng, 10_000, 1.0, np.zeros(3), 0.06)
    keep = np.linalg.norm(centers, axis=1) > 0.3
    centers, radii = np.vstack([[(0.0, 0.0, 0.0)], centers[keep]]), np.concatenate([[0.2], radii[keep]])  # the eye's
    one, two = _cloud_scene(centers, radii, True), _cloud_scene(centers, radii, False)
    cameras = [durer.PerspectiveCamera((0.0, 0.0, 0.0), (0.2, 0.1, -1), (0, 1, 0), fov_degrees=90),
               durer.PerspectiveCamera((0.3, -0.2, 0.1), (-0.1, 0.3, -1), (0, 1, 0), fov_degrees=60, t_min=0.15),
               durer.OrthographicCamera((0.0, 0.1, 0.2), (1, 1, -1), (0, 1, 0), size=1.5, t_min=0.0)]
    for camera in cameras:
        seen, hit = assert_render_matches_cast(one, camera, 64, 48, precision, spheres=(centers, radii, True))
        inside = durer.render(two, camera, width=64, height=48, passes=PASSES, precision=precision, threads=2)
        passed = seen.object_id != inside.object_id
        assert passed.mean() > 0.01, camera  # rays that started inside a sphere now meet what lies beyond
        assert np.all(seen.depth[passed & hit] > inside.depth[passed & hit])


@pytest.mark.parametrize("precision", ["float", "double"])
def test_a_point_inside_a_one_sided_sphere_is_lit_through_it(precision):
    """A camera inside a large one-sided ball cut by a lit ground, many small spheres about (so that
    the sun's shadow rays search a view of the spheres): the ground inside the ball is shaded as if
    the ball were not there, the camera's and the shadow rays passing its inside (a shadow ray leaves
    the ball by its far side); two-sided, the ball's inner wall is all the camera sees."""
    rng = np.random.default_rng(5)
    small_centers = np.column_stack([rng.uniform(-6, 6, (3000, 2)), rng.uniform(0.5, 3, 3000)])
    small_centers = small_centers[np.linalg.norm(small_centers, axis=1) > 2.5]

    def scene(ball: str | None):
        s = durer.Scene()
        s.add_material(diffuse=(0.8, 0.8, 0.8))
        s.add_plane((0, 0, 1), 0.0, 0)
        s.add_spheres(small_centers, 0.05, 0)
        if ball is not None:
            s.add_spheres([(0.0, 0.0, 0.0)], 1.5, 0, one_sided=ball == "one-sided")
        s.add_directional_light((0.3, 0.2, -1), (1.0, 1.0, 1.0), shadows=True)
        return s

    camera = durer.PerspectiveCamera((0.2, -0.1, 0.8), (0.1, 0.2, -1), (0, 1, 0), fov_degrees=70)
    renders = {ball: durer.render(scene(ball), camera, width=48, height=48, passes=("color", "depth", "object_id"),
                                  precision=precision, threads=2)
               for ball in (None, "one-sided", "two-sided")}
    alone, one, two = renders[None], renders["one-sided"], renders["two-sided"]
    assert (alone.object_id == 0).mean() > 0.5  # the ground, mostly
    np.testing.assert_array_equal(one.color, alone.color)
    np.testing.assert_array_equal(one.depth, alone.depth)
    assert np.all(two.object_id == two.object_id.max())  # the ball's inside, everywhere


@pytest.mark.parametrize("precision", ["float", "double"])
def test_shadow_rays_from_inside_with_a_point_light_and_bounces(precision):
    """Mirror rays and a point light's shadow rays (through its cube of views) that start inside a
    one-sided sphere pass through it too: the render equals the one of the scene without that
    sphere wherever the camera sees a point inside it."""
    rng = np.random.default_rng(9)
    centers = rng.uniform(-4, 4, (2000, 3))
    centers = centers[np.linalg.norm(centers, axis=1) > 2.2]

    def scene(with_ball: bool):
        s = durer.Scene()
        s.add_material(diffuse=(0.6, 0.6, 0.6), reflective=(0.3, 0.3, 0.3))
        s.add_plane((0, 0, 1), -0.5, 0)
        s.add_spheres(centers, 0.08, 0)
        if with_ball:
            s.add_spheres([(0.0, 0.0, 0.0)], 2.0, 0, one_sided=True)
        s.add_point_light((1.0, 0.5, 1.2), (2.0, 2.0, 2.0), shadows=True)
        return s

    camera = durer.PerspectiveCamera((0.0, 0.0, 0.5), (0.3, 0.1, -1), (0, 1, 0), fov_degrees=80)
    kw = dict(width=40, height=40, passes=("color", "depth"), precision=precision, threads=2, max_bounces=2)
    with_ball, without = durer.render(scene(True), camera, **kw), durer.render(scene(False), camera, **kw)
    np.testing.assert_array_equal(with_ball.depth, without.depth)
    # Where what the camera sees lies inside the ball, its light and its mirror ray start inside too.
    origins, directions = camera.rays(40, 40, precision)
    cast = durer.cast(scene(False), origins.reshape(-1, 3), directions.reshape(-1, 3), precision=precision)
    at = origins.reshape(-1, 3) + cast.t[:, None] * directions.reshape(-1, 3)
    deep = (np.linalg.norm(at, axis=1) < 1.9).reshape(40, 40)
    assert deep.mean() > 0.3
    np.testing.assert_array_equal(with_ball.color[deep], without.color[deep])


def test_one_sided_spheres_survive_pickling_moves_and_the_hierarchy():
    """The flag follows each sphere through a pickle, a move and a hierarchy's reordering; bad flags
    are refused naming the argument."""
    rng = np.random.default_rng(2)
    centers = rng.uniform(-1, 1, (500, 3))
    scene = durer.Scene()
    ids = scene.add_spheres(centers, 0.01, one_sided=np.arange(500) % 2 == 0)
    origins = centers + 0.001  # each ray starts inside its own sphere
    directions = np.tile((0.0, 0.0, 1.0), (500, 1))
    first = durer.cast(scene, origins, directions)
    assert np.all(first.object_id[1::2] == ids[1::2])  # two-sided: each ray meets its own sphere's far side
    assert not np.any(first.object_id[::2] == ids[::2])  # one-sided: each passes its own
    again = durer.cast(pickle.loads(pickle.dumps(scene)), origins, directions)
    np.testing.assert_array_equal(again.t, first.t)
    scene.move_spheres(ids, centers + 5.0)
    moved = durer.cast(scene, origins + 5.0, directions)
    np.testing.assert_array_equal(moved.object_id, first.object_id)
    np.testing.assert_array_equal(durer.occluded(scene, origins + 5.0, directions), np.isfinite(moved.t))
    with pytest.raises(TypeError, match="one_sided"):
        scene.add_spheres(centers[:2], 0.1, one_sided=[1, 0])
    with pytest.raises(ValueError, match="one_sided must be one bool or 2 bools"):
        scene.add_spheres(centers[:2], 0.1, one_sided=[True, False, True])
