"""The 6.837 scene-file reader: the whole grammar, transform matrices checked by hand, the corpus,
and malformed files giving SceneFileError at the exact line."""

from __future__ import annotations

import math
import re
import textwrap
from pathlib import Path

import numpy as np
import pytest

import durer
from durer.course.scene_file import SceneFileError, SceneMaterial, read_obj, read_scene_file, rodrigues_matrix
from helpers import CORPUS

CORPUS_FILES = sorted(CORPUS.glob("*.txt"))
CORPUS_FILES = [p for p in CORPUS_FILES if p.name != "commands.txt"]

CUBE_OBJ = """\
v -1 -1 -1
v 1 -1 -1
v -1 1 -1
v 1 1 -1
v -1 -1 1
v 1 -1 1
v -1 1 1
v 1 1 1
f 1 3 4
f 1 4 2
f 5 6 8
f 5 8 7
f 1 2 6
f 1 6 5
f 3 7 8
f 3 8 4
f 1 5 7
f 1 7 3
f 2 4 8
f 2 8 6"""


def write(folder: Path, text: str, name: str = "scene.txt") -> Path:
    path = folder / name
    path.write_text(textwrap.dedent(text))
    return path


def read(folder: Path, text: str):
    return read_scene_file(write(folder, text))


def one_primitive(body: str) -> str:
    """A scene with one material and `body` as the root group's only object."""
    return f"Materials {{ numMaterials 1 Material {{ }} }}\nGroup {{ numObjects 1 MaterialIndex 0\n{body}\n}}\n"


def transform_matrix(folder: Path, ops: str) -> np.ndarray:
    scene = read(folder, one_primitive(f"Transform {{ {ops} Sphere {{ center 0 0 0 radius 1 }} }}"))
    return scene.primitives[0].matrix


# --- the grammar ----------------------------------------------------------------------------------

def test_every_keyword(tmp_path):
    write(tmp_path, CUBE_OBJ, "cube.obj")
    scene = read(tmp_path, """\
        PerspectiveCamera {
            center 0 1 10
            direction 0 -.1 -1
            up 0 1 0
            angle 30
        }
        Background { ambientLight 0.1 0.2 0.3 color .4 0.5 0.6 }
        Lights {
            numLights 3
            DirectionalLight { direction -0.5 -0.5 -1 color 0.8 0.8 0.8 }
            PointLight { position 0 5 0 color 1 1 1 attenuation 0 0.2 0.05 }
            PointLight { position 1 2 3 color 0.5 0 0 }
        }
        Materials {
            numMaterials 3
            PhongMaterial {
                indexOfRefraction 1.5
                transparentColor 0.1 0.2 0.3
                reflectiveColor 0.4 0.5 0.6
                exponent 32
                specularColor 0.7 0.8 0.9
                diffuseColor 1 0 0
            }
            Material { diffuseColor 0 1 0 }
            Material { }
        }
        Group {
            numObjects 5
            MaterialIndex 0
            Sphere { center 1 2 3 radius 0.5 }
            MaterialIndex 1
            Plane { normal 0 1 0 offset -2 }
            Triangle { vertex0 0 0 0 vertex1 1 0 0 vertex2 0 1 0 }
            MaterialIndex 2
            TriangleMesh { obj_file cube.obj }
            Group {
                numObjects 1
                Transform { Translate 1 0 0 Sphere { center 0 0 0 radius 2 } }
            }
        }
        """)
    camera = scene.camera
    assert (camera.projection, camera.center, camera.direction, camera.up, camera.size) == (
        "perspective", (0, 1, 10), (0, -0.1, -1), (0, 1, 0), 30)
    assert scene.background == (0.4, 0.5, 0.6) and scene.ambient == (0.1, 0.2, 0.3)
    assert scene.effective_ambient == (0.1, 0.2, 0.3)
    directional, point, plain_point = scene.lights
    assert (directional.kind, directional.direction, directional.color) == ("directional", (-0.5, -0.5, -1), (0.8,) * 3)
    assert (point.kind, point.position, point.color) == ("point", (0, 5, 0), (1, 1, 1))
    assert point.attenuation == (0, 0.2, 0.05)
    assert plain_point.attenuation == (1, 0, 0)
    assert scene.materials == [
        SceneMaterial((1, 0, 0), (0.7, 0.8, 0.9), 32, (0.4, 0.5, 0.6), (0.1, 0.2, 0.3), 1.5),
        SceneMaterial(diffuse=(0, 1, 0)),
        SceneMaterial((1, 1, 1), (0, 0, 0), 1, (0, 0, 0), (0, 0, 0), 1),
    ]
    sphere, plane, triangle, mesh, moved = scene.primitives
    assert [p.kind for p in scene.primitives] == ["sphere", "plane", "triangle", "mesh", "sphere"]
    assert [p.material for p in scene.primitives] == [0, 1, 1, 2, 2]
    assert (sphere.center, sphere.radius) == ((1, 2, 3), 0.5)
    assert (plane.normal, plane.offset) == ((0, 1, 0), -2)
    np.testing.assert_array_equal(triangle.vertices, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    assert mesh.vertices.shape == (8, 3) and mesh.faces.shape == (12, 3) and mesh.faces.dtype == np.int32
    assert mesh.mesh_path == tmp_path / "cube.obj"
    np.testing.assert_array_equal(mesh.faces[0], [0, 2, 3])  # "f 1 3 4", 1-based
    for p in (sphere, plane, triangle, mesh):
        np.testing.assert_array_equal(p.matrix, np.eye(4))
    np.testing.assert_array_equal(moved.matrix[:3, 3], [1, 0, 0])
    assert sphere.source == f"{tmp_path / 'scene.txt'}:30"


def test_orthographic_camera_and_defaults(tmp_path):
    scene = read(tmp_path, """\
        OrthographicCamera { center 0 0 10 direction 0 0 -2 up 0.5 1 0 size 5 }
        Group { numObjects 0 }
        """)
    assert scene.camera.projection == "orthographic" and scene.camera.size == 5
    assert scene.camera.direction == (0, 0, -2) and scene.camera.up == (0.5, 1, 0)  # as written
    assert scene.background == (0.5, 0.5, 0.5) and scene.ambient == (0, 0, 0)
    assert scene.effective_ambient == (1, 1, 1)  # no lights: the A2+ parser forces full ambient
    assert scene.lights == [] and scene.materials == [] and scene.primitives == []


def test_empty_file_has_nothing(tmp_path):
    scene = read(tmp_path, "\n\n")
    assert scene.camera is None and scene.primitives == []


@pytest.mark.parametrize("keyword", ["Material", "PhongMaterial"])
def test_both_material_keywords(tmp_path, keyword):
    scene = read(tmp_path, f"Materials {{ numMaterials 1 {keyword} {{ diffuseColor 0.25 0.5 1 }} }}")
    assert scene.materials == [SceneMaterial(diffuse=(0.25, 0.5, 1))]


@pytest.mark.parametrize("text, value", [("-.16", -0.16), (".4", 0.4), ("5.", 5.0), ("+2", 2.0), ("1e-1", 0.1),
                                         ("-3E2", -300.0), ("0", 0.0)])
def test_number_forms(tmp_path, text, value):
    scene = read(tmp_path, one_primitive(f"Plane {{ normal 0 1 0 offset {text} }}"))
    assert scene.primitives[0].offset == value


def test_material_index_is_parser_global(tmp_path):
    # MaterialIndex ignores the hierarchy: set inside a nested group, it stays in effect after it closes.
    scene = read(tmp_path, """\
        Materials { numMaterials 3 Material { } Material { } Material { } }
        Group {
            numObjects 4
            MaterialIndex 0
            Sphere { center 0 0 0 radius 1 }
            Group {
                numObjects 1
                Transform {
                    Translate 1 0 0
                    Group { numObjects 1 MaterialIndex 2 Sphere { center 0 0 0 radius 1 } }
                }
            }
            Sphere { center 0 0 0 radius 1 }
            MaterialIndex 1
            Group { numObjects 1 Sphere { center 0 0 0 radius 1 } }
        }
        """)
    assert [p.material for p in scene.primitives] == [0, 2, 2, 1]


def test_num_objects_counts_objects_not_material_indices(tmp_path):
    scene = read(tmp_path, """\
        Materials { numMaterials 2 Material { } Material { } }
        Group { numObjects 2 MaterialIndex 0 MaterialIndex 1 Sphere { center 0 0 0 radius 1 }
                MaterialIndex 0 Sphere { center 0 0 0 radius 1 } MaterialIndex 1 }
        """)
    assert [p.material for p in scene.primitives] == [1, 0]


def test_materials_block_may_follow_the_group(tmp_path):
    scene = read(tmp_path, """\
        Group { numObjects 1 MaterialIndex 1 Sphere { center 0 0 0 radius 1 } }
        Materials { numMaterials 2 Material { } Material { diffuseColor 1 0 0 } }
        """)
    assert scene.primitives[0].material == 1


# --- transforms -------------------------------------------------------------------------------------

C30, S30 = math.cos(math.radians(30)), math.sin(math.radians(30))
H = math.sqrt(0.5)


@pytest.mark.parametrize("ops, linear, translation", [
    ("Scale 2 3 4", [[2, 0, 0], [0, 3, 0], [0, 0, 4]], [0, 0, 0]),
    ("UniformScale 0.5", [[0.5, 0, 0], [0, 0.5, 0], [0, 0, 0.5]], [0, 0, 0]),
    ("Translate 1 -2 .5", np.eye(3), [1, -2, 0.5]),
    ("XRotate 90", [[1, 0, 0], [0, 0, -1], [0, 1, 0]], [0, 0, 0]),
    ("YRotate 90", [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], [0, 0, 0]),
    ("ZRotate 90", [[0, -1, 0], [1, 0, 0], [0, 0, 1]], [0, 0, 0]),
    ("ZRotate 30", [[C30, -S30, 0], [S30, C30, 0], [0, 0, 1]], [0, 0, 0]),
    ("XRotate -30", [[1, 0, 0], [0, C30, S30], [0, -S30, C30]], [0, 0, 0]),
    ("Rotate { 0 0 1 90 }", [[0, -1, 0], [1, 0, 0], [0, 0, 1]], [0, 0, 0]),
    ("Rotate { 1 0 0 30 }", [[1, 0, 0], [0, C30, -S30], [0, S30, C30]], [0, 0, 0]),
    # About (1, 1, 1)/√3 by 120°: the cyclic permutation x -> y -> z -> x.
    ("Rotate { 0.5773502691896258 0.5773502691896258 0.5773502691896258 120 }",
     [[0, 0, 1], [1, 0, 0], [0, 1, 0]], [0, 0, 0]),
    # The course does not normalise the axis: c·I + (1 − c)·a·aᵀ + s·[a]× with a = (0, 0, 2), c = 0, s = 1.
    ("Rotate { 0 0 2 90 }", [[0, -2, 0], [2, 0, 0], [0, 0, 4]], [0, 0, 0]),
    # Row-major: the last column is the translation.
    ("Matrix { 1 0 0 5  0 2 0 6  0 0 3 7  0 0 0 1 }", [[1, 0, 0], [0, 2, 0], [0, 0, 3]], [5, 6, 7]),
    # The braced form of later course parsers.
    ("Translate { 1 2 3 } XRotate { 90 }", [[1, 0, 0], [0, 0, -1], [0, 1, 0]], [1, 2, 3]),
])
def test_transform_op_matrices(tmp_path, ops, linear, translation):
    expected = np.eye(4)
    expected[:3, :3] = linear
    expected[:3, 3] = translation
    np.testing.assert_allclose(transform_matrix(tmp_path, ops), expected, rtol=0, atol=1e-15)


def test_first_op_is_outermost(tmp_path):
    # M = T·S: the sphere is scaled first, then moved.
    m = transform_matrix(tmp_path, "Translate 1 0 0 Scale 2 2 2")
    np.testing.assert_allclose(m @ [1, 0, 0, 1], [3, 0, 0, 1])
    m = transform_matrix(tmp_path, "Scale 2 2 2 Translate 1 0 0")
    np.testing.assert_allclose(m @ [1, 0, 0, 1], [4, 0, 0, 1])


def test_rotate_then_squash_squashes_first(tmp_path):
    # scene2_13: `ZRotate 45` then `Scale 1 0.2 1` is a sphere squashed along y, then tilted by 45°.
    m = transform_matrix(tmp_path, "ZRotate 45 Scale 1 0.2 1")
    np.testing.assert_allclose(m @ [1, 0, 0, 1], [H, H, 0, 1], atol=1e-15)
    np.testing.assert_allclose(m @ [0, 1, 0, 1], [-0.2 * H, 0.2 * H, 0, 1], atol=1e-15)
    np.testing.assert_allclose(m @ [0, 0, 1, 1], [0, 0, 1, 1], atol=1e-15)


def test_matrix_op_is_pre_multiplied(tmp_path):
    # Every other op post-multiplies; `Matrix` pre-multiplies: M = Mread·M.
    scale2 = "Matrix { 2 0 0 0  0 2 0 0  0 0 2 0  0 0 0 1 }"
    m = transform_matrix(tmp_path, f"Translate 1 0 0 {scale2}")
    np.testing.assert_array_equal(m @ [0, 0, 0, 1], [2, 0, 0, 1])  # S·T, not T·S (which gives 1, 0, 0)
    m = transform_matrix(tmp_path, f"{scale2} Translate 1 0 0")
    np.testing.assert_array_equal(m @ [0, 0, 0, 1], [2, 0, 0, 1])


def test_nested_transforms_compose(tmp_path):
    scene = read(tmp_path, one_primitive("""\
        Transform { Translate 0 0 1
            Transform { ZRotate 90 Transform { Scale 2 1 1 Sphere { center 0 0 0 radius 1 } } } }"""))
    m = scene.primitives[0].matrix
    np.testing.assert_allclose(m @ [1, 0, 0, 1], [0, 2, 1, 1], atol=1e-15)  # scale, then rotate, then move
    assert not m.flags.writeable


def test_primitives_under_one_transform_share_its_matrix(tmp_path):
    scene = read(tmp_path, one_primitive("""\
        Transform { Translate 1 2 3 Group { numObjects 2 Sphere { center 0 0 0 radius 1 }
                                                          Sphere { center 1 0 0 radius 1 } } }"""))
    a, b = scene.primitives
    assert a.matrix is b.matrix


# --- .obj files ------------------------------------------------------------------------------------

def test_obj_is_found_next_to_the_scene_not_in_the_cwd(tmp_path, monkeypatch):
    folder = tmp_path / "scenes"
    folder.mkdir()
    write(folder, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "tri.obj")
    write(folder, one_primitive("TriangleMesh { obj_file tri.obj }"))
    monkeypatch.chdir(tmp_path)
    scene = read_scene_file(Path("scenes") / "scene.txt")
    assert scene.primitives[0].mesh_path == Path("scenes") / "tri.obj"
    np.testing.assert_array_equal(scene.primitives[0].faces, [[0, 1, 2]])


def test_obj_crlf_comments_blank_lines(tmp_path):
    path = tmp_path / "m.obj"
    path.write_bytes(b"# a comment\r\nv 0 0 0\r\n\r\nv 1.5 -.5 2e1\r\nv 0 1 0\r\nf 3 2 1\r\n")
    vertices, faces = read_obj(path)
    np.testing.assert_array_equal(vertices, [[0, 0, 0], [1.5, -0.5, 20], [0, 1, 0]])
    np.testing.assert_array_equal(faces, [[2, 1, 0]])
    assert vertices.dtype == np.float64 and faces.dtype == np.int32
    assert not vertices.flags.writeable and not faces.flags.writeable


BOM = b"\xef\xbb\xbf"  # UTF-8's byte order mark, which Windows Notepad writes first


def test_a_byte_order_mark_is_not_part_of_the_text(tmp_path):
    (tmp_path / "tri.obj").write_bytes(BOM + b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    text = "PerspectiveCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 angle 30 }\n"
    (tmp_path / "scene.txt").write_bytes(BOM + (text + one_primitive("TriangleMesh { obj_file tri.obj }")).encode())
    scene = read_scene_file(tmp_path / "scene.txt")
    assert scene.camera.projection == "perspective"
    np.testing.assert_array_equal(scene.primitives[0].faces, [[0, 1, 2]])


def test_control_characters_of_a_token_are_escaped_in_the_error(tmp_path):
    """A binary file's bytes quoted raw vanished on a terminal ("got 'PerspectiveCamera'" for a token
    that is not)."""
    (tmp_path / "scene.txt").write_bytes(b"\x00\x01\x02PerspectiveCamera {\n}\n")
    with pytest.raises(SceneFileError) as info:
        read_scene_file(tmp_path / "scene.txt")
    assert "got '\\x00\\x01\\x02PerspectiveCamera'" in str(info.value) and str(info.value).isprintable()


@pytest.mark.parametrize("end", ["\r", "\r\n", "\n"], ids=["CR", "CRLF", "LF"])
def test_errors_are_at_their_line_whatever_ends_the_lines(tmp_path, end):
    """Old Mac editors end lines with CR alone: lines are still counted (as str.splitlines counts them)."""
    scene = one_primitive("Sphere {\ncenter 0 0 0\nradius abc }")
    (tmp_path / "scene.txt").write_bytes(end.join(scene.splitlines()).encode())
    with pytest.raises(SceneFileError, match=r"scene.txt:5: expected a number for 'radius', got 'abc'$"):
        read_scene_file(tmp_path / "scene.txt")
    (tmp_path / "bad.obj").write_bytes(end.join(["v 0 0 0", "v 1 0 0", "", "f 1 2 3"]).encode())
    with pytest.raises(SceneFileError, match=r"bad.obj:4: face indices \(1, 2, 3\) out of range: expected 1..2"):
        read_obj(tmp_path / "bad.obj")


def test_a_corpus_scene_with_cr_line_ends_reads_the_same(tmp_path):
    name = "scene2_14_axes_cube.txt"
    (tmp_path / "cube.obj").write_bytes((CORPUS / "cube.obj").read_bytes().replace(b"\n", b"\r"))
    (tmp_path / name).write_bytes((CORPUS / name).read_bytes().replace(b"\n", b"\r"))
    ours, theirs = read_scene_file(tmp_path / name), read_scene_file(CORPUS / name)
    assert (ours.camera, ours.lights, ours.materials) == (theirs.camera, theirs.lights, theirs.materials)
    assert [(p.kind, p.source.rsplit(":", 1)[1]) for p in ours.primitives] == [
        (p.kind, p.source.rsplit(":", 1)[1]) for p in theirs.primitives]  # the same objects at the same lines
    for a, b in zip(ours.primitives, theirs.primitives):
        np.testing.assert_array_equal(a.matrix, b.matrix)
        np.testing.assert_array_equal(a.faces, b.faces)


def test_an_obj_used_twice_is_read_once(tmp_path):
    write(tmp_path, CUBE_OBJ, "cube.obj")
    scene = read(tmp_path, """\
        Materials { numMaterials 1 Material { } }
        Group { numObjects 2 MaterialIndex 0 TriangleMesh { obj_file cube.obj }
                Transform { Translate 1 0 0 TriangleMesh { obj_file cube.obj } } }
        """)
    a, b = scene.primitives
    assert a.vertices is b.vertices and a.faces is b.faces


def test_bunny_1k_reads_whole():
    vertices, faces = read_obj(CORPUS / "bunny_1k.obj")
    assert vertices.shape == (502, 3) and faces.shape == (1000, 3)
    assert faces.min() == 0 and faces.max() == 501
    assert vertices.dtype == np.float64 and faces.dtype == np.int32


# --- the corpus ------------------------------------------------------------------------------------

def test_the_corpus_is_complete():
    assert len(CORPUS_FILES) == 49
    assert {p.name for p in CORPUS.glob("*.obj")} == {"bunny_1k.obj", "bunny_200.obj", "cube.obj", "diamond.obj"}


@pytest.mark.parametrize("path", CORPUS_FILES, ids=lambda p: p.stem)
def test_corpus_file_counts_match_its_text(path):
    """Lights, materials and primitives as many as the file's own text declares or contains."""
    words = path.read_text().split()
    scene = read_scene_file(path)
    declared_lights = int(words[words.index("numLights") + 1]) if "numLights" in words else 0
    assert len(scene.lights) == declared_lights
    assert len(scene.materials) == int(words[words.index("numMaterials") + 1])
    for keyword, kind in (("Sphere", "sphere"), ("Plane", "plane"), ("Triangle", "triangle"), ("TriangleMesh", "mesh")):
        assert sum(p.kind == kind for p in scene.primitives) == words.count(keyword), keyword
    assert scene.camera is not None
    assert all(0 <= p.material < len(scene.materials) for p in scene.primitives)


def test_scene2_16_spheres():
    scene = read_scene_file(CORPUS / "scene2_16_t_scale.txt")
    assert [p.material for p in scene.primitives] == [3, 0, 1, 2, 4, 5]
    assert [p.radius for p in scene.primitives] == [0.25, 0.5, 1, 2, 0.25, 0.5 * 2]
    first = scene.primitives[0].matrix
    np.testing.assert_array_equal(first, [[5, 0, 0, -1.25], [0, 5, 0, -1.25], [0, 0, 5, -2], [0, 0, 0, 1]])
    np.testing.assert_array_equal(scene.primitives[2].matrix, np.eye(4))
    assert scene.lights[0].direction == (-0.5, -0.5, -1) and scene.ambient == (0.5, 0.5, 0.5)


def test_scene2_14_meshes_and_nested_groups():
    scene = read_scene_file(CORPUS / "scene2_14_axes_cube.txt")
    assert scene.camera.direction == (-0.16, -0.12, -0.5)
    assert [p.material for p in scene.primitives] == [0, 1, 2, 3]
    assert all(p.faces.shape == (12, 3) and p.mesh_path.name == "cube.obj" for p in scene.primitives)
    x_axis = scene.primitives[0].matrix
    np.testing.assert_array_equal(x_axis, [[5, 0, 0, 5], [0, 0.2, 0, 0], [0, 0, 0.2, 0], [0, 0, 0, 1]])
    # Translate 4 3 1, XRotate 10, YRotate 20, ZRotate 30, Scale 2 0.5 3: T·Rx·Ry·Rz·S.
    def rot(axis, degrees):
        c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
        m = np.eye(4)
        i, j = [(1, 2), (2, 0), (0, 1)][axis]
        m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
        return m
    expected = np.eye(4)
    expected[:3, 3] = (4, 3, 1)
    expected = expected @ rot(0, 10) @ rot(1, 20) @ rot(2, 30) @ np.diag([2, 0.5, 3, 1])
    np.testing.assert_allclose(scene.primitives[3].matrix, expected, rtol=0, atol=1e-15)


def test_scene2_15_crazy_transforms():
    scene = read_scene_file(CORPUS / "scene2_15_crazy_transforms.txt")
    left, right = scene.primitives
    assert (left.material, right.material) == (0, 1)
    c20, s20 = math.cos(math.radians(20)), math.sin(math.radians(20))
    outer = np.diag([0.5, 0.5, 0.5, 1]) @ np.array([[1, 0, 0, 0], [0, c20, -s20, 0], [0, s20, c20, 0], [0, 0, 0, 1]])
    outer = outer @ np.array([[1, 0, 0, -3], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    rz = np.array([[H, -H, 0, 0], [H, H, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    stretch = np.diag([1, 2, 1, 1])
    np.testing.assert_allclose(left.matrix, outer @ _translation(1, 0, 0) @ rz @ stretch, atol=1e-15)
    np.testing.assert_allclose(right.matrix, outer @ _translation(6, 0, 0) @ stretch @ rz, atol=1e-15)


def _translation(x, y, z):
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def test_scene4_14_diamond_and_point_lights():
    scene = read_scene_file(CORPUS / "scene4_14_faceted_gem.txt")
    gem, floor = scene.primitives
    assert gem.kind == "mesh" and gem.vertices.shape == (57, 3) and gem.faces.shape == (110, 3)
    assert floor.kind == "plane" and floor.offset == -3.5 and floor.material == 1
    assert [light.attenuation for light in scene.lights] == [(0, 0, 0.025)] * 3
    assert scene.materials[0] == SceneMaterial((0.25,) * 3, (0.25,) * 3, 32, (0.5,) * 3, (0.95,) * 3, 2.413)


def test_assignment1_scenes_have_no_lights():
    for path in CORPUS_FILES:
        if path.name.startswith("scene1_"):
            scene = read_scene_file(path)
            assert scene.lights == [] and scene.effective_ambient == (1, 1, 1)


# --- malformed files ---------------------------------------------------------------------------------

BASE = """\
OrthographicCamera {
    center 0 0 10
    direction 0 0 -1
    up 0 1 0
    size 5
}
Materials {
    numMaterials 2
    Material { diffuseColor 1 0 0 }
    PhongMaterial { diffuseColor 0 1 0 }
}
Group {
    numObjects 2
    MaterialIndex 0
    Sphere {
        center 0 0 0
        radius 1
    }
    MaterialIndex 1
    Sphere { center 1 1 1 radius 0.5 }
}
"""


def test_base_scene_is_valid(tmp_path):
    scene = read(tmp_path, BASE)
    assert [p.material for p in scene.primitives] == [0, 1]


@pytest.mark.parametrize("old, new, line, message", [
    # missing braces / premature end of file
    ("        radius 1\n    }\n", "        radius 1\n", 18,
     "expected '}' in Sphere, got 'MaterialIndex'"),
    ("    Sphere {\n        center 0", "    Sphere\n        center 0", 16, "expected '{' after 'Sphere', got 'center'"),
    ("radius 0.5 }\n}\n", "radius 0.5 }\n", 20,
     "unexpected end of file: expected an object, 'MaterialIndex' or '}' (the Group block opened at line 12 is "
     "not closed)"),
    ("radius 0.5 }\n}\n", "radius", 20,
     "unexpected end of file: expected a number for 'radius' (the Sphere block opened at line 20 is not closed)"),
    # bad numbers
    ("radius 1\n", "radius abc\n", 17, "expected a number for 'radius', got 'abc'"),
    ("center 0 0 0\n", "center 0 0x1 0\n", 16, "expected a number for 'center', got '0x1'"),
    ("center 0 0 0\n", "center 0 nan 0\n", 16, "expected a number for 'center', got 'nan'"),
    ("center 0 0 0\n", "center 0 1_0 0\n", 16, "expected a number for 'center', got '1_0'"),
    ("center 0 0 0\n", "center 0 1e999 0\n", 16, "expected a finite number for 'center', got '1e999'"),
    ("numObjects 2", "numObjects 2.0", 13, "expected an integer for 'numObjects', got '2.0'"),
    ("MaterialIndex 1", "MaterialIndex one", 19, "expected an integer for 'MaterialIndex', got 'one'"),
    # unknown keywords
    ("    Sphere {\n        center 0", "    Sphre {\n        center 0", 15,
     "expected 'Group', 'Sphere', 'Plane', 'Triangle', 'TriangleMesh', 'Transform', 'MaterialIndex' or '}' in "
     "Group, got 'Sphre'"),
    ("Materials {", "Material {", 7, "expected 'OrthographicCamera', 'PerspectiveCamera', 'Background', 'Lights', "
                                     "'Materials' or 'Group', got 'Material'"),
    ("{ diffuseColor 1 0 0 }", "{ difuseColor 1 0 0 }", 9,
     "expected 'diffuseColor', 'specularColor', 'exponent', 'reflectiveColor', 'transparentColor', "
     "'indexOfRefraction' or '}' in Material, got 'difuseColor'"),
    ("    size 5\n", "    angle 5\n", 5, "expected 'size' in OrthographicCamera, got 'angle'"),
    # wrong counts
    ("numObjects 2", "numObjects 3", 21, "numObjects is 3 (line 13) but the Group has only 2 objects"),
    ("numObjects 2", "numObjects 1", 20, "numObjects is 1 (line 13) but more objects follow: expected '}'"),
    ("numMaterials 2", "numMaterials 3", 11, "numMaterials is 3 (line 8) but the block has only 2 materials"),
    ("numMaterials 2", "numMaterials 1", 10, "numMaterials is 1 (line 8) but more materials follow: expected '}'"),
    ("numMaterials 2", "numMaterials -1", 8, "expected 'numMaterials' >= 0, got -1"),
    # material indices
    ("MaterialIndex 1", "MaterialIndex 2", 19, "MaterialIndex 2 out of range: expected 0..1"),
    ("MaterialIndex 1", "MaterialIndex -1", 19, "MaterialIndex -1 out of range: expected 0..1"),
    ("    MaterialIndex 0\n", "\n", 15, "no MaterialIndex before this Sphere: expected 'MaterialIndex i' before the "
                                      "first primitive"),
    # values the renderer would reject
    ("radius 1\n", "radius 0\n", 17, "expected 'radius' > 0, got 0"),
    ("radius 1\n", "radius -2\n", 17, "expected 'radius' > 0, got -2"),
    ("direction 0 0 -1", "direction 0 0 0", 3, "'direction' must not be the zero vector, got 0 0 0"),
    ("up 0 1 0", "up 0 0 0", 4, "'up' must not be the zero vector"),
    ("up 0 1 0", "up 0 0 2", 4, "'up' must not be parallel to 'direction', got 0 0 2"),
    ("size 5", "size 0", 5, "expected 'size' > 0, got 0"),
    ("diffuseColor 0 1 0", "diffuseColor 0 -1 0", 10,
     "'diffuseColor' must be >= 0 in every component (Dürer renders no negative light), got 0 -1 0"),
    # a second camera
    ("Materials {\n", "OrthographicCamera { center 0 0 1 direction 0 0 -1 up 0 1 0 size 1 }\nMaterials {\n", 7,
     "a second camera: the first is at line 1"),
    ("radius 0.5 }\n}\n", "radius 0.5 }\n}\nGroup { numObjects 0 }\n", 22,
     "a second Group block: the first is at line 12"),
])
def test_malformed_scene(tmp_path, old, new, line, message):
    assert old in BASE
    path = write(tmp_path, BASE.replace(old, new, 1))
    with pytest.raises(SceneFileError) as info:
        read_scene_file(path)
    error = info.value
    assert (error.path, error.line, error.message) == (str(path), line, message)
    assert str(error) == f"{path}:{line}: {message}"


SPHERE = "Sphere { center 0 0 0 radius 1 }"
EXPECTED_IN_TRANSFORM = ("expected a transform op ('Scale', 'UniformScale', 'Translate', 'XRotate', 'YRotate', "
                         "'ZRotate', 'Rotate', 'Matrix') or an object ('Group', 'Sphere', 'Plane', 'Triangle', "
                         "'TriangleMesh', 'Transform') in Transform")


@pytest.mark.parametrize("body, line, message", [
    (f"Transform {{ Scale 1 0 1 {SPHERE} }}", 3, "Scale is not invertible: expected a non-singular transform"),
    (f"Transform {{ UniformScale 0 {SPHERE} }}", 3, "UniformScale is not invertible: expected a non-singular "
                                                    "transform"),
    (f"Transform {{\nRotate {{ 0 0 1 90 }}\nMatrix {{ 1 0 0 0 0 1 0 0 0 0 1 0 0 0 1 1 }} {SPHERE} }}", 5,
     "expected an affine Matrix (last row 0 0 0 1), got last row 0 0 1 1"),
    (f"Transform {{ Matrix {{ 1 0 0 0 0 1 0 0 0 0 0 0 0 0 0 1 }} {SPHERE} }}", 3,
     "Matrix is not invertible: expected a non-singular transform"),
    (f"Transform {{ Rotate {{\n0 0 0 30 }} {SPHERE} }}", 4, "the Rotate axis must not be the zero vector"),
    ("Transform { Translate 1 0 0 }", 3, f"{EXPECTED_IN_TRANSFORM}, got '}}'"),
    (f"Transform {{ {SPHERE}\n{SPHERE} }}", 4, "expected '}' in Transform, got 'Sphere'"),
    (f"Transform {{ Translate 1 0 0\nMaterialIndex 0 {SPHERE} }}", 4, f"{EXPECTED_IN_TRANSFORM}, got 'MaterialIndex'"),
    ("Plane {\nnormal 0 0 0 offset 1 }", 4, "'normal' must not be the zero vector, got 0 0 0"),
    ("Triangle { vertex0 0 0 0 vertex1 1 0 0 vertex3 0 1 0 }", 3, "expected 'vertex2' in Triangle, got 'vertex3'"),
])
def test_malformed_objects(tmp_path, body, line, message):
    path = write(tmp_path, one_primitive(body))
    with pytest.raises(SceneFileError) as info:
        read_scene_file(path)
    assert (info.value.line, info.value.message) == (line, message)


# The core's rule (docs/numerics.md, "Invertible transforms, one rule"): |det A| > 1e-12 of its
# Hadamard bound, scale-free, so any axis scale passes and a nearly flat shear does not.
@pytest.mark.parametrize("op, matrix, refused", [
    ("Scale 1 0 1", np.diag([1.0, 0.0, 1.0, 1.0]), True),  # singular
    ("Scale 1 1 1e-13", np.diag([1.0, 1.0, 1e-13, 1.0]), False),  # an axis scale, however small
    ("Matrix { 1 0 0 0 1 1e-13 0 0 0 0 1 0 0 0 0 1 }", np.array([[1, 0, 0, 0], [1, 1e-13, 0, 0], [0, 0, 1, 0],
                                                                [0, 0, 0, 1.0]]), True),  # a nearly flat shear
    # The course does not normalise the axis: about (0, 0, 1/√2) by 180°, the z diagonal entry
    # c + (1 − c)·a² is 0 but for rounding: a tiny axis scale, not a singular map.
    ("Rotate { 0 0 0.7071067811865476 180 }", rodrigues_matrix((0, 0, 0.7071067811865476), 180), False),
])
def test_the_reader_refuses_exactly_the_transforms_the_core_refuses(tmp_path, op, matrix, refused):
    path = write(tmp_path, one_primitive(f"Transform {{ {op} {SPHERE} }}"))
    if refused:
        with pytest.raises(ValueError, match="transform must be invertible"):
            durer.Scene().add_spheres([[0.0, 0.0, 0.0]], [1.0], transform=matrix)
        with pytest.raises(SceneFileError) as info:
            read_scene_file(path)
        assert (info.value.line, info.value.message) == (3, f"{op.split()[0]} is not invertible: expected a "
                                                            "non-singular transform")
    else:
        core = durer.Scene()
        core.add_spheres([[0.0, 0.0, 0.0]], [1.0], transform=matrix)
        assert core.transform_count == 1
        scene = read_scene_file(path)
        np.testing.assert_array_equal(scene.primitives[0].matrix, matrix)
        assert scene.to_scene().transform_count == 1


def test_degenerate_triangle_is_legal(tmp_path):
    scene = read(tmp_path, one_primitive("Triangle { vertex0 0 0 0 vertex1 1 1 1 vertex2 2 2 2 }"))
    assert scene.primitives[0].kind == "triangle"


@pytest.mark.parametrize("lights, line, message", [
    ("numLights 2\nDirectionalLight { direction 0 0 -1 color 1 1 1 }\n}", 4,
     "numLights is 2 (line 2) but the block has only 1 light"),
    ("numLights 1\nDirectionalLight { direction 0 0 -1 color 1 1 1 }\nPointLight { position 0 0 0 color 1 1 1 }\n}",
     4, "numLights is 1 (line 2) but more lights follow: expected '}'"),
    ("numLights 1\nDirectionalLight {\ndirection 0 0 0 color 1 1 1 }\n}", 4,
     "'direction' must not be the zero vector, got 0 0 0"),
    ("numLights 1\nPointLight { position 0 0 0 color 1 1 1\nattenuation 0 0 0 }\n}", 4,
     "'attenuation' must not be all zero (the light would be infinite), got 0 0 0"),
    ("numLights 1\nPointLight { position 0 0 0 color 1 1 1\nfalloff 1 }\n}", 4,
     "expected 'attenuation' or '}' in PointLight, got 'falloff'"),
    ("numLights 1\nSpotLight { }\n}", 3, "expected 'DirectionalLight' or 'PointLight', got 'SpotLight'"),
])
def test_malformed_lights(tmp_path, lights, line, message):
    path = write(tmp_path, f"Lights {{\n{lights}\n")
    with pytest.raises(SceneFileError) as info:
        read_scene_file(path)
    assert (info.value.line, info.value.message) == (line, message)


# What the reader takes but the core refuses is refused while reading, at the item's line.
@pytest.mark.parametrize("text, line, message", [
    (BASE.replace("up 0 1 0", "up 0 1 1e300"), 1,
     "Dürer cannot render this OrthographicCamera: up must not be parallel to direction"),
    (one_primitive("Plane { normal 1e-320 0 0 offset 1 }"), 3,
     "Dürer cannot render this Plane: offset / |normal| must be finite, got inf"),
])
def test_values_the_core_refuses_are_scene_file_errors(tmp_path, text, line, message):
    path = write(tmp_path, text)
    with pytest.raises(SceneFileError) as info:
        read_scene_file(path)
    assert (info.value.path, info.value.line, info.value.message) == (str(path), line, message)


def test_material_index_past_the_end_when_materials_come_later(tmp_path):
    path = write(tmp_path, "Group { numObjects 1\nMaterialIndex 1\nSphere { center 0 0 0 radius 1 } }\n"
                           "Materials { numMaterials 1 Material { } }\n")
    with pytest.raises(SceneFileError, match=r"scene.txt:2: MaterialIndex 1 out of range: expected 0..0$"):
        read_scene_file(path)


def test_missing_obj(tmp_path):
    path = write(tmp_path, one_primitive("TriangleMesh {\nobj_file\nmissing.obj }"))
    with pytest.raises(SceneFileError) as info:
        read_scene_file(path)
    assert info.value.line == 5
    assert info.value.message == (f"cannot read the .obj file '{tmp_path / 'missing.obj'}' named by 'obj_file': "
                                  "No such file or directory")


@pytest.mark.parametrize("obj, line, message", [
    ("v 0 0 0\nv 1 0 0\nvn 0 0 1\n", 3, "expected a 'v x y z' or 'f i j k' line, got 'vn 0 0 1' (the 6.837 .obj "
                                        "reader understands no other lines)"),
    ("v 0 0 0\nv 1 0\n", 2, "expected 'v x y z' with three numbers, got 'v 1 0'"),
    ("v 0 0 0\nv 1 0 abc\n", 2, "expected 'v x y z' with three numbers, got 'v 1 0 abc'"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3 4\n", 5,
     "expected 'f i j k' with three 1-based vertex indices (faces are triangles), got 'f 1 2 3 4'"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/2 3/3\n", 4,
     "expected 'f i j k' with three 1-based vertex indices (faces are triangles), got 'f 1/1 2/2 3/3'"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 0 1 2\n", 5, "face indices (0, 1, 2) out of range: expected 1..3 (the vertices "
                                                  "defined above)"),
    ("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n", 3, "face indices (1, 2, 3) out of range: expected 1..2 (the vertices "
                                                "defined above)"),
    ("v 0 0 0\nv 1 0 0\nv 0 1e999 0\nf 1 2 3\n", 3, "expected finite vertex coordinates, got (0.0, inf, 0.0)"),
    # int64 could not hold it (an OverflowError traceback before)
    (f"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 {2**63}\n", 4,
     "face indices out of range: expected at most 18 digits, got 'f 1 2 9223372036854775808'"),
])
def test_malformed_obj_names_the_obj_file_and_line(tmp_path, obj, line, message):
    write(tmp_path, obj, "bad.obj")
    path = write(tmp_path, one_primitive("TriangleMesh { obj_file bad.obj }"))
    with pytest.raises(SceneFileError) as info:
        read_scene_file(path)
    assert (info.value.path, info.value.line, info.value.message) == (str(tmp_path / "bad.obj"), line, message)


@pytest.mark.parametrize("obj", ["", "# nothing exported\n", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"],
                         ids=["0 bytes", "comments only", "vertices only"])
def test_an_obj_without_faces_is_an_error_at_the_triangle_mesh(tmp_path, obj):
    """An empty export or the wrong file: a mesh without triangles would render nothing, silently."""
    write(tmp_path, obj, "empty.obj")
    path = write(tmp_path, one_primitive("TriangleMesh {\nobj_file empty.obj }"))
    with pytest.raises(SceneFileError) as info:
        read_scene_file(path)
    assert (info.value.path, info.value.line) == (str(path), 4)
    assert info.value.message == (f"the .obj file '{tmp_path / 'empty.obj'}' named by 'obj_file' has no faces: "
                                  "expected at least one 'f i j k' line")


def test_missing_scene_file_is_an_os_error(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_scene_file(tmp_path / "nope.txt")


# --- never a crash --------------------------------------------------------------------------------------

def _tokens(path: Path) -> list[str]:
    return re.findall(r"\S+|\s+", path.read_text())


@pytest.mark.parametrize("name", ["scene2_16_t_scale.txt", "scene4_14_faceted_gem.txt",
                                  "scene4_10_point_light_distance.txt"])
def test_every_truncation_is_a_scene_file_error(tmp_path, name):
    pieces = _tokens(CORPUS / name)
    (tmp_path / "diamond.obj").write_bytes((CORPUS / "diamond.obj").read_bytes())
    (tmp_path / "cube.obj").write_bytes((CORPUS / "cube.obj").read_bytes())
    words = [i for i, piece in enumerate(pieces) if not piece.isspace()]
    errors = 0
    for cut in words[1:]:
        path = write(tmp_path, "".join(pieces[:cut]))
        try:
            read_scene_file(path)
        except SceneFileError as error:
            assert error.message.startswith("unexpected end of file: expected "), error
            assert error.line == "".join(pieces[:cut]).rstrip().count("\n") + 1
            errors += 1
        else:
            # Only a cut between top-level blocks leaves a valid (smaller) scene.
            assert pieces[cut] in ("Lights", "Background", "Materials", "Group"), pieces[cut]
    assert errors >= len(words) - 6


@pytest.mark.parametrize("name", ["scene2_14_axes_cube.txt", "scene4_12_point_light_circle_d_attenuation.txt"])
def test_random_token_damage_never_crashes(tmp_path, name):
    """Replace, drop or duplicate one token at a time: the result parses or raises SceneFileError."""
    (tmp_path / "cube.obj").write_bytes((CORPUS / "cube.obj").read_bytes())
    pieces = _tokens(CORPUS / name)
    words = [i for i, piece in enumerate(pieces) if not piece.isspace()]
    rng = np.random.default_rng(6837)
    junk = ["{", "}", "0", "-1", "1e999", "abc", "Sphere", "Group", "MaterialIndex", "Transform", "Matrix", "Rotate",
            "numObjects", "TriangleMesh", "obj_file", "Scale", "", "PointLight", "color"]
    outcomes = {"parsed": 0, "error": 0}
    for _ in range(400):
        damaged = list(pieces)
        damaged[words[rng.integers(len(words))]] = f" {junk[rng.integers(len(junk))]} "
        path = write(tmp_path, "".join(damaged))
        try:
            read_scene_file(path)
            outcomes["parsed"] += 1
        except SceneFileError:
            outcomes["error"] += 1
    assert outcomes["error"] > 200  # most damage is detected


def test_nesting_is_bounded_with_a_line_number(tmp_path):
    from durer.course.scene_file import MAX_NESTING

    def nested(depth: int) -> str:
        body = "Sphere { center 0 0 0 radius 1 }"
        for _ in range(depth):
            body = f"Group {{ numObjects 1\n{body}\n}}"
        return one_primitive(body)

    assert len(read(tmp_path, nested(MAX_NESTING - 2)).primitives) == 1  # the root group and Sphere are blocks too
    text = nested(2000)  # deeper than Python's recursion limit would allow
    line = MAX_NESTING + 2  # the Group that opens block MAX_NESTING + 1: lines 1-2 open the file and its root Group
    with pytest.raises(SceneFileError, match=rf"scene.txt:{line}: 'Group' nested more than {MAX_NESTING}"):
        read(tmp_path, text)


def test_files_that_are_not_regular_or_names_with_nul_are_errors_with_a_line(tmp_path):
    with pytest.raises(SceneFileError, match=r"scene.txt:3: cannot read the .obj file '/dev/zero'.*not a regular file"):
        read(tmp_path, one_primitive("TriangleMesh { obj_file /dev/zero }"))
    with pytest.raises(SceneFileError, match=r"scene.txt:3: cannot read the .obj file .*contains a NUL byte"):
        read(tmp_path, one_primitive("TriangleMesh { obj_file a\0b.obj }"))
    with pytest.raises(OSError, match="not a regular file"):
        read_scene_file("/dev/zero")


def test_integers_with_thousands_of_digits_are_refused_at_their_line(tmp_path):
    digits = "9" * 5000  # int() would raise its own ValueError past 4,300 digits
    with pytest.raises(SceneFileError, match=r"scene.txt:1: expected an integer for 'numMaterials' of at most 18"):
        read(tmp_path, f"Materials {{ numMaterials {digits} }}")
