"""The 6.837 corpus rendered: every scene renders; the assignment-1 scenes, scene2_16's t under
scale, ellipsoid normals, the camera inside a sphere, back faces and the cube are checked against
values computed here from the scene geometry with the course's own formulas (FORMAT.md)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import durer
from durer.course.gallery import command_lines
from durer.course.raytracer import parse_arguments, render_scene_file, to_bytes
from durer.course.scene_file import SceneCamera, read_scene_file
from helpers import CORPUS

SCENES = sorted(p for p in CORPUS.glob("scene*.txt"))
A1 = [p for p in SCENES if p.name.startswith("scene1_")]
N = 200


def official_options():
    """scene name -> the options of its first official command line."""
    options = {}
    for _, line in command_lines(CORPUS / "commands.txt"):
        parsed = parse_arguments(line.split()[1:])
        options.setdefault(parsed.input.stem, parsed)
    return options


OFFICIAL = official_options()


# --- the course's geometry, in float64 --------------------------------------------------------------

def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def course_rays(camera: SceneCamera, width: int, height: int):
    """Pixel-centre rays (origins, directions), each (H, W, 3), top row first, by FORMAT.md's
    camera formulas; size or angle spans the larger image dimension."""
    d = unit(camera.direction)
    horizontal = unit(np.cross(d, camera.up))
    up = np.cross(horizontal, d)
    span = max(width, height)
    u = (np.arange(width) + 0.5 - width / 2) / span          # x − ½ for a square image
    v = (height / 2 - np.arange(height) - 0.5) / span        # y − ½, row 0 at the top
    U, V = (g[..., None] for g in np.meshgrid(u, v))
    if camera.projection == "orthographic":
        origins = np.asarray(camera.center) + U * camera.size * horizontal + V * camera.size * up
        return origins, np.broadcast_to(d, origins.shape)
    distance = 0.5 / math.tan(math.radians(camera.size) / 2)
    directions = unit(d * distance + U * horizontal + V * up)
    return np.broadcast_to(np.asarray(camera.center, dtype=np.float64), directions.shape), directions


def sphere_roots(origins, directions, center, radius):
    """Both roots of |o + t·d − c|² = r² (nan where the ray misses) and the discriminant over r²·|d|²."""
    oc = origins - np.asarray(center, dtype=np.float64)
    a = np.einsum("...i,...i", directions, directions)
    b = np.einsum("...i,...i", oc, directions)
    c = np.einsum("...i,...i", oc, oc) - radius**2
    disc = b * b - a * c
    root = np.sqrt(np.where(disc >= 0, disc, np.nan))
    return (-b - root) / a, (-b + root) / a, disc / (a * radius**2)


def first_sphere_hits(origins, directions, spheres, t_min):
    """(index of the sphere hit or -1, t, ambiguous) for world spheres [(center, radius), ...]:
    the nearest root >= t_min. `ambiguous` marks grazing rays and near ties, where rounding may
    legitimately pick the other answer."""
    shape = origins.shape[:-1]
    best_t = np.full(shape, np.inf)
    best = np.full(shape, -1)
    ambiguous = np.zeros(shape, dtype=bool)
    candidates = []
    for k, (center, radius) in enumerate(spheres):
        t0, t1, disc = sphere_roots(origins, directions, center, radius)
        t = np.where(t0 >= t_min, t0, np.where(t1 >= t_min, t1, np.nan))
        ambiguous |= np.abs(disc) < 1e-6
        candidates.append(t)
        closer = t < best_t
        best_t = np.where(closer, t, best_t)
        best = np.where(closer, k, best)
    for t in candidates:
        ambiguous |= (np.abs(t - best_t) < 1e-6) & (t != best_t)
    return best, best_t, ambiguous


def byte_window(values, slack=1e-3):
    """The bytes int(v·255) may take when v carries float32 rounding: exact unless v·255 lies within
    `slack` of an integer."""
    scaled = np.asarray(values, dtype=np.float64) * 255
    low = np.clip(np.trunc(scaled - slack), 0, 255)
    high = np.clip(np.trunc(scaled + slack), 0, 255)
    return low, high


def assert_bytes(actual, values, slack=1e-3):
    low, high = byte_window(values, slack)
    actual = np.asarray(actual)
    bad = (actual < low) | (actual > high)
    assert not bad.any(), f"{bad.sum()} bytes off, e.g. {actual[bad][:5]} not in [{low[bad][:5]}, {high[bad][:5]}]"


def flat_byte(value):
    """The byte of a colour stored as float32 in the render, by image.C's int(c·255)."""
    return np.trunc(np.float64(np.float32(value)) * 255)


def depth_grey(t, near, far):
    return (far - np.clip(t, near, far)) / (far - near)


def world_spheres(scene):
    """(center, radius) in world space of spheres under translate-and-uniform-scale transforms."""
    spheres = []
    for p in scene.primitives:
        m = p.matrix
        scale = np.linalg.norm(m[:3, 0])
        assert np.allclose(m[:3, :3], scale * np.eye(3), rtol=0, atol=1e-15), "not a uniform scale"
        spheres.append((m[:3, :3] @ p.center + m[:3, 3], scale * p.radius))
    return spheres


def render(path, width=N, height=N, **changes):
    options = OFFICIAL[Path(path).stem]
    settings = dict(shade_back=options.shade_back, shadows=options.shadows, bounces=options.bounces,
                    weight=options.weight)
    settings.update(changes)
    return render_scene_file(path, width, height, **settings)


# --- every scene ----------------------------------------------------------------------------------------

def test_every_scene_has_an_official_command_line():
    assert len(SCENES) == 49
    assert set(OFFICIAL) == {p.stem for p in SCENES}


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_every_scene_renders(path):
    result = render(path)
    assert result.color.shape == (N, N, 4) and result.depth.shape == (N, N) and result.normal.shape == (N, N, 3)
    assert np.isfinite(result.color).all()
    background = np.float32(read_scene_file(path).background)
    hits = np.isfinite(result.depth)
    # Something is in view, and the pixels that see nothing show the background.
    assert hits.mean() > 0.02
    np.testing.assert_array_equal(result.color[~hits][:, :3], np.broadcast_to(background, ((~hits).sum(), 3)))
    np.testing.assert_allclose(np.linalg.norm(result.normal[hits], axis=1), 1, atol=1e-5)


@pytest.mark.parametrize("path", [CORPUS / "scene1_03.txt", CORPUS / "scene2_04_perspective.txt",
                                  CORPUS / "scene2_14_axes_cube.txt", CORPUS / "scene4_03_mirrored_floor.txt"],
                         ids=lambda p: p.stem)
@pytest.mark.parametrize("width, height", [(200, 200), (64, 48), (30, 50)])
def test_durer_cameras_cast_the_course_rays(path, width, height):
    camera = read_scene_file(path).camera
    origins, directions = camera.to_durer().rays(width, height)
    expected_origins, expected_directions = course_rays(camera, width, height)
    np.testing.assert_allclose(origins, expected_origins, rtol=0, atol=1e-12)
    np.testing.assert_allclose(directions, expected_directions, rtol=0, atol=1e-12)


# --- assignment 1: flat colours and depth, every pixel ------------------------------------------------------

@pytest.mark.parametrize("path", A1, ids=lambda p: p.stem)
def test_assignment1_colour_and_depth_of_every_pixel(path):
    scene = read_scene_file(path)
    near, far, _ = OFFICIAL[path.stem].depth
    result = render(path)
    origins, directions = course_rays(scene.camera, N, N)
    spheres = [(p.center, p.radius) for p in scene.primitives]
    hit, t, ambiguous = first_sphere_hits(origins, directions, spheres, -math.inf)  # orthographic: t from -inf
    assert ambiguous.mean() < 0.002
    clear = ~ambiguous
    kd = np.array([scene.materials[p.material].diffuse for p in scene.primitives] + [scene.background])
    expected_colour = flat_byte(kd[hit])  # index -1: the background
    colour = to_bytes(result.color[..., :3])
    np.testing.assert_array_equal(colour[clear], expected_colour[clear])
    grey = to_bytes(durer.depth_to_gray(result.depth, near, far))
    expected_grey = np.where(hit >= 0, depth_grey(np.nan_to_num(t, posinf=far), near, far), 0.0)
    assert_bytes(grey[clear], expected_grey[clear])
    np.testing.assert_allclose(result.depth[clear & (hit >= 0)], t[clear & (hit >= 0)], rtol=1e-6, atol=1e-6)


# (scene, column, row, the sphere hit (index in file order) or None for the background)
A1_PIXELS = [
    ("scene1_01", 100, 100, 0), ("scene1_01", 0, 0, None), ("scene1_01", 139, 100, 0), ("scene1_01", 141, 100, None),
    ("scene1_02", 100, 100, 0), ("scene1_02", 140, 59, 1), ("scene1_02", 60, 140, 2), ("scene1_02", 60, 59, 3),
    ("scene1_02", 140, 140, 4), ("scene1_02", 199, 199, None),
    ("scene1_03", 100, 100, 0), ("scene1_03", 10, 10, None),
    # scene1_04/05: the green sphere at (1, 1, 1) sits on the central ray, in front of the red one
    ("scene1_04", 100, 100, 1), ("scene1_05", 100, 100, 1), ("scene1_04", 100, 60, 1),
    # scene1_05 looks along −(1, 1, 1): horizontal (1, 0, −1)/√2, up (−1, 2, −1)/√6; the sphere at (−1, 1, −1)
    # projects to (0, 1.633) -> pixel (100, 34), (1, −1, −1) to (1.414, −0.816) -> (156, 132), (−1, −1, 1) to (43, 132)
    ("scene1_05", 100, 34, 3), ("scene1_05", 156, 132, 4), ("scene1_05", 43, 132, 2),
    # scene1_06: three overlapping spheres along x = z, camera on +z: the one nearest the camera wins;
    # at x = 0.0125 the blue sphere (1, 0, 1) is still there, its front at z = 1.157
    ("scene1_06", 100, 100, 2), ("scene1_06", 140, 100, 2), ("scene1_06", 60, 100, 1), ("scene1_06", 30, 100, 0),
    # scene1_07: the camera at z = 0 inside the middle sphere sees, from t = -inf, the sphere hit first
    ("scene1_07", 100, 100, 2), ("scene1_07", 60, 100, 1), ("scene1_07", 20, 100, 0),
]


@pytest.mark.parametrize("name, column, row, sphere", A1_PIXELS)
def test_assignment1_pixels(name, column, row, sphere):
    """One pixel: the ray through its centre, which sphere it meets first and at what t."""
    path = CORPUS / f"{name}.txt"
    scene = read_scene_file(path)
    near, far, _ = OFFICIAL[name].depth
    camera = scene.camera
    d = unit(camera.direction)
    horizontal = unit(np.cross(d, camera.up))
    up = np.cross(horizontal, d)
    x, y = (column + 0.5) / N, 1 - (row + 0.5) / N
    origin = np.asarray(camera.center) + (x - 0.5) * camera.size * horizontal + (y - 0.5) * camera.size * up
    ts = []
    for p in scene.primitives:
        oc = origin - p.center
        b, c = oc @ d, oc @ oc - p.radius**2
        ts.append(-b - math.sqrt(b * b - c) if b * b >= c else math.inf)  # the nearer root: t_min is -inf
    assert (int(np.argmin(ts)) if min(ts) < math.inf else None) == sphere
    result = render(path)
    colour = to_bytes(result.color[row, column, :3])
    grey = to_bytes(durer.depth_to_gray(result.depth[row:row + 1, column:column + 1], near, far))[0, 0]
    if sphere is None:
        assert tuple(colour) == tuple(flat_byte(scene.background))
        assert grey == 0 and math.isinf(result.depth[row, column])
    else:
        kd = scene.materials[scene.primitives[sphere].material].diffuse
        assert tuple(colour) == tuple(flat_byte(kd))
        t = ts[sphere]
        assert result.depth[row, column] == pytest.approx(t, rel=1e-6)
        assert_bytes(grey, depth_grey(t, near, far))


def test_scene1_01_centre_pixel_by_hand():
    # Pixel (100, 100) of 200: x = y·(−1) = 0.5/200·5 = 0.0125; t = 10 − √(1 − 2·0.0125²).
    result = render(CORPUS / "scene1_01.txt")
    t = 10 - math.sqrt(1 - 2 * 0.0125**2)
    assert t == pytest.approx(9.000156262, rel=1e-10)
    assert result.depth[100, 100] == pytest.approx(t, rel=1e-7)  # the depth pass is float32
    assert tuple(to_bytes(result.color[100, 100, :3])) == (255, 0, 0)
    assert to_bytes(durer.depth_to_gray(result.depth, 9, 10))[100, 100] == 254  # int(0.99984·255)


# --- transforms: t under scale, ellipsoid normals ----------------------------------------------------------

def test_scene2_16_t_stays_in_world_units():
    path = CORPUS / "scene2_16_t_scale.txt"
    scene = read_scene_file(path)
    spheres = world_spheres(scene)
    assert [r for _, r in spheres] == [1.25, 1.0, 1.0, 1.0, 1.25, 0.5]
    origins, directions = course_rays(scene.camera, N, N)
    hit, t, ambiguous = first_sphere_hits(origins, directions, spheres, -math.inf)
    assert set(np.unique(hit)) == {-1, 0, 1, 2, 3, 4, 5}   # every sphere is seen somewhere
    clear = ~ambiguous & (hit >= 0)
    # cast in double: t to ~1e-9 relative although four of the spheres are scaled by 5, 2 or 0.5
    casts = durer.cast(scene.to_scene(), origins[clear], directions[clear], t_min=-math.inf)
    np.testing.assert_allclose(casts.t, t[clear], rtol=1e-9)
    file_index = np.array([p.material for p in scene.primitives])
    np.testing.assert_array_equal(casts.material_id, file_index[hit[clear]] + 1)  # Dürer's material 0 is built in
    # the depth pass (float32) and the official -depth 2 7 image
    result = render(path)
    np.testing.assert_allclose(result.depth[clear], t[clear], rtol=1e-6)
    grey = to_bytes(durer.depth_to_gray(result.depth, 2, 7))
    assert_bytes(grey[clear], depth_grey(t[clear], 2, 7))
    # colour: kd·(ambient 0.5 + 0.5·max(N·L, 0)) with the world normal of the world sphere
    centers = np.array([c for c, _ in spheres])[hit[clear]]
    radii = np.array([r for _, r in spheres])[hit[clear]]
    points = origins[clear] + t[clear, None] * directions[clear]
    normals = (points - centers) / radii[:, None]
    light = unit([0.5, 0.5, 1])
    kd = np.array([scene.materials[p.material].diffuse for p in scene.primitives])[hit[clear]]
    expected = kd * (0.5 + 0.5 * np.clip(normals @ light, 0, None))[:, None]
    assert_bytes(to_bytes(result.color[..., :3])[clear], expected)
    np.testing.assert_allclose(result.normal[clear], normals, atol=2e-6)


ELLIPSOID_PIXELS = [(100, 100), (150, 95), (60, 108), (100, 90), (30, 100), (170, 103)]


def test_scene2_11_ellipsoid_normals():
    """x² + (y/0.2)² + z² = 1 seen along −z: the normal is ∇ = (x, 25·y, z), normalised."""
    path = CORPUS / "scene2_11_squashed_sphere.txt"
    scene = read_scene_file(path)
    result = render(path)
    casts = durer.cast(scene.to_scene(), *(a.reshape(-1, 3) for a in scene.camera.to_durer().rays(N, N)),
                       t_min=-math.inf)
    light = unit([0.2, 0.2, 1])
    pixel = 2.5 / N
    for column, row in ELLIPSOID_PIXELS:
        x, y = (column + 0.5 - N / 2) * pixel, (N / 2 - row - 0.5) * pixel
        z = math.sqrt(1 - x * x - 25 * y * y)
        normal = unit([x, 25 * y, z])
        k = row * N + column
        np.testing.assert_allclose(casts.normal[k], normal, rtol=0, atol=1e-12)
        assert casts.t[k] == pytest.approx(10 - z, rel=1e-12)
        np.testing.assert_allclose(result.normal[row, column], normal, atol=2e-6)
        assert_bytes(to_bytes(result.color[row, column, :3]), np.full(3, max(normal @ light, 0.0)))
    # normals image: |n| per component
    rgb = to_bytes(durer.normal_to_rgb(result.normal))
    column, row = ELLIPSOID_PIXELS[2]
    x, y = (column + 0.5 - N / 2) * pixel, (N / 2 - row - 0.5) * pixel
    assert_bytes(rgb[row, column], np.abs(unit([x, 25 * y, math.sqrt(1 - x * x - 25 * y * y)])))


def test_scene2_13_rotated_ellipsoid_normals_by_the_inverse_transpose():
    """Squashed, then rotated by 45° about z: the ray goes into object space by M⁻¹ and the normal
    comes back by M⁻ᵀ."""
    path = CORPUS / "scene2_13_rotated_squashed_sphere.txt"
    scene = read_scene_file(path)
    c, s = math.cos(math.pi / 4), math.sin(math.pi / 4)
    m = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.diag([1, 0.2, 1])
    np.testing.assert_allclose(scene.primitives[0].matrix[:3, :3], m, rtol=0, atol=1e-16)
    origins, directions = course_rays(scene.camera, N, N)
    inverse = np.linalg.inv(m)
    o, d = origins @ inverse.T, directions @ inverse.T
    t0, _, disc = sphere_roots(o, d, (0, 0, 0), 1.0)
    seen = np.isfinite(t0) & (disc > 1e-6)
    assert 0.05 < seen.mean() < 0.5
    object_points = o[seen] + t0[seen, None] * d[seen]
    normals = unit(object_points @ inverse)  # (M⁻ᵀ n) for each row n
    casts = durer.cast(scene.to_scene(), origins[seen], directions[seen], t_min=-math.inf)
    np.testing.assert_allclose(casts.t, t0[seen], rtol=1e-10)
    np.testing.assert_allclose(casts.normal, normals, rtol=0, atol=1e-9)
    result = render(path)
    np.testing.assert_allclose(result.normal[seen], normals, atol=2e-6)


# --- scene2_05: the camera inside a sphere, with and without -shade_back ---------------------------------

@pytest.mark.parametrize("column, row", [(0, 0), (199, 0), (20, 150), (180, 199)])
@pytest.mark.parametrize("shade_back", [False, True])
def test_scene2_05_inside_the_big_sphere(column, row, shade_back):
    path = CORPUS / "scene2_05_inside_sphere.txt"
    scene = read_scene_file(path)
    origins, directions = course_rays(scene.camera, N, N)
    eye, d = origins[row, column], directions[row, column]
    # the ray misses the small green sphere at the origin, and the blue one is behind the eye
    assert np.isnan(sphere_roots(eye, d, (0, 0, 0), 1.0)[0])
    assert not sphere_roots(eye, d, (0, 0, 15), 1.0)[1] >= 0
    t_near, t_far, _ = sphere_roots(eye, d, (0, 0, 5), 6.0)
    assert t_near < 0 < t_far  # inside: only the far root is in front of the eye
    point = eye + t_far * d
    outward = (point - (0, 0, 5)) / 6
    light = unit([0.5, 0.5, 1])
    normal = -outward if shade_back and d @ outward > 0 else outward
    red = 0.2 + 0.8 * max(normal @ light, 0.0)
    result = render(path, shade_back=shade_back)
    assert result.depth[row, column] == pytest.approx(t_far, rel=1e-6)
    assert_bytes(to_bytes(result.color[row, column, :3]), np.array([red, 0, 0]))
    if (normal @ light) <= 0:
        assert tuple(to_bytes(result.color[row, column, :3])) == (51, 0, 0)  # ambient 0.2 only
    assert_bytes(to_bytes(durer.depth_to_gray(result.depth, 9, 11))[row, column], depth_grey(t_far, 9, 11))


def test_scene2_05_green_sphere_in_front():
    path = CORPUS / "scene2_05_inside_sphere.txt"
    scene = read_scene_file(path)
    origins, directions = course_rays(scene.camera, N, N)
    eye, d = origins[100, 100], directions[100, 100]
    t, _, _ = sphere_roots(eye, d, (0, 0, 0), 1.0)
    normal = (eye + t * d) / 1.0
    green = 0.2 + 0.8 * max(normal @ unit([0.5, 0.5, 1]), 0)
    result = render(path)
    assert result.depth[100, 100] == pytest.approx(t, rel=1e-6)
    assert_bytes(to_bytes(result.color[100, 100, :3]), np.array([0, green, 0]))


# --- triangles and meshes ----------------------------------------------------------------------------------

@pytest.mark.parametrize("shade_back", [False, True])
def test_scene2_07_back_facing_triangle(shade_back):
    """The lower (green) triangle's winding gives the normal (0, 0, −1), away from the camera: without
    -shade_back only the ambient term lights it, with it the flipped normal is lit."""
    path = CORPUS / "scene2_07_sphere_triangles.txt"
    scene = read_scene_file(path)
    lower = scene.primitives[2].vertices
    np.testing.assert_array_equal(unit(np.cross(lower[1] - lower[0], lower[2] - lower[0])), [0, 0, -1])
    result = render(path, shade_back=shade_back)
    origins, directions = course_rays(scene.camera, N, N)
    light = unit([0.5, 0.5, 1])
    for column, row, material, normal in [(100, 170, 2, (0, 0, -1)), (100, 30, 1, (0, 0, 1))]:
        o, d = origins[row, column], directions[row, column]
        t = -o[2] / d[2]  # the plane z = 0
        shading_normal = -np.array(normal) if shade_back and d @ normal > 0 else np.array(normal)
        kd = np.array(scene.materials[material].diffuse)
        assert result.depth[row, column] == pytest.approx(t, rel=1e-6)
        assert_bytes(to_bytes(result.color[row, column, :3]), kd * (0.1 + 0.9 * max(shading_normal @ light, 0)))
    assert tuple(to_bytes(result.color[170, 100, :3])) == ((0, 212, 0) if shade_back else (0, 25, 0))


def test_scene3_01_cube_every_pixel():
    """The cube mesh [−1, 1]³ seen by an orthographic camera: t and the face normal of every pixel by
    the slab method, and its diffuse colour."""
    path = CORPUS / "scene3_01_cube_orthographic.txt"
    scene = read_scene_file(path)
    origins, directions = course_rays(scene.camera, N, N)
    with np.errstate(divide="ignore"):
        t1, t2 = (-1 - origins) / directions, (1 - origins) / directions
    t_enter = np.minimum(t1, t2).max(axis=-1)
    t_exit = np.maximum(t1, t2).min(axis=-1)
    hit = t_enter < t_exit
    axis = np.minimum(t1, t2).argmax(axis=-1)
    # away from edges, where the slab entries of two axes tie
    entries = np.sort(np.minimum(t1, t2), axis=-1)
    clear = ~hit | ((entries[..., 2] - entries[..., 1] > 1e-6) & (t_exit - t_enter > 1e-6))
    clear &= np.abs(t_exit - t_enter) > 1e-6
    normals = np.zeros(origins.shape)
    rows, cols = np.nonzero(hit)
    normals[rows, cols, axis[rows, cols]] = -np.sign(directions[rows, cols, axis[rows, cols]])
    result = render(path)
    assert (np.isfinite(result.depth) == hit)[clear].all()
    np.testing.assert_allclose(result.depth[hit & clear], t_enter[hit & clear], rtol=1e-6)
    np.testing.assert_allclose(result.normal[hit & clear], normals[hit & clear], atol=1e-6)
    light = unit([0.5, 0.3, 1])
    red = 0.1 + 0.9 * np.clip(normals @ light, 0, None)
    expected = np.stack([red, np.zeros_like(red), np.zeros_like(red)], axis=-1)
    assert_bytes(to_bytes(result.color[..., :3])[hit & clear], expected[hit & clear])
    assert {tuple(n) for n in normals[hit & clear].astype(int)} == {(1, 0, 0), (0, 1, 0), (0, 0, 1)}


def test_scene4_03_open_mirror_floor():
    """Floor points (two Triangles, kd 0.3, mirror 0.7) whose shadow rays reach both lights and whose
    mirror ray leaves the scene: ambient and diffuse only, 0.3·(0.1 + 0.7·N·L1 + 0.2·N·L2) = 0.218530 -> byte 55."""
    path = CORPUS / "scene4_03_mirrored_floor.txt"
    scene_file = read_scene_file(path)
    scene = scene_file.to_scene()
    origins, directions = scene_file.camera.to_durer().rays(N, N)
    origins, directions = origins.reshape(-1, 3), directions.reshape(-1, 3)
    first = durer.cast(scene, origins, directions)
    floor = first.material_id == 1  # file material 0
    # The test's own secondary rays start 1e-9 above the floor (y = 0 exactly), clear of it.
    points = origins[floor] + first.t[floor, None] * directions[floor] + [0, 1e-9, 0]
    lights = [unit([0.3, 0.5, 0.5]), unit([-0.3, 1, 0.5])]
    mirror = directions[floor] * [1, -1, 1]
    open_sky = np.ones(len(points), dtype=bool)
    for toward in [*(np.broadcast_to(v, points.shape) for v in lights), mirror]:
        open_sky &= np.isinf(durer.cast(scene, points, np.ascontiguousarray(toward)).t)
    assert open_sky.mean() > 0.5
    expected = 0.3 * (0.1 + 0.7 * lights[0][1] + 0.2 * lights[1][1])
    assert expected == pytest.approx(0.218530, abs=1e-6)
    result = render(path)
    colour = to_bytes(result.color[..., :3]).reshape(-1, 3)[floor][open_sky]
    assert_bytes(colour, np.full(colour.shape, expected))
