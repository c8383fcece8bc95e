"""Back faces are decided in the core: with shade_back, a surface seen from behind is shaded (and
reported in the Normal pass) with its flipped normal. The Blender build relies on it instead of
turning plane normals toward the camera, so both must give the same image, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

import durer


def scene(normal_sign: float, *, lit: bool) -> durer.Scene:
    s = durer.Scene()
    red = s.add_material((0.8, 0.2, 0.1), specular=(0.3, 0.3, 0.3), exponent=12)
    s.add_plane((0, 0, normal_sign), normal_sign * -5.0, material=red)  # the plane z = -5
    s.add_spheres([[0.5, 0.3, -3.0]], 0.6)
    if lit:
        s.add_point_light((0, 1, 2), (1, 1, 1), shadows=True)
        s.ambient = (0.1, 0.1, 0.1)
    return s


@pytest.mark.parametrize("lit", [False, True])
@pytest.mark.parametrize("precision", ["float", "double"])
def test_shade_back_equals_a_plane_turned_towards_the_camera(lit, precision):
    camera = durer.PerspectiveCamera((0, 0, 3), (0, 0, -1), (0, 1, 0), fov_degrees=70)
    kwargs = dict(spp=2, precision=precision)
    back = durer.render(scene(-1.0, lit=lit), camera, 24, 18, shade_back=True, **kwargs)  # seen from behind
    turned = durer.render(scene(1.0, lit=lit), camera, 24, 18, shade_back=True, **kwargs)  # as Blender did
    for name in ("color", "depth", "normal"):
        np.testing.assert_array_equal(getattr(back, name), getattr(turned, name), err_msg=name)
    # The corner pixels see the plane: its normal points back at the camera.
    np.testing.assert_allclose(back.normal[0, 0], (0, 0, 1), atol=1e-6)


def test_without_shade_back_a_back_face_keeps_its_normal():
    camera = durer.OrthographicCamera((0, 0, 3), (0, 0, -1), (0, 1, 0), size=20)
    result = durer.render(scene(-1.0, lit=True), camera, 8, 8, passes=("normal",))
    np.testing.assert_array_equal(result.normal[0, 0], (0, 0, -1))
    flipped = durer.render(scene(-1.0, lit=True), camera, 8, 8, passes=("normal",), shade_back=True)
    np.testing.assert_array_equal(flipped.normal[0, 0], (0, 0, 1))
