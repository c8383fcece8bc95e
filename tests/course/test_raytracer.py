"""The `raytracer` command, `render_scene_file`, `SceneFile.to_scene` and the `gallery` command."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import durer
from durer.course import gallery, raytracer
from durer.course.raytracer import RaytracerOptions, parse_arguments, render_scene_file, to_bytes, write_image
from durer.course.scene_file import SceneFileError, read_scene_file
from durer.render import DEFAULT_PASSES
from helpers import ROOT

CORPUS = ROOT / "scenes" / "6837"


# --- bytes and images ------------------------------------------------------------------------------

def test_to_bytes_truncates_then_clamps():
    values = np.array([0.0, 0.5, 1.0, 1.2, -0.1, 0.999, 0.1, 0.2, 3.0 / 255, 2.9999 / 255])
    np.testing.assert_array_equal(to_bytes(values), [0, 127, 255, 255, 0, 254, 25, 51, 3, 2])
    assert to_bytes(values).dtype == np.uint8


def test_write_image_png_and_tga(tmp_path):
    rgb = np.zeros((2, 3, 3), dtype=np.uint8)
    rgb[0, 0] = (255, 0, 0)   # top left: red
    rgb[1, 2] = (1, 2, 3)     # bottom right
    for name in ("a.png", "b.TGA"):
        path = write_image(tmp_path / name, rgb)
        with Image.open(path) as image:
            assert image.mode == "RGB" and image.size == (3, 2)
            np.testing.assert_array_equal(np.asarray(image), rgb)
    data = (tmp_path / "b.TGA").read_bytes()
    # the course's SaveTGA header: uncompressed true colour, 24 bits, top-left origin; pixels B, G, R
    assert (data[2], data[16], data[17]) == (2, 24, 0x20)
    assert data[12:16] == bytes([3, 0, 2, 0])
    assert data[18:21] == bytes([0, 0, 255]) and data[18 + 15:18 + 18] == bytes([3, 2, 1])
    with pytest.raises(ValueError, match=r"c.jpg: the image must end in .png or .tga"):
        write_image(tmp_path / "c.jpg", rgb)


# --- options ----------------------------------------------------------------------------------------

def test_full_command_line():
    options = parse_arguments("-input s.txt -size 64 48 -output o.tga -depth -2 2.5 d.png -normals n.tga "
                              "-shade_back -shadows -bounces 3 -weight 0.01 -spp 4 -precision float".split())
    assert options == RaytracerOptions(Path("s.txt"), 64, 48, Path("o.tga"), (-2.0, 2.5, Path("d.png")),
                                       Path("n.tga"), True, True, 3, 0.01, 4, "float", ())
    assert options.passes == DEFAULT_PASSES


def test_defaults_and_passes():
    options = parse_arguments(["-input", "s.txt", "-size", "200", "200", "-output", "o.png"])
    assert (options.shade_back, options.shadows, options.bounces, options.weight, options.spp, options.precision) == (
        False, False, 0, 0.0, 1, "double")
    assert options.passes == ("color",)
    assert parse_arguments("-input s -size 1 1 -output o.png -normals n.png".split()).passes == ("color", "normal")


def test_preview_options_are_accepted_and_ignored():
    options = parse_arguments("-input s.txt -size 200 200 -output o.tga -gui -tessellation 100 50 -gouraud".split())
    assert options.ignored == ("-gui", "-tessellation", "-gouraud")
    assert options == RaytracerOptions(Path("s.txt"), 200, 200, Path("o.tga"), ignored=options.ignored)


@pytest.mark.parametrize("arguments, message", [
    ("-size 2 2 -output o.png", "the following arguments are required: -input"),
    ("-input s.txt -size 2 -output o.png", "argument -size: expected 2 arguments"),
    ("-input s.txt -size 2 x -output o.png", "argument -size: invalid int value: 'x'"),
    # render's limits (the core's among them), named by the course's options, before the scene is read
    ("-input s.txt -size 0 2 -output o.png", "-size WIDTH must be >= 1, got 0"),
    ("-input s.txt -size 10 9999999 -output o.png", "-size HEIGHT must be <= 1048576, got 9999999"),
    ("-input s.txt -size 2 2 -output o.png -bounces 5000", "-bounces must be in [0, 1000], got 5000"),
    ("-input s.txt -size 2 2 -output o.png -spp 2000000", "-spp must be in [1, 1048576], got 2000000"),
    ("-input s.txt -size 2 2 -output o.jpg", "-output o.jpg: the image must end in .png or .tga"),
    ("-input s.txt -size 2 2 -output o.png -depth 5 5 d.png", "-depth needs MIN < MAX, got 5 5"),
    ("-input s.txt -size 2 2 -output o.png -depth a 5 d.png", "-depth MIN must be a number, got 'a'"),
    ("-input s.txt -size 2 2 -output o.png -depth 1 5 d.bmp", "-depth d.bmp: the image must end in .png or .tga"),
    ("-input s.txt -size 2 2 -output o.png -normals n", "-normals n: the image must end in .png or .tga"),
    ("-input s.txt -size 2 2 -output o.png -bounces -1", "-bounces must be in [0, 1000], got -1"),
    ("-input s.txt -size 2 2 -output o.png -weight nan", "-weight must be finite and >= 0, got nan"),
    ("-input s.txt -size 2 2 -output o.png -spp 0", "-spp must be in [1, 1048576], got 0"),
    ("-input s.txt -size 2 2 -output o.png -precision half", "argument -precision: invalid choice: 'half'"),
    ("-input s.txt -size 2 2 -output o.png -foo", "unrecognized option: -foo"),
    ("-inp s.txt -size 2 2 -output o.png", "unrecognized option: -inp"),  # no abbreviations
    # before the render, not a traceback after it (Pillow's OverflowError writing the header)
    ("-input s.txt -size 70000 1 -output o.png -depth 9 10 d.tga",
     "-depth d.tga: a TGA image is at most 65535 pixels wide and tall, got -size 70000 1"),
    ("-input s.txt -size 2 2 -output o.png -depth 9 10 o.png",  # the colour image was overwritten, exit 0
     "-output and -depth name the same image o.png: the second would overwrite the first"),
    ("-input s.txt -size 2 2 -output o.png -normals ./o.png",
     "-output and -normals name the same image o.png: the second would overwrite the first"),
])
def test_bad_options_exit_with_code_2(capsys, arguments, message):
    with pytest.raises(SystemExit) as info:
        raytracer.main(arguments.split())
    assert info.value.code == 2
    error = capsys.readouterr().err
    assert error.startswith("usage: python -m durer raytracer")
    assert message in error


def test_malformed_scene_exits_with_code_1(tmp_path, capsys):
    scene = tmp_path / "bad.txt"
    scene.write_text("Group {\n numObjects 1\n MaterialIndex 0\n Sphere { center 0 0 0 radius abc } }\n")
    assert raytracer.main(["-input", str(scene), "-size", "4", "4", "-output", str(tmp_path / "o.png")]) == 1
    assert capsys.readouterr().err == f"raytracer: error: {scene}:4: expected a number for 'radius', got 'abc'\n"
    assert not (tmp_path / "o.png").exists()


FAR_SPHERE = """OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }
Materials { numMaterials 1 Material { diffuseColor 1 0 0 } }
Group {
 numObjects 2
 MaterialIndex 0
 Sphere { center 0 0 0 radius 1 }
 Sphere { center 0 0 -1e20 radius 1 }
}
"""


def test_what_only_double_holds_is_refused_in_float_at_the_items_line(tmp_path, capsys):
    scene = tmp_path / "far.txt"
    scene.write_text(FAR_SPHERE)
    assert 9 < render_scene_file(scene, 4, 4, precision="double").depth[2, 2] < 10  # double holds 1e20
    arguments = ["-input", str(scene), "-size", "4", "4", "-output", str(tmp_path / "o.png"), "-precision", "float"]
    assert raytracer.main(arguments) == 1
    error = capsys.readouterr().err
    assert error.startswith(f"raytracer: error: {scene}:7: Dürer cannot render this Sphere with precision='float': ")
    assert "1e+18" in error and error.count("\n") == 1
    scene.write_text(FAR_SPHERE.replace("center 0 0 10 direction", "center 0 0 1e30 direction"))
    with pytest.raises(SceneFileError, match=r"far.txt:1: Dürer cannot render this OrthographicCamera with precision='float'"):
        render_scene_file(scene, 4, 4, precision="float")


def test_missing_scene_file_exits_with_code_1(tmp_path, capsys):
    assert raytracer.main(["-input", str(tmp_path / "nope.txt"), "-size", "4", "4", "-output", "o.png"]) == 1
    assert "No such file or directory" in capsys.readouterr().err


def test_output_under_a_file_and_images_too_large_for_memory_exit_with_one_line(tmp_path, capsys):
    scene = ROOT / "scenes" / "6837" / "scene1_01.txt"
    (tmp_path / "a_file").write_text("")
    assert raytracer.main(["-input", str(scene), "-size", "4", "4", "-output", str(tmp_path / "a_file" / "o.png")]) == 1
    assert capsys.readouterr().err == f"raytracer: error: [Errno 20] '{tmp_path / 'a_file'}' is a file, not a folder\n"
    # 10^12 pixels: their float32 buffers (16 TB) cannot be allocated on any machine
    assert raytracer.main(["-input", str(scene), "-size", "1000000", "1000000", "-output", str(tmp_path / "o.png")]) == 1
    assert capsys.readouterr().err == "raytracer: error: not enough memory for a 1000000x1000000 image\n"


def test_a_scene_needs_a_camera(tmp_path):
    path = tmp_path / "s.txt"
    path.write_text("Background { color 1 0 0 }")
    with pytest.raises(ValueError, match=r"s.txt: the scene has no camera"):
        render_scene_file(path, 4, 4)


@pytest.mark.parametrize("options, error, name", [
    ({"bounces": -1}, ValueError, "bounces"),
    ({"bounces": 1.5}, TypeError, "bounces"),
    ({"weight": "x"}, TypeError, "weight"),
    ({"weight": -0.5}, ValueError, "weight"),
    ({"spp": 0}, ValueError, "spp"),
    ({"passes": ["colour"]}, ValueError, "passes"),
])
def test_bad_options_are_named_as_render_scene_file_names_them(tmp_path, options, error, name):
    """durer.render calls them max_bounces and min_weight; the caller passed bounces and weight. The
    options are checked before the file is read (this one does not exist)."""
    with pytest.raises(error, match=rf"^{name} must be "):
        render_scene_file(tmp_path / "never_read.txt", 4, 4, **options)


def test_passes_may_be_one_name():
    result = render_scene_file(CORPUS / "scene1_01.txt", 8, 8, passes="color")
    assert result.stats["passes"] == ("color",) and result.depth is None and result.normal is None


CAMERA_AND_BACKGROUND = ("OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
                         "Background { color 0.25 0.5 0.75 }\n")


@pytest.mark.parametrize("groups", ["", "Group { numObjects 0 }\n", "Group { numObjects 1 Group { numObjects 0 } }\n"],
                         ids=["no Group", "an empty Group", "nested empty Groups"])
def test_a_scene_with_nothing_to_render_warns(tmp_path, capsys, groups):
    """Legal (an empty Group says so explicitly) but seldom meant: the API warns, the command says so on
    stderr and renders the background with exit code 0."""
    path = tmp_path / "s.txt"
    path.write_text(CAMERA_AND_BACKGROUND + groups)
    message = (f"{path}: nothing to render: no Sphere, Plane, Triangle or TriangleMesh (no Group block, or only "
               "empty ones); the image is the background colour")
    with pytest.warns(raytracer.EmptySceneWarning, match=f"^{re.escape(message)}$"):
        result = render_scene_file(path, 4, 4, passes="color")
    np.testing.assert_allclose(result.color[..., :3], np.broadcast_to([0.25, 0.5, 0.75], (4, 4, 3)))
    assert raytracer.main(["-input", str(path), "-size", "4", "4", "-output", str(tmp_path / "o.png")]) == 0
    assert capsys.readouterr().err == f"raytracer: warning: {message}\n"
    assert (tmp_path / "o.png").exists()


def test_an_empty_group_beside_objects_renders_without_a_warning(tmp_path):
    path = tmp_path / "s.txt"
    path.write_text(CAMERA_AND_BACKGROUND + "Materials { numMaterials 1 Material { diffuseColor 1 0 0 } }\n"
                    "Group { numObjects 2 Group { numObjects 0 } MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }\n")
    render_scene_file(path, 4, 4)  # the suite turns any warning into an error


# --- to_scene ----------------------------------------------------------------------------------------

def test_to_scene_objects_materials_lights():
    scene_file = read_scene_file(CORPUS / "scene4_03_mirrored_floor.txt")
    scene = scene_file.to_scene()
    assert scene.object_count == 2 + 3           # two triangles, three meshes (one object each)
    assert scene.material_count == 1 + 4         # Dürer's default material 0, then the file's four
    assert scene.light_count == 2
    assert scene.ambient == (0.1, 0.1, 0.1) and scene.background == (0, 0, 0, 1)
    # straight down onto the mirrored floor (file material 0), and onto the green bar's top (material 2)
    hits = durer.cast(scene, [[3, 5, 3], [0, 10, -2]], [[0, -1, 0], [0, -1, 0]])
    np.testing.assert_array_equal(hits.material_id, [1, 3])
    # the bar: Translate 0 2 -2, Scale 1.6 0.3 0.1, Translate 0 1 0 on the cube [-1, 1]³: top at y = 2 + 0.3·2
    np.testing.assert_allclose(hits.t, [5, 10 - 2.6], rtol=1e-12)
    np.testing.assert_allclose(hits.normal, [[0, 1, 0], [0, 1, 0]], atol=1e-12)


def test_to_scene_without_lights_keeps_flat_shading():
    scene_file = read_scene_file(CORPUS / "scene1_02.txt")
    scene = scene_file.to_scene()
    assert scene.light_count == 0 and scene.ambient == (0, 0, 0)   # flat: 6.837's forced ambient of 1
    result = durer.render(scene, scene_file.camera.to_durer(), 8, 8)
    assert result.stats["effects"] == ("flat",)


def test_to_scene_batches_spheres_and_triangles_by_matrix(monkeypatch):
    # Read first: the reader makes each item alone to see whether the core takes it.
    files = {name: read_scene_file(CORPUS / name) for name in (
        "scene3_09_exponent_variations.txt", "scene2_16_t_scale.txt", "scene4_12_point_light_circle_d_attenuation.txt",
        "scene4_03_mirrored_floor.txt")}
    calls: dict[str, int] = {}
    for name in ("add_spheres", "add_triangles", "add_mesh", "add_plane"):
        original = getattr(durer.Scene, name)

        def counted(self, *args, _original=original, _name=name, **kwargs):
            calls[_name] = calls.get(_name, 0) + 1
            return _original(self, *args, **kwargs)

        monkeypatch.setattr(durer.Scene, name, counted)
    files["scene3_09_exponent_variations.txt"].to_scene()   # 9 spheres, no transform
    assert calls == {"add_spheres": 1}
    calls.clear()
    files["scene2_16_t_scale.txt"].to_scene()    # 6 spheres, 5 distinct transforms
    assert calls == {"add_spheres": 6}
    calls.clear()
    files["scene4_12_point_light_circle_d_attenuation.txt"].to_scene()
    assert calls == {"add_plane": 1, "add_mesh": 3, "add_spheres": 3}
    calls.clear()
    files["scene4_03_mirrored_floor.txt"].to_scene()
    assert calls == {"add_triangles": 1, "add_mesh": 3}


def test_transforms_reach_the_scene_only_when_not_identity(monkeypatch):
    seen = []
    original = durer.Scene.add_spheres

    def spy(self, centers, radii, material=0, *, transform=None):
        seen.append(transform)
        return original(self, centers, radii, material, transform=transform)

    scene_file = read_scene_file(CORPUS / "scene2_16_t_scale.txt")
    monkeypatch.setattr(durer.Scene, "add_spheres", spy)
    scene_file.to_scene()
    assert sum(t is None for t in seen) == 1
    np.testing.assert_array_equal(seen[0], [[5, 0, 0, -1.25], [0, 5, 0, -1.25], [0, 0, 5, -2], [0, 0, 0, 1]])


@pytest.mark.parametrize("shadows", [False, True])
def test_shadows_option_makes_every_light_cast_shadows(shadows):
    result = render_scene_file(CORPUS / "scene4_01_sphere_shadow.txt", 40, 40, shadows=shadows)
    assert ("shadows" in result.stats["effects"]) == shadows
    assert (result.stats["shadow_rays"] > 0) == shadows


def test_render_scene_file_options_reach_the_renderer():
    path = CORPUS / "scene4_04_reflective_sphere.txt"
    result = render_scene_file(read_scene_file(path), 30, 20, bounces=2, weight=0.01, spp=4, precision="float",
                               passes=("color",))
    assert result.stats["spp"] == 4 and result.stats["precision"] == "float"
    assert result.depth is None and result.normal is None and result.color.shape == (20, 30, 4)
    assert "reflection" in result.stats["effects"] and result.stats["reflection_rays"] > 0
    assert render_scene_file(path, 30, 20).stats["reflection_rays"] == 0  # -bounces 0 is the course default


# --- the command, end to end --------------------------------------------------------------------------------

def test_command_end_to_end(tmp_path):
    """scene1_01 at 40×30: size 5 spans the width, so pixels are 0.125 wide; pixel (20, 15) is centred
    at (0.0625, −0.0625) and meets the unit sphere at z = √(1 − 2·0.0625²) = 0.996086, t = 9.003914."""
    out = tmp_path / "out"
    command = [sys.executable, "-m", "durer", "raytracer", "-input", str(CORPUS / "scene1_01.txt"), "-size", "40",
               "30", "-output", str(out / "colour.tga"), "-depth", "9", "10", str(out / "depth.png"), "-normals",
               str(out / "normals.tga"), "-gui"]
    done = subprocess.run(command, capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == "note: ignoring -gui (options of the course's OpenGL preview)"
    assert lines[1:4] == [str(out / "colour.tga"), str(out / "depth.png"), str(out / "normals.tga")]
    assert lines[4].startswith("rendered 40x30, 1 spp in ") and lines[4].endswith("effects: flat")
    images = {}
    for name in ("colour.tga", "depth.png", "normals.tga"):
        with Image.open(out / name) as image:
            assert image.size == (40, 30) and image.mode == "RGB"
            images[name] = np.asarray(image)
    colour, depth, normals = images["colour.tga"], images["depth.png"], images["normals.tga"]
    assert tuple(colour[15, 20]) == (255, 0, 0) and tuple(colour[0, 0]) == (0, 0, 0)
    # grey = (10 − t)/(10 − 9) = 0.996086 -> int(254.002) = 254; misses are black
    assert tuple(depth[15, 20]) == (254, 254, 254) and tuple(depth[0, 0]) == (0, 0, 0)
    # |n| = (0.0625, 0.0625, 0.996086) -> int(15.94), int(15.94), int(254.002)
    assert tuple(normals[15, 20]) == (15, 15, 254) and tuple(normals[0, 0]) == (0, 0, 0)
    # the sphere's silhouette: x² + y² <= 1 at pixel centres, nothing else
    x = (np.arange(40) + 0.5 - 20) * 0.125
    y = (15 - np.arange(30) - 0.5) * 0.125
    inside = np.add.outer(y**2, x**2) <= 1
    np.testing.assert_array_equal(colour[..., 0] == 255, inside)
    data = (out / "colour.tga").read_bytes()
    assert (data[2], data[16], data[17]) == (2, 24, 0x20) and data[18 + 3 * (15 * 40 + 20):][:3] == bytes([0, 0, 255])


def test_command_bad_option_exit_code():
    done = subprocess.run([sys.executable, "-m", "durer", "raytracer", "-input", "x.txt", "-size", "10", "10"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "the following arguments are required: -output" in done.stderr


# --- the gallery -----------------------------------------------------------------------------------------

def test_every_command_line_is_valid():
    lines = gallery.command_lines(CORPUS / "commands.txt")
    assert len(lines) == 67
    scenes = set()
    for number, line in lines:
        options = gallery.gallery_options(line, f"commands.txt:{number}", CORPUS, Path("g"), None)
        assert options.input.exists(), line
        assert options.output.suffix == ".png" and options.output.parent == Path("g")
        scenes.add(options.input.name)
    assert scenes == {p.name for p in CORPUS.glob("scene*.txt")}


def test_gallery_command(tmp_path, capsys):
    page = tmp_path / "docs" / "gallery.md"
    code = gallery.main(["--commands", str(CORPUS / "commands.txt"), "--output-dir", str(tmp_path / "docs" / "g"),
                         "--page", str(page), "--only", "scene2_0[57]*", "--size", "24"])
    assert code == 0
    text = page.read_text()
    rows = [line for line in text.splitlines() if line.startswith("| scene2_")]
    assert len(rows) == 4   # scene2_05 and scene2_07, each with and without -shade_back
    assert rows[0].startswith("| scene2_05_inside_sphere | `-input scene2_05_inside_sphere.txt -size 200 200 ")
    assert '<img src="g/output2_05.png"' in rows[0] and '<img src="g/depth2_05.png"' in rows[0]
    assert '<img src="g/normals2_05.png"' in rows[0] and rows[0].endswith(" | diffuse |")
    for name in ("output2_05", "depth2_05", "normals2_05", "output2_05_no_back", "output2_07", "depth2_07"):
        with Image.open(tmp_path / "docs" / "g" / f"{name}.png") as image:
            assert image.size == (24, 24)
    # The colour images are the scene rendered directly at --size with each line's -shade_back (or not).
    colours = []
    for name, shade_back in (("output2_05", True), ("output2_05_no_back", False)):
        direct = render_scene_file(CORPUS / "scene2_05_inside_sphere.txt", 24, 24, shade_back=shade_back)
        with Image.open(tmp_path / "docs" / "g" / f"{name}.png") as image:
            colours.append(np.asarray(image))
        np.testing.assert_array_equal(colours[-1], to_bytes(direct.color[..., :3]))
    assert (colours[0] != colours[1]).any()  # inside the sphere, -shade_back shows what no-back leaves unlit
    assert "- **Machine:** " in text and f"{len(rows)} command lines" in text
    assert "wrote" in capsys.readouterr().out


def test_gallery_refuses_a_page_it_could_not_write_before_rendering(tmp_path, capsys, monkeypatch):
    (tmp_path / "a_file").write_text("")
    monkeypatch.setattr(gallery, "render_gallery", lambda *args: pytest.fail("rendered before the --page check"))
    with pytest.raises(SystemExit) as info:
        gallery.main(["--page", str(tmp_path / "a_file" / "g.md")])
    assert info.value.code == 2
    assert capsys.readouterr().err.endswith(f"error: --page {tmp_path / 'a_file' / 'g.md'}: "
                                            f"'{tmp_path / 'a_file'}' is a file, not a folder\n")


def test_gallery_only_matching_nothing_fails(tmp_path, capsys):
    assert gallery.main(["--commands", str(CORPUS / "commands.txt"), "--output-dir", str(tmp_path),
                         "--page", str(tmp_path / "g.md"), "--only", "nothing*"]) == 1
    assert "no command matches" in capsys.readouterr().err
