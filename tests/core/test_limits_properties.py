"""Property test of the one rule for numbers (issue 18, item 3; docs/numerics.md "Accepted ranges"):
an ordinary scene and camera with a few fields replaced by doubles drawn from the whole range (huge,
tiny, subnormal, zero, either sign) either raises a ValueError naming one of the replaced fields, or
renders -- and casts, with directions of the drawn length -- finite values: colour and normal finite everywhere, depth finite on hits and
+inf on misses, unit normals on hits. In both precisions, derandomised."""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import durer
from durer.render import PRECISIONS

SETTINGS = settings(derandomize=True, deadline=None, database=None, max_examples=3000,
                    suppress_health_check=[HealthCheck.too_slow])

# Any finite double, with the extremes and the limits' neighbourhoods drawn often.
EXTREMES = [0.0, 5e-324, 1e-310, 1e-300, 1e-40, 1e-20, 1e-10, 1.0, 1e10, 9e17, 1.1e18, 1e20, 9e35, 1.1e36, 1e39,
            1e150, 1e300, 1.7976931348623157e308]
numbers = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False),
    st.tuples(st.sampled_from(EXTREMES), st.sampled_from([1.0, -1.0])).map(lambda p: p[0] * p[1]),
)

# field -> (what the error message names, its key in the setup, the component replaced or None)
FIELDS: dict[str, tuple[str, str, int | None]] = {
    "sphere centre": ("centers", "center", 0),
    "sphere radius": ("radii", "radius", None),
    "triangle vertex": ("vertices", "vertex", 2),
    "box corner": ("hi", "hi", 1),
    "plane offset": ("offset", "offset", None),
    "plane normal": ("normal", "plane_normal", 0),
    "light position": ("position", "light", 1),
    "light colour": ("color", "light_color", None),
    "light direction": ("direction", "sun", 0),
    "exponent": ("exponent", "exponent", None),
    "diffuse": ("diffuse", "diffuse", None),
    "emission": ("emission", "emission", None),
    "reflective": ("reflective", "reflective", None),
    "ior": ("ior", "ior", None),
    "attenuation": ("attenuation", "attenuation", None),
    "background": ("background", "background", None),
    "scale": ("transform", "scale", None),
    "scale x": ("transform", "stretch", 0),
    "transparent": ("transparent", "transparent", None),
    "spot position": ("position", "spot", 2),
    "spot angle": ("half_angle_degrees", "spot_angle", None),
    "area light position": ("position", "area", 0),
    "area light edge": ("u", "area_u", None),
    "point light radius": ("radius", "radius_light", None),
    "fov": ("fov_degrees", "fov", None),
    "camera centre": ("center", "eye", 0),
    "camera direction": ("direction", "view", 1),
    "camera size": ("size", "size", None),  # orthographic only: perspective cameras take "fov"
    "camera shift": ("shift", "shift", None),
    "pixel aspect": ("pixel_aspect", "aspect", None),
    "cast direction length": ("directions", "length", None),
}


def names(message: str, name: str) -> bool:
    """Whether `message` names the field `name` as a whole token ("hi[0]" names "hi", "within" does not;
    "directions[3]" does not name "direction")."""
    return re.search(rf"(?<!\w){re.escape(name)}(?!\w)", message) is not None


def replace(setup: dict[str, Any], field: str, value: float) -> None:
    _, key, component = FIELDS[field]
    if component is None:
        setup[key] = value
    else:
        setup[key][component] = value


def base_setup() -> dict[str, Any]:
    return {"center": [0.0, 0.0, 0.0], "radius": 1.0, "vertex": [0.0, 1.0, -1.0], "hi": [3.0, 1.0, 1.0],
            "offset": -2.0, "plane_normal": [0.0, 0.0, 1.0], "sun": [0.0, -1.0, -1.0], "exponent": 8.0,
            "view": [0.0, 0.0, -1.0], "stretch": [1.0, 1.0, 1.0], "transparent": 0.25, "spot": [0.0, 0.0, 6.0],
            "area": [0.0, 2.0, 3.0], "area_u": 1.0, "radius_light": 0.5, "spot_angle": 30.0, "fov": 40.0, "light": [2.0, 3.0, 4.0], "light_color": 1.0, "diffuse": 0.5, "emission": 0.0,
            "reflective": 0.5, "ior": 1.5, "attenuation": 1.0,
            "background": 0.1, "scale": 1.0, "eye": [0.0, 0.0, 5.0], "size": 4.0, "shift": 0.0, "aspect": 1.0,
            "length": 1.0}


def build(setup: dict[str, Any], perspective: bool) -> tuple[durer.Scene, Any]:
    scene = durer.Scene()
    material = scene.add_material(diffuse=(setup["diffuse"], 0.5, 0.5), emission=(setup["emission"], 0, 0),
                                  specular=(0.5, 0.5, 0.5), exponent=setup["exponent"],
                                  reflective=(setup["reflective"], 0.5, 0.5), transparent=(setup["transparent"], 0.25, 0.25),
                                  ior=setup["ior"])
    scene.add_spheres([setup["center"]], setup["radius"], material=material)
    scene.add_triangles([[[-1.0, -1.0, -1.0], [1.0, -1.0, -1.0], setup["vertex"]]])
    scene.add_boxes([[2.0, -1.0, -1.0]], [setup["hi"]])
    scale = setup["scale"]
    scene.add_spheres([[0.0, -1.5, 0.0]], 0.5, transform=np.diag([scale, scale, scale, 1.0]))
    scene.add_boxes([[-0.5, 1.0, -0.5]], [[0.5, 2.0, 0.5]], transform=np.diag([*setup["stretch"], 1.0]))
    scene.add_spot_light(setup["spot"], (0, 0, -1), (1, 1, 1), half_angle_degrees=setup["spot_angle"], blend=0.5,
                         attenuation=(0, 0, 1), shadows=True)
    scene.add_area_light(setup["area"], (setup["area_u"], 0, 0), (0, -1.0, 0), (1, setup["light_color"], 1), samples=2,
                         shadows=True)
    scene.add_plane(setup["plane_normal"], setup["offset"])
    scene.add_point_light(setup["light"], (setup["light_color"], 1.0, 1.0), attenuation=(setup["attenuation"], 0, 1),
                          shadows=True, radius=setup["radius_light"], samples=2)
    scene.add_directional_light(setup["sun"], (0.5, setup["light_color"], 0.5))
    scene.background = (setup["background"], 0.0, 0.0)
    common = dict(center=setup["eye"], direction=setup["view"], up=(0, 1, 0), shift=(setup["shift"], 0.0),
                  pixel_aspect=setup["aspect"])
    if perspective:
        return scene, durer.PerspectiveCamera(**common, fov_degrees=setup["fov"])
    return scene, durer.OrthographicCamera(**common, size=setup["size"])


def assert_finite(result: durer.RenderResult) -> None:
    hit = np.isfinite(result.depth)
    assert np.isfinite(result.color).all(), result.color
    assert not np.isnan(result.depth).any() and (result.depth[~hit] == math.inf).all(), result.depth
    assert np.isfinite(result.normal).all(), result.normal
    np.testing.assert_allclose(np.linalg.norm(result.normal[hit], axis=-1), 1.0, atol=1e-5)
    assert not result.normal[~hit].any()


@SETTINGS
@given(
    replaced=st.lists(st.tuples(st.sampled_from(sorted(FIELDS)), numbers), min_size=1, max_size=3),
    precision=st.sampled_from(PRECISIONS),
    perspective=st.booleans(),
    spp=st.sampled_from([1, 4]),
)
def test_extreme_values_are_refused_by_name_or_render_finite(replaced, precision, perspective, spp):
    setup = base_setup()
    for field, value in replaced:
        replace(setup, field, value)
    named = {FIELDS[field][0] for field, _ in replaced}
    try:
        scene, camera = build(setup, perspective)
        result = durer.render(scene, camera, 5, 4, spp=spp, precision=precision)
        rays = camera.rays(5, 4, precision)
        cast = durer.cast(scene, rays[0].reshape(-1, 3), rays[1].reshape(-1, 3) * setup["length"], precision=precision)
    except ValueError as error:
        event("refused")
        # "the image window (center, size or fov_degrees, shift, pixel_aspect at 5x4)" lists the camera
        # fields it is made of: it passes here only when one of them was replaced, like any other name.
        assert any(names(str(error), name) for name in named), (str(error), replaced)
        return
    event("rendered")
    assert_finite(result)
    hit = cast.object_id >= 0
    assert np.isfinite(cast.t[hit]).all() and (cast.t[~hit] == math.inf).all()
    np.testing.assert_allclose(np.linalg.norm(cast.normal[hit], axis=-1), 1.0, atol=1e-5)


@SETTINGS
@given(
    origin=st.tuples(numbers, numbers, numbers),
    direction=st.tuples(numbers, numbers, numbers),
    t_min=st.one_of(st.just(0.0), st.just(-math.inf), numbers),
    precision=st.sampled_from(PRECISIONS),
)
def test_extreme_rays_are_refused_by_name_or_cast_finite(origin, direction, t_min, precision):
    """cast of one drawn ray among ordinary ones at the ordinary scene: a ValueError naming the
    ray's field, or every hit finite, in range and with a unit normal."""
    scene, _ = build(base_setup(), False)
    origins = np.array([(0.0, 0.0, 5.0), origin, (0.5, 0.5, 5.0)])
    directions = np.array([(0.0, 0.0, -1.0), direction, (0.0, 0.0, -1.0)])
    try:
        cast = durer.cast(scene, origins, directions, t_min=t_min, precision=precision)
    except ValueError as error:
        assert any(names(str(error), name) for name in ("origins[1]", "directions[1]", "t_min")), str(error)
        return
    hit = cast.object_id >= 0
    # the ordinary rays meet the sphere at t = 4 and, last, the plane z = -2 at t = 7 (t >= t_min counts)
    assert (hit[0] and hit[2]) or t_min > 7
    assert np.isfinite(cast.t[hit]).all() and (cast.t[hit] >= t_min).all() and (cast.t[~hit] == math.inf).all()
    np.testing.assert_allclose(np.linalg.norm(cast.normal[hit], axis=-1), 1.0, atol=1e-5)
