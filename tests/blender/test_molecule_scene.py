"""scenes/molecule.blend (issue 14's molecule showcase), made by scenes/make_molecule.py from a seed:
one point cloud of atoms whose `Color` attribute gives each its element's colour in the render,
shadowed by a sun and darkened in its crevices by the ambient occlusion the file turns on through
Cycles' Fast GI."""

from __future__ import annotations

import importlib.util
import subprocess
import sys

import numpy as np
import pytest
from helpers import SCENES
from helpers.blender import export, render_passes

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

import durer.blender  # noqa: E402
from bpy_extras.object_utils import world_to_camera_view  # noqa: E402
from durer.blender import engine  # noqa: E402
from mathutils import Vector  # noqa: E402

pytestmark = pytest.mark.blender


def load_script(path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def make_molecule():
    return load_script(SCENES / "make_molecule.py")


def open_molecule(path=SCENES / "molecule.blend"):
    durer.blender.register()
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    return bpy.context.scene


def atom_attributes() -> dict[str, np.ndarray]:
    """The Protein mesh's point attributes and vertex positions, as the file holds them."""
    mesh = bpy.data.objects["Protein"].data
    n = len(mesh.vertices)
    out = {"co": np.empty(3 * n, np.float32), "element": np.empty(n, np.int32), "radius": np.empty(n, np.float32),
           "Color": np.empty(4 * n, np.float32)}
    mesh.vertices.foreach_get("co", out["co"])
    for name, field in (("element", "value"), ("radius", "value"), ("Color", "color")):
        mesh.attributes[name].data.foreach_get(field, out[name])
    return out


def test_the_script_makes_the_file_from_the_seed(make_molecule, tmp_path):
    positions, elements = make_molecule.molecule()
    again, same = make_molecule.molecule()
    np.testing.assert_array_equal(again, positions)
    assert same == elements and set(elements) == set(make_molecule.ELEMENTS)
    counts = [elements.count(e) for e in ("H", "C", "O", "N", "S")]
    assert 3000 < len(elements) < 4000 and counts == sorted(counts, reverse=True) and counts[-1] > 0
    other, _ = make_molecule.molecule(seed=make_molecule.SEED + 1)
    assert other.shape != positions.shape or not np.allclose(other, positions)

    out = tmp_path / "molecule.blend"
    done = subprocess.run([sys.executable, str(SCENES / "make_molecule.py"), str(out)], check=False,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    open_molecule(out)
    made = atom_attributes()
    numbers, radii, colors = make_molecule.atom_table(elements)
    np.testing.assert_allclose(made["co"].reshape(-1, 3), positions, atol=1e-6)
    np.testing.assert_array_equal(made["element"], numbers)
    np.testing.assert_array_equal(made["radius"], radii)
    np.testing.assert_array_equal(made["Color"].reshape(-1, 4), colors)
    open_molecule()  # the committed file is the one the script makes
    for name, values in atom_attributes().items():
        np.testing.assert_array_equal(values, made[name], err_msg=name)


@pytest.fixture
def molecule():
    """The committed file at 192x108, one ray through each pixel centre, the atoms' Pass Index 1."""
    s = open_molecule()
    s.render.resolution_percentage = 20
    s.durer.samples = 1
    s.durer.sampler = "CENTER"
    bpy.data.objects["Protein"].pass_index = 1
    return s


def test_the_export_reads_each_atoms_radius_and_element_colour(make_molecule, molecule):
    s = molecule
    assert s.render.engine == "DURER" and s.cycles.use_fast_gi and s.durer.ambient_occlusion == "AUTO"
    data = export(s)
    attributes = atom_attributes()
    cpk = {number: color for number, _, color in make_molecule.ELEMENTS.values()}
    assert data.sphere_count == len(attributes["element"]) and data.ambient_occlusion == (16, 1.0)
    np.testing.assert_allclose(data.sphere_radii, attributes["radius"], rtol=1e-7)
    # kd is the colour times the Principled BSDF's (1 - F0): F0 = 0.04 at IOR 1.5, Specular IOR Level 0.5.
    np.testing.assert_allclose(data.sphere_colors, [np.multiply(cpk[z], 0.96) for z in attributes["element"]],
                               rtol=1e-6)


def image_size(s) -> tuple[int, int]:
    """(height, width) in pixels."""
    return tuple(n * s.render.resolution_percentage // 100 for n in (s.render.resolution_y, s.render.resolution_x))


def first_atoms(s, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The atom each pixel's ray (through its centre, top row first) meets first, -1 for the ground
    or nothing, and the distance of that hit along the view axis: ray–sphere intersections with
    every atom, in numpy."""
    attributes = atom_attributes()
    centres, radii = attributes["co"].reshape(-1, 3).astype(np.float64), attributes["radius"].astype(np.float64)
    top_right, _, bottom_left, top_left = (np.array(v) for v in s.camera.data.view_frame(scene=s))
    h, w = image_size(s)
    u, v = (cols[:, None] + 0.5) / w, (rows[:, None] + 0.5) / h
    local = top_left + u * (top_right - top_left) + v * (bottom_left - top_left)
    rotation = np.array(s.camera.matrix_world.to_3x3())
    directions = local @ rotation.T / np.linalg.norm(local, axis=1, keepdims=True)
    to_centres = centres[None] - np.array(s.camera.location)  # (pixels, atoms, 3)
    along = np.einsum("pac,pc->pa", to_centres, directions)
    miss2 = np.einsum("pac,pac->pa", to_centres, to_centres) - along**2
    t = np.where(miss2 < radii**2, along - np.sqrt(np.maximum(radii**2 - miss2, 0)), np.inf)
    first = np.argmin(t, axis=1)
    t_first = t[np.arange(len(first)), first]
    forward = -rotation[:, 2]
    return np.where(np.isfinite(t_first), first, -1), t_first * (directions @ forward)


def atom_centre_pixels(s, element: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns (top row first) of the pixels the atoms of `element` project into."""
    attributes = atom_attributes()
    h, w = image_size(s)
    xy = np.array([world_to_camera_view(s, s.camera, Vector(co))[:2] for co, z in
                   zip(attributes["co"].reshape(-1, 3), attributes["element"]) if z == element])
    return ((1 - xy[:, 1]) * h).astype(int), (xy[:, 0] * w).astype(int)


def test_element_colours_show_in_the_render_with_the_suns_shadow(make_molecule, molecule, tmp_path):
    passes = render_passes(molecule, tmp_path / "molecule.exr", normal=False, indexes=True)
    info = engine.last_render
    assert info.error is None and info.warnings == [] and (info.planes, info.spheres) == (1, 3519)
    assert {"colors", "shadows", "ambient_occlusion"} <= set(info.stats["effects"])
    assert info.stats["shadow_rays"] > 0.5 * info.stats["rays"]
    # The ground far behind the molecule: its colour times the ambient light and the sun's (Dürer's
    # Sun of strength S lights as S/pi, at cos 1/|travel| here). Where the ray from the atom nearest
    # the molecule's centre along the sun's light meets the ground: the ambient light alone, as
    # much of it as occlusion leaves (proportional to ground × ambient: no white sunlight in it).
    m = make_molecule
    ground, ambient, travel = (np.array(v) for v in (m.GROUND, m.AMBIENT, m.SUN_TRAVEL))
    lit = ground * (ambient + m.SUN_STRENGTH / np.pi / np.linalg.norm(travel))
    np.testing.assert_allclose(passes["color"][:10, :10, :3], np.broadcast_to(lit, (10, 10, 3)), rtol=1e-5)
    centres = atom_attributes()["co"].reshape(-1, 3)
    inner = centres[np.argmin(np.linalg.norm(centres - centres.mean(axis=0), axis=1))]
    x, y, _ = world_to_camera_view(molecule, molecule.camera, Vector(inner + inner[2] / -travel[2] * travel))
    h, w = image_size(molecule)
    row, col = int((1 - y) * h), int(x * w)
    assert passes["IndexOB"][row, col] == 0  # the ground
    share = passes["color"][row, col, :3] / (ground * ambient)
    assert 0.3 < share[0] < 1 + 1e-6 and np.allclose(share, share[0], rtol=1e-5)
    elements = atom_attributes()["element"]
    rgb = passes["color"][..., :3]

    def dominated_by(element: int, channel: int) -> np.ndarray:
        """At the pixels whose ray meets an atom of `element` first (among those its atoms project
        into), whether `channel` is more than twice each other one; pixels black in shadow and
        fully occluded left out."""
        rows, cols = atom_centre_pixels(molecule, element)
        first, depth = first_atoms(molecule, rows, cols)
        seen = first >= 0
        np.testing.assert_allclose(passes["depth"][rows, cols][seen], depth[seen], rtol=1e-4)  # float32 hits
        hits = seen & (elements[np.maximum(first, 0)] == element)
        colour = rgb[rows[hits], cols[hits]]
        colour = colour[colour.sum(axis=1) > 0.01]
        assert len(colour) >= 20, element
        return colour[:, channel] > 2 * np.delete(colour, channel, axis=1).max(axis=1)

    assert dominated_by(8, 0).all() and dominated_by(7, 2).all()  # oxygen red, nitrogen blue
    assert not dominated_by(6, 0).any() and not dominated_by(6, 2).any()  # carbon grey
    assert not dominated_by(1, 0).any() and not dominated_by(1, 2).any()  # hydrogen white


def test_ambient_occlusion_darkens_the_atoms_and_nothing_far_from_them(molecule, tmp_path):
    molecule.durer.ambient_occlusion = "OFF"
    off = render_passes(molecule, tmp_path / "off.exr", normal=False, indexes=True)
    assert engine.last_render.stats["ao_rays"] == 0
    molecule.durer.ambient_occlusion = "AUTO"  # the file's: on, as Cycles' Fast GI is
    on = render_passes(molecule, tmp_path / "on.exr", normal=False, indexes=True)
    stats = engine.last_render.stats
    h, w = on["depth"].shape
    assert stats["ao_rays"] == 16 * w * h  # every pixel sees an atom or the ground
    atoms = on["IndexOB"] == 1
    assert atoms.mean() > 0.1
    luminance = {name: passes["color"][..., :3] @ [0.2126, 0.7152, 0.0722] for name, passes in
                 (("off", off), ("on", on))}
    assert luminance["on"][atoms].mean() < 0.85 * luminance["off"][atoms].mean()
    # The ground at the top of the image lies metres behind the molecule: nothing occludes it.
    np.testing.assert_allclose(on["color"][:10], off["color"][:10], rtol=1e-6)


def test_the_bench_renders_it_with_both_engines_and_saves_their_images(tmp_path):
    bench = load_script(SCENES.parent / "bench" / "showcase_vs_cycles.py")
    out = bench.compare_engines(SCENES / "molecule.blend", 64, 36, samples=1, cycles_samples=2, images=tmp_path)
    assert out["samples"] == 1 and out["cycles_samples"] == 2 and bpy.context.scene.cycles.samples == 2
    assert out["durer"]["spheres"] == 3519 and out["durer"]["ao_rays"] == 16 * 64 * 36
    assert bench.report(out, None)[0] == "molecule.blend at 64x36, Dürer 1, Cycles 2 sample(s); median of 1 runs"
    for name in ("durer", "cycles"):
        path = tmp_path / f"molecule-{name}.png"
        image = bpy.data.images.load(str(path))
        assert tuple(image.size) == (64, 36) and image.file_format == "PNG"
        assert path.read_bytes()[25] == 2  # the PNG header's colour type: RGB, no alpha
