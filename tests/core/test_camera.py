"""Camera rays against hand-computed rays (6.837 conventions, fit and shift)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import durer


def test_orthographic_square_follows_the_6837_formula():
    # origin = center + (x - 1/2)·size·horizontal + (y - 1/2)·size·up, x, y pixel centres in [0, 1]
    cam = durer.OrthographicCamera(center=(1, 2, 3), direction=(0, 0, -1), up=(0, 1, 0), size=4)
    origins, directions = cam.rays(4, 4)
    for j in range(4):
        for i in range(4):
            x, y = (i + 0.5) / 4, 1 - (j + 0.5) / 4  # row 0 is the top
            expected = np.array([1, 2, 3]) + (x - 0.5) * 4 * np.array([1, 0, 0]) + (y - 0.5) * 4 * np.array([0, 1, 0])
            np.testing.assert_allclose(origins[j, i], expected, atol=1e-15)
    np.testing.assert_array_equal(directions, np.broadcast_to([0, 0, -1], (4, 4, 3)))


def test_orthographic_non_square_size_spans_the_larger_dimension():
    cam = durer.OrthographicCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), size=2)
    origins, _ = cam.rays(4, 2)  # pixel size 2/4 = 0.5
    np.testing.assert_allclose(origins[0, :, 0], [-0.75, -0.25, 0.25, 0.75])
    np.testing.assert_allclose(origins[:, 0, 1], [0.25, -0.25])
    origins, _ = cam.rays(2, 4)  # tall image: size spans the height
    np.testing.assert_allclose(origins[:, 0, 1], [0.75, 0.25, -0.25, -0.75])
    np.testing.assert_allclose(origins[0, :, 0], [-0.25, 0.25])


def test_direction_and_up_are_orthonormalised():
    # Neither unit nor orthogonal: horizontal = normalize(d x up), up' = horizontal x d.
    cam = durer.OrthographicCamera(center=(0, 0, 0), direction=(0, 0, -5), up=(0, 3, 3), size=2)
    origins, directions = cam.rays(2, 2)
    np.testing.assert_allclose(directions[0, 0], [0, 0, -1])
    np.testing.assert_allclose(origins[0, 1], [0.5, 0.5, 0], atol=1e-15)  # top right: +horizontal, +up'


def test_orthographic_looking_along_x():
    cam = durer.OrthographicCamera(center=(0, 0, 0), direction=(1, 0, 0), up=(0, 0, 1), size=2)
    origins, directions = cam.rays(2, 2)
    # horizontal = x × z = -y; up' = -y × x = z
    np.testing.assert_allclose(origins[0, 0], [0, 0.5, 0.5], atol=1e-15)
    np.testing.assert_allclose(directions[1, 1], [1, 0, 0])


@pytest.mark.parametrize("precision", ["float", "double"])
def test_perspective_rays(precision):
    cam = durer.PerspectiveCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), fov_degrees=90)
    origins, directions = cam.rays(2, 2, precision)
    np.testing.assert_array_equal(origins, 0)
    # 90 degrees over 2 pixels: image plane at distance 1 spans [-1, 1], pixel centres at ±0.5.
    expected = np.array([-0.5, 0.5, -1]) / math.sqrt(1.5)
    np.testing.assert_allclose(directions[0, 0], expected, rtol=1e-6 if precision == "float" else 1e-15)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=2), 1, rtol=1e-6)


def test_perspective_non_square_fov_spans_the_larger_dimension():
    cam = durer.PerspectiveCamera(center=(1, 1, 1), direction=(0, 0, -1), up=(0, 1, 0), fov_degrees=90)
    _, directions = cam.rays(4, 2)  # 2 tan(45°) / 4 = 0.5 per pixel
    np.testing.assert_allclose(directions[0, 0], np.array([-0.75, 0.25, -1]) / math.sqrt(0.75**2 + 0.25**2 + 1))
    _, directions = cam.rays(1, 3)  # tall: the fov spans the height
    np.testing.assert_allclose(directions[0, 0], np.array([0, 2 / 3, -1]) / math.sqrt(4 / 9 + 1))
    # The outermost pixel edges sit at ±fov/2: the corner rays of a large image approach 45°.
    _, directions = cam.rays(1000, 500)
    angle = math.degrees(math.atan2(-directions[250, 0, 0], -directions[250, 0, 2]))
    assert angle == pytest.approx(45, abs=0.06)


def test_fit_horizontal_and_vertical():
    tall = dict(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), size=2)
    origins, _ = durer.OrthographicCamera(**tall, fit="horizontal").rays(2, 4)  # size spans the width (2 px)
    np.testing.assert_allclose(origins[0, :, 0], [-0.5, 0.5])
    np.testing.assert_allclose(origins[:, 0, 1], [1.5, 0.5, -0.5, -1.5])
    origins, _ = durer.OrthographicCamera(**tall, fit="vertical").rays(4, 2)  # spans the height (2 px)
    np.testing.assert_allclose(origins[0, :, 0], [-1.5, -0.5, 0.5, 1.5])


def test_shift_moves_the_image_window():
    base = dict(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), size=2)
    plain, _ = durer.OrthographicCamera(**base).rays(4, 2)
    shifted, _ = durer.OrthographicCamera(**base, shift=(0.5, -0.25)).rays(4, 2)
    np.testing.assert_allclose(shifted - plain, np.broadcast_to([1.0, -0.5, 0], plain.shape))
    _, d = durer.PerspectiveCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), fov_degrees=90,
                                   shift=(0.25, 0)).rays(2, 2)
    # extent 2·tan(45°) = 2, shift 0.25 of it = 0.5: the left column now looks straight ahead in x.
    np.testing.assert_allclose(d[0, 0], np.array([0, 0.5, -1]) / math.sqrt(1.25))


def test_camera_t_range_defaults():
    ortho = durer.OrthographicCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), size=1)
    persp = durer.PerspectiveCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), fov_degrees=30)
    assert ortho.t_min == -math.inf and ortho.t_max == math.inf
    assert persp.t_min == 0 and persp.t_max == math.inf


def test_cameras_are_values():
    a = durer.OrthographicCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), 2.0)
    b = durer.OrthographicCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), size=2.0)
    assert a == b and hash(a) == hash(b)
    assert a.center == (0.0, 0.0, 0.0)


def test_pixel_aspect_stretches_pixels_vertically():
    # Pixels twice as tall as wide: 4x2 pixels cover a square window; "auto" compares 4 with 2·2.
    cam = durer.OrthographicCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), 2.0, pixel_aspect=2.0)
    origins, _ = cam.rays(4, 2)
    np.testing.assert_allclose(origins[0, :, 0], [-0.75, -0.25, 0.25, 0.75])
    np.testing.assert_allclose(origins[:, 0, 1], [0.5, -0.5])
    vertical = durer.OrthographicCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), 2.0, fit="vertical", pixel_aspect=0.5)
    origins, _ = vertical.rays(2, 4)  # height spans 4·0.5 = 2 pixel widths = size 2: one unit per width
    np.testing.assert_allclose(origins[:, 0, 1], [0.75, 0.25, -0.25, -0.75])
    np.testing.assert_allclose(origins[0, :, 0], [-0.5, 0.5])
    with pytest.raises(ValueError, match="pixel_aspect"):
        durer.OrthographicCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), 2.0, pixel_aspect=0.0)


@pytest.mark.parametrize("sampler", ["stratified", "adaptive"])
def test_perspective_clip_planes_bound_the_distance_along_the_view_axis(precision, sampler):
    """With clip_planes, t_min and t_max are planes across the view axis (Blender's clip range): a
    wall at view depth 9.5 is whole under a far plane at 10, though its corners lie 16 away along
    their rays; a wall at 0.5 before a near plane at 0.55 is cut away whole and the wall behind it
    seen through it, where clipping along the rays kept its off-axis part."""
    scene = durer.Scene()
    near_wall, far_wall = scene.add_plane((0, 0, 1), -0.5), scene.add_plane((0, 0, 1), -9.5)
    kw = dict(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), fov_degrees=120)

    def seen(camera):
        result = durer.render(scene, camera, 32, 24, precision=precision, sampler=sampler, depth="planar",
                              passes=("depth", "object_id"))
        return result.depth, result.object_id

    depth, ids = seen(durer.PerspectiveCamera(**kw, t_min=0.55, t_max=10, clip_planes=True))
    assert (ids == far_wall).all()
    np.testing.assert_allclose(depth, 9.5, rtol=1e-6)
    depth, ids = seen(durer.PerspectiveCamera(**kw, t_min=0.55, t_max=10))  # along the rays
    assert ids[12, 16] == far_wall and ids[0, 0] == near_wall and (ids == near_wall).mean() > 0.9
    depth, ids = seen(durer.PerspectiveCamera(**kw, t_min=0.45, t_max=9.4, clip_planes=True))
    assert (ids == near_wall).all()
    scene = durer.Scene()
    scene.add_plane((0, 0, 1), -9.5)
    depth, ids = seen(durer.PerspectiveCamera(**kw, t_max=9.4, clip_planes=True))
    assert (ids == -1).all() and np.isinf(depth).all()
    depth, ids = seen(durer.PerspectiveCamera(**kw, t_max=9.6, clip_planes=True))
    assert (ids == 0).all()


def test_clip_planes_is_a_flag():
    with pytest.raises(TypeError, match="clip_planes"):
        durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), clip_planes="yes")


def test_a_ray_searched_past_the_near_plane_still_stops_at_the_far_one(precision):
    """Off-axis rays meet the wall at view depth 0.5 before the near plane at 0.55: searched again
    from that plane, they meet the wall at 9.5, beyond the far plane at 9.4: a miss, every pixel."""
    scene = durer.Scene()
    scene.add_plane((0, 0, 1), -0.5)
    scene.add_plane((0, 0, 1), -9.5)
    camera = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), fov_degrees=120, t_min=0.55, t_max=9.4,
                                     clip_planes=True)
    result = durer.render(scene, camera, 32, 24, precision=precision, passes=("depth", "object_id"))
    assert (result.object_id == -1).all() and np.isinf(result.depth).all()


def test_clip_planes_lie_before_the_eye():
    with pytest.raises(ValueError, match=r"t_min must be >= 0 with clip_planes \(planes before the eye\), got -5"):
        durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), t_min=-5, t_max=-1, clip_planes=True)
    durer.OrthographicCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), t_min=-5, t_max=-1)  # its planes are its t
