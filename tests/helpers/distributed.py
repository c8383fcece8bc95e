"""Small scenes for the distributed tests: every kind of object, light and effect."""

from __future__ import annotations

import numpy as np

import durer

#: Every wait on a cluster in these tests is bounded by this many seconds.
TIMEOUT = 120


def every_kind_scene(seed: int = 7) -> durer.Scene:
    """Spheres, a bounded plane, triangles, a mesh, boxes, a transformed group, three kinds of
    lights with shadows, a mirror and glass: every add a scene records."""
    rng = np.random.default_rng(seed)
    scene = durer.Scene()
    scene.background = (0.1, 0.2, 0.3, 0.9)
    scene.ambient = (0.05, 0.05, 0.05)
    red = scene.add_material(diffuse=(0.9, 0.1, 0.1), specular=(0.5, 0.5, 0.5), exponent=20)
    mirror = scene.add_material((0.05, 0.05, 0.05), reflective=(0.8, 0.8, 0.8))
    glass = scene.add_material((0, 0, 0), transparent=(0.9, 0.9, 0.9), ior=1.5)
    scene.add_spheres(rng.uniform(-2, 2, (40, 3)), rng.uniform(0.1, 0.4, 40), material=red)
    scene.add_spheres([[0, 0.5, 0], [1.5, 0.5, 1]], 0.6, material=np.array([mirror, glass]))
    scene.add_plane((0, 1, 0), -2.0)
    scene.add_plane((0, 0, 1), -3.0, bounds=((-3, -2, -3), (6, 0, 0), (0, 4, 0)), material=red)
    scene.add_triangles([[[-2, 1, 1], [-1, 1, 1], [-1.5, 2, 1]]], red)
    cube = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    faces = [[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
             [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]]
    scene.add_mesh(cube * 0.5 + (1, -1, -1), faces, mirror)
    squash = np.diag([1.5, 0.5, 1.0, 1.0])
    squash[:3, 3] = (-1, -1, 1)
    scene.add_boxes([[-0.5, -0.5, -0.5]], [[0.5, 0.5, 0.5]], glass, transform=squash)
    scene.add_spheres([[0, 0, 0]], 0.5, red, transform=squash)
    scene.add_directional_light((-1, -1, -1), (0.8, 0.8, 0.8), shadows=True)
    scene.add_point_light((0, 4, 3), (10, 10, 10), attenuation=(0, 0, 1), shadows=True)
    scene.add_spot_light((2, 4, 2), (0, -1, 0), (5, 5, 5), half_angle_degrees=30, blend=0.2)
    return scene


def orbit_cameras(count: int) -> list[durer.PerspectiveCamera]:
    """`count` cameras on a circle around the origin, looking at it."""
    cameras = []
    for angle in np.linspace(0, 2 * np.pi, count, endpoint=False):
        center = (6 * np.sin(angle), 2.0, 6 * np.cos(angle))
        cameras.append(durer.PerspectiveCamera(center, tuple(-np.array(center)), (0, 1, 0), fov_degrees=50))
    return cameras


def assert_same_image(a: durer.RenderResult, b: durer.RenderResult) -> None:
    """Bit-identical passes (NaN-free float32 arrays, inf where nothing was hit)."""
    for name in durer.RenderResult.ARRAYS:
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None) == (y is None), name
        if x is not None:
            assert x.shape == y.shape and x.dtype == y.dtype, name
            assert np.array_equal(x.view(np.uint8), y.view(np.uint8)), f"{name} differs"


#: Blender's metadata stamps that name the .blend's path (a worker renders a copy elsewhere) or the
#: time: they differ between any two runs.
VOLATILE_STAMPS = {"File", "Date", "Time", "RenderTime"}


def assert_same_image_file(a, b) -> None:
    """Two image files hold the same pixels (and passes) bit for bit and the same metadata stamps
    but for VOLATILE_STAMPS."""
    from pathlib import Path

    from PIL import Image

    if Path(a).suffix == ".exr":
        from helpers.exr import read_exr

        x, y = read_exr(a), read_exr(b)
        assert x.keys() == y.keys() and len(x) > 4, sorted(x)
        for name in x:
            assert np.array_equal(x[name].view(np.uint8), y[name].view(np.uint8)), name
        return
    with Image.open(a) as x, Image.open(b) as y:
        assert np.array_equal(np.asarray(x), np.asarray(y)), f"{a} and {b} differ"
        assert {k: v for k, v in x.info.items() if k not in VOLATILE_STAMPS | {"exif"}} == \
            {k: v for k, v in y.info.items() if k not in VOLATILE_STAMPS | {"exif"}}
