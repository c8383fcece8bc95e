"""Bad input raises ValueError/TypeError naming the argument, and changes nothing."""

from __future__ import annotations

import re

import array
import math
import pickle

import numpy as np
import pytest

import durer

NAN, INF = math.nan, math.inf
ORTHO = dict(center=(0, 0, 5), direction=(0, 0, -1), up=(0, 1, 0), size=2.0)
PERSP = dict(center=(0, 0, 5), direction=(0, 0, -1), up=(0, 1, 0), fov_degrees=45.0)


def scene() -> durer.Scene:
    s = durer.Scene()
    s.add_spheres([[0, 0, 0]], [1.0])
    return s


def camera() -> durer.OrthographicCamera:
    return durer.OrthographicCamera(**ORTHO)


CASES = [
    # (description, call, exception, message fragment)
    ("NaN centre", lambda: scene().add_spheres([[0, NAN, 0]], [1.0]), ValueError, "centers"),
    ("inf centre", lambda: scene().add_spheres([[INF, 0, 0]], [1.0]), ValueError, "centers"),
    ("zero radius", lambda: scene().add_spheres([[0, 0, 0]], [0.0]), ValueError, "radii"),
    ("negative radius", lambda: scene().add_spheres([[0, 0, 0], [1, 1, 1]], [1.0, -2.0]), ValueError, "radii"),
    ("NaN radius", lambda: scene().add_spheres([[0, 0, 0]], NAN), ValueError, "radii"),
    ("centres shape", lambda: scene().add_spheres([[0, 0]], [1.0]), ValueError, "centers"),
    ("radii shape", lambda: scene().add_spheres([[0, 0, 0]], [1.0, 2.0]), ValueError, "radii"),
    ("centres dtype", lambda: scene().add_spheres([["a", "b", "c"]], [1.0]), TypeError, "centers"),
    ("radii dtype", lambda: scene().add_spheres([[0, 0, 0]], ["x"]), TypeError, "radii"),
    ("unknown material", lambda: scene().add_spheres([[0, 0, 0]], [1.0], material=7), ValueError, "material"),
    ("unknown material in array", lambda: scene().add_spheres([[0, 0, 0], [2, 0, 0]], 1.0, material=np.array([0, 9])),
     ValueError, "material"),
    ("float material", lambda: scene().add_spheres([[0, 0, 0]], [1.0], material=1.5), TypeError, "material"),
    ("material count", lambda: scene().add_spheres([[0, 0, 0]], [1.0], material=np.array([0, 0])), ValueError, "material"),
    ("ragged material", lambda: scene().add_spheres([[0, 0, 0], [1, 1, 1]], 1.0, material=[[0], [0, 1]]), TypeError,
     "^material must be an array of numbers"),
    ("bounds generator", lambda: scene().add_plane((0, 1, 0), 0.0, bounds=(v for v in [(0, 0, 0)] * 3)), TypeError,
     "^bounds must be \\(corner, edge1, edge2\\) or None, got generator"),
    ("bounds int", lambda: scene().add_plane((0, 1, 0), 0.0, bounds=3), TypeError, "^bounds must be .* got int"),
    ("zero normal", lambda: scene().add_plane((0, 0, 0), 1.0), ValueError, "normal"),
    ("NaN normal", lambda: scene().add_plane((0, NAN, 1), 1.0), ValueError, "normal"),
    ("inf offset", lambda: scene().add_plane((0, 1, 0), INF), ValueError, "offset"),
    ("plane material", lambda: scene().add_plane((0, 1, 0), 0.0, material=3), ValueError, "material"),
    ("bounds off the plane", lambda: scene().add_plane((0, 1, 0), 0.0, bounds=((0, 1, 0), (1, 0, 0), (0, 0, 1))),
     ValueError, "corner"),
    ("bounds edge out of plane", lambda: scene().add_plane((0, 1, 0), 0.0, bounds=((0, 0, 0), (1, 1, 0), (0, 0, 1))),
     ValueError, "edge1"),
    ("parallel bounds edges", lambda: scene().add_plane((0, 1, 0), 0.0, bounds=((0, 0, 0), (1, 0, 0), (2, 0, 0))),
     ValueError, "parallel"),
    ("zero bounds edge", lambda: scene().add_plane((0, 1, 0), 0.0, bounds=((0, 0, 0), (0, 0, 0), (0, 0, 1))),
     ValueError, "edge1"),
    ("negative diffuse", lambda: scene().add_material(diffuse=(1, -0.1, 0)), ValueError, "diffuse"),
    ("NaN diffuse", lambda: scene().add_material(diffuse=(1, NAN, 0)), ValueError, "diffuse"),
    ("diffuse shape", lambda: scene().add_material(diffuse=(1, 0)), ValueError, "diffuse"),
    ("zero light direction", lambda: scene().add_directional_light((0, 0, 0), (1, 1, 1)), ValueError, "direction"),
    ("NaN light colour", lambda: scene().add_directional_light((0, 0, -1), (1, NAN, 1)), ValueError, "color"),
    ("inf light position", lambda: scene().add_point_light((0, INF, 0), (1, 1, 1)), ValueError, "position"),
    ("background alpha", lambda: setattr(scene(), "background", (0, 0, 0, 2)), ValueError, "background"),
    ("background shape", lambda: setattr(scene(), "background", (0, 0)), ValueError, "background"),
    ("NaN ambient", lambda: setattr(scene(), "ambient", (NAN, 0, 0)), ValueError, "ambient"),
    # cameras
    ("NaN camera centre", lambda: durer.OrthographicCamera(**{**ORTHO, "center": (NAN, 0, 0)}), ValueError, "center"),
    ("zero direction", lambda: durer.OrthographicCamera(**{**ORTHO, "direction": (0, 0, 0)}), ValueError, "direction"),
    ("zero up", lambda: durer.PerspectiveCamera(**{**PERSP, "up": (0, 0, 0)}), ValueError, "up"),
    ("up parallel to direction", lambda: durer.OrthographicCamera(**{**ORTHO, "up": (0, 0, 3)}), ValueError, "parallel"),
    ("up antiparallel", lambda: durer.PerspectiveCamera(**{**PERSP, "up": (0, 0, 1)}), ValueError, "parallel"),
    ("zero size", lambda: durer.OrthographicCamera(**{**ORTHO, "size": 0.0}), ValueError, "size"),
    ("negative size", lambda: durer.OrthographicCamera(**{**ORTHO, "size": -1.0}), ValueError, "size"),
    ("inf size", lambda: durer.OrthographicCamera(**{**ORTHO, "size": INF}), ValueError, "size"),
    ("fov 0", lambda: durer.PerspectiveCamera(**{**PERSP, "fov_degrees": 0.0}), ValueError, "fov_degrees"),
    ("fov 180", lambda: durer.PerspectiveCamera(**{**PERSP, "fov_degrees": 180.0}), ValueError, "fov_degrees"),
    ("fov NaN", lambda: durer.PerspectiveCamera(**{**PERSP, "fov_degrees": NAN}), ValueError, "fov_degrees"),
    ("fov string", lambda: durer.PerspectiveCamera(**{**PERSP, "fov_degrees": "wide"}), TypeError, "fov_degrees"),
    ("unknown fit", lambda: durer.PerspectiveCamera(**PERSP, fit="diagonal"), ValueError, "fit"),
    ("NaN shift", lambda: durer.PerspectiveCamera(**PERSP, shift=(NAN, 0)), ValueError, "shift"),
    ("empty t range", lambda: durer.PerspectiveCamera(**PERSP, t_min=5.0, t_max=5.0), ValueError, "t_min"),
    ("NaN t_max", lambda: durer.OrthographicCamera(**ORTHO, t_max=NAN), ValueError, "t_max"),
    ("centre shape", lambda: durer.OrthographicCamera(**{**ORTHO, "center": (0, 0)}), ValueError, "center"),
    # render
    ("width 0", lambda: durer.render(scene(), camera(), 0, 10), ValueError, "width"),
    ("height -1", lambda: durer.render(scene(), camera(), 10, -1), ValueError, "height"),
    ("float width", lambda: durer.render(scene(), camera(), 10.5, 10), TypeError, "width"),
    ("width before region", lambda: durer.render(scene(), camera(), 0, 8, region=(0, 0, 1, 1)), ValueError,
     "^width must be >= 1, got 0"),
    ("height beyond the core's", lambda: durer.render(scene(), camera(), 8, 2**20 + 1), ValueError,
     "^height must be <= 1048576"),
    ("huge rays", lambda: camera().rays(2**31 - 1, 2**31 - 1), ValueError, "^width must be <= 1048576"),
    ("rays height 0", lambda: camera().rays(2, 0), ValueError, "^height must be >= 1"),
    ("spp 0", lambda: durer.render(scene(), camera(), 4, 4, spp=0), ValueError, "spp"),
    ("negative seed", lambda: durer.render(scene(), camera(), 4, 4, seed=-1), ValueError, "seed"),
    ("unknown precision", lambda: durer.render(scene(), camera(), 4, 4, precision="half"), ValueError, "precision"),
    ("unknown method", lambda: durer.render(scene(), camera(), 4, 4, sphere_method="magic"), ValueError,
     "sphere_method"),
    ("unknown pass", lambda: durer.render(scene(), camera(), 4, 4, passes=("color", "albedo")), ValueError, "passes"),
    ("no passes", lambda: durer.render(scene(), camera(), 4, 4, passes=()), ValueError, "passes"),
    ("threads 0", lambda: durer.render(scene(), camera(), 4, 4, threads=0), ValueError, "threads"),
    ("not a scene", lambda: durer.render("scene", camera(), 4, 4), TypeError, "scene"),
    ("not a camera", lambda: durer.render(scene(), object(), 4, 4), TypeError, "camera"),
    ("progress not callable", lambda: durer.render(scene(), camera(), 4, 4, progress=3), TypeError, "progress"),
    ("cancel not callable", lambda: durer.render(scene(), camera(), 4, 4, cancel="yes"), TypeError, "cancel"),
    # cast
    ("NaN origin", lambda: durer.cast(scene(), [[0, NAN, 0]], [[0, 0, 1]]), ValueError, "origins"),
    ("inf direction", lambda: durer.cast(scene(), [[0, 0, 0]], [[0, -INF, 1]]), ValueError, "directions"),
    ("zero direction ray", lambda: durer.cast(scene(), [[0, 0, 0], [1, 1, 1]], [[0, 0, 1], [0, 0, 0]]), ValueError,
     "directions\\[1\\]"),
    ("origins shape", lambda: durer.cast(scene(), [0, 0, 0], [[0, 0, 1]]), ValueError, "origins"),
    ("directions count", lambda: durer.cast(scene(), [[0, 0, 0]], [[0, 0, 1], [0, 1, 0]]), ValueError, "directions"),
    ("cast precision", lambda: durer.cast(scene(), [[0, 0, 0]], [[0, 0, 1]], precision="quad"), ValueError, "precision"),
    ("cast t range", lambda: durer.cast(scene(), [[0, 0, 0]], [[0, 0, 1]], t_min=2.0, t_max=1.0), ValueError, "t_min"),
    ("cast t_min NaN", lambda: durer.cast(scene(), [[0, 0, 0]], [[0, 0, 1]], t_min=NAN), ValueError, "t_min"),
    ("cast complex", lambda: durer.cast(scene(), np.zeros((1, 3), complex), [[0, 0, 1]]), TypeError, "origins"),
    ("cast check string", lambda: durer.cast(scene(), [[0, 0, 0]], [[0, 0, 0]], check="no"), TypeError,
     "^check must be True or False, got str"),
    # the showcase
    ("negative showcase count", lambda: durer.showcase_scene(-1), ValueError, "^small_spheres must be >= 0, got -1"),
    ("float showcase count", lambda: durer.showcase_scene(2.0), TypeError, "^small_spheres must be an integer"),
    ("float showcase seed", lambda: durer.showcase_scene(3, seed=1.5), TypeError, "^seed must be an integer"),
    ("negative showcase seed", lambda: durer.showcase_scene(3, seed=-1), ValueError, "^seed must be >= 0"),
]


@pytest.mark.parametrize(("what", "call", "error", "field"), CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_rejected_naming_the_field(what, call, error, field):
    with pytest.raises(error, match=field):
        call()


@pytest.mark.parametrize("call, message", [
    (lambda: durer.cast(scene(), [[0, 0, 0]], [[0, 0, 1]], t_min=1e-9, t_max=1e-10),
     "t_min must be < t_max, got 1e-09 and 1e-10"),
    (lambda: scene().add_spheres([[0, 0, 0]], [-1e-9]), "radii[0] must be finite and > 0, got -1e-09"),
    (lambda: durer.render(scene(), durer.OrthographicCamera(**ORTHO), 4, 4, min_weight=-1e-9),
     "min_weight must be finite and >= 0, got -1e-09"),
])
def test_small_numbers_in_messages_show_as_given_not_as_zero(call, message):
    """Errors show the offending value to six significant digits (1e-09), not fixed-point
    (0.000000, which reads as if the value were zero)."""
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        call()


def test_a_rejected_add_changes_nothing():
    s = scene()
    with pytest.raises(ValueError, match=r"^radii\[2\] must be finite and > 0"):
        s.add_spheres([[0, 0, 0], [1, 1, 1], [2, 2, 2]], [1.0, 1.0, -1.0])
    with pytest.raises(ValueError, match="^bounds corner is not on the plane"):
        s.add_plane((0, 1, 0), 0.0, bounds=((0, 5, 0), (1, 0, 0), (0, 0, 1)))
    assert (s.sphere_count, s.plane_count, s.object_count) == (1, 0, 1)
    assert s.add_spheres([[3, 3, 3]], 1.0).tolist() == [1]  # ids continue where they were


def test_nearly_parallel_up_is_accepted_and_orthonormalised():
    cam = durer.OrthographicCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1e-6, 1), size=2)
    origins, d = cam.rays(2, 2)
    np.testing.assert_array_equal(d, np.broadcast_to((0, 0, -1), (2, 2, 3)))
    # right = forward × up ∝ (1e-6, 0, 0) -> (1, 0, 0); up' = right × forward = (0, 1, 0) exactly. The
    # pixel centres sit ±0.5 along them; the given up, unorthonormalised, would tilt them nearly onto z.
    np.testing.assert_array_equal(origins, [[(-0.5, 0.5, 0), (0.5, 0.5, 0)], [(-0.5, -0.5, 0), (0.5, -0.5, 0)]])


@pytest.mark.parametrize("material", [2**31, 2**32 + 1, np.int64(2**32 + 1), np.uint64(2**63), 2**40, -(2**31) - 1])
def test_scalar_ids_beyond_int32_are_refused_not_wrapped(material):
    scene = durer.Scene()
    scene.add_material((1, 0, 0))  # id 1: what 2**32 + 1 used to wrap to
    for add in (lambda: scene.add_spheres([[0, 0, 0]], 1.0, material=material),
                lambda: scene.add_triangles([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], material),
                lambda: scene.add_boxes([[0, 0, 0]], [[1, 1, 1]], material),
                lambda: scene.add_plane((0, 0, 1), 0.0, material=material),
                lambda: scene.add_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], material=material)):
        with pytest.raises(ValueError, match=r"^material must be [<>]= "):
            add()
    assert scene.object_count == 0


def test_threads_beyond_a_c_int_is_a_value_error_naming_it():
    scene = durer.Scene()
    camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 2)
    with pytest.raises(ValueError, match=r"^threads must be <= 2147483647, got 2147483648$"):
        durer.render(scene, camera, 4, 4, threads=2**31)


@pytest.mark.parametrize(("field", "call"), [
    ("offset", lambda big: scene().add_plane((0, 1, 0), big)),
    ("exponent", lambda big: scene().add_material(exponent=big)),
    ("blend", lambda big: scene().add_spot_light((0, 0, 0), (0, 0, 1), (1, 1, 1), half_angle_degrees=30, blend=big)),
    ("size", lambda big: durer.OrthographicCamera(**{**ORTHO, "size": big})),
    ("fov_degrees", lambda big: durer.PerspectiveCamera(**{**PERSP, "fov_degrees": big})),
    ("min_weight", lambda big: durer.render(scene(), camera(), 4, 4, min_weight=big)),
    ("target_error", lambda big: durer.render(scene(), camera(), 4, 4, sampler="adaptive", target_error=big)),
    ("t_max", lambda big: durer.cast(scene(), [[0, 0, 0]], [[0, 0, 1]], t_max=big)),
])
def test_a_number_beyond_the_doubles_is_a_value_error_naming_it(field, call):
    # float(10**400) raises OverflowError, which named nothing.
    with pytest.raises(ValueError, match=f"^{field} must be within the range of a float"):
        call(10**400)


@pytest.mark.parametrize("given", [
    lambda buf: memoryview(buf), lambda buf: buf, lambda buf: buf[:, :],
    lambda buf: type("Wrapper", (), {"__array__": lambda self, dtype=None, copy=None: buf})(),
])
def test_the_scene_never_aliases_the_callers_memory(given):
    # The scene keeps a record of every add for pickling (Dask workers render the unpickled copy): a
    # buffer the caller changes afterwards must change neither the scene nor its pickle.
    buf = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 2.0]])  # the second sphere in front of the first
    s = durer.Scene()
    s.add_spheres(given(buf), 1.0)
    before = durer.render(s, camera(), 8, 8).depth
    buf[1, 0] = 100  # the second sphere leaves the view: only an aliased record would see it
    copy = pickle.loads(pickle.dumps(s))
    np.testing.assert_array_equal(durer.render(copy, camera(), 8, 8).depth, before)


def test_a_converted_buffer_is_not_copied_again():
    floats = array.array("f", [0.0] * 6)  # float32: the float64 conversion is new memory, the record
    s = durer.Scene()
    s.add_spheres(np.frombuffer(floats, np.float32).reshape(2, 3), 1.0)
    floats[3] = 100
    recorded = s._adds[0][1][0]
    assert recorded.flags.owndata and recorded[1, 0] == 0


def test_every_add_takes_material_by_one_rule():
    # One id may be a Python int, a numpy integer or a 0-d integer array, in every add; (N,) ids where
    # an add makes N objects.
    triangle = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    adds = (lambda s, m: s.add_spheres([[0, 0, 0]], 1.0, material=m),
            lambda s, m: s.add_triangles([triangle], m),
            lambda s, m: s.add_boxes([[0, 0, 0]], [[1, 1, 1]], m),
            lambda s, m: s.add_plane((0, 0, 1), 0.0, material=m),
            lambda s, m: s.add_mesh(triangle, [[0, 1, 2]], material=m),
            lambda s, m: s.add_mesh_instances(triangle, [[0, 1, 2]], [np.eye(4)], material=m))
    for one in (1, np.int64(1), np.array(1), np.array(1, np.uint8)):
        s = durer.Scene()
        s.add_material((1, 0, 0))
        for add in adds:
            add(s, one)
        assert s.object_count == 6
    for bad, error, message in ((np.array(1.0), TypeError, "^material must be an integer, got float64"),
                                (np.array(2**31), ValueError, "^material must be <= 2147483647"),
                                (True, TypeError, "^material must be an integer, got bool")):
        for add in adds:
            with pytest.raises(error, match=message):
                add(durer.Scene(), bad)
    with pytest.raises(TypeError, match="^material must be an integer, got list"):
        durer.Scene().add_plane((0, 0, 1), 0.0, material=[0])  # a plane is one object


def test_empty_lists_are_empty_adds_as_empty_arrays_are():
    # np.asarray([]) is float64 of shape (0,): [] is still the caller's "none", as np.zeros((0, 3)) is.
    s = scene()
    assert s.add_spheres([], []).tolist() == []
    assert s.add_spheres(np.zeros((0, 3)), 1.0, material=[], colors=[]).tolist() == []
    assert s.add_triangles([], material=[]).tolist() == []
    assert s.add_boxes([], [], colors=[]).tolist() == []
    s.move_spheres([], [])
    s.move_spheres([], [], [])
    assert s.add_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], []) == 1  # as with np.zeros((0, 3), int) faces
    assert durer.cast(s, [], []).t.shape == (0,)
    assert (s.sphere_count, s.object_count) == (1, 2)
    with pytest.raises(ValueError, match=r"^centers must have shape \(N, 3\), got \(0, 2\)"):
        s.add_spheres(np.zeros((0, 2)), 1.0)  # an explicit empty array of the wrong width is still wrong
