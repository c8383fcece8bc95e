"""Reader for the MIT 6.837 (Fall 2004) scene-file format of assignments 1-4.

The grammar is in scenes/6837/FORMAT.md; docs/6837.md lists where we decide what the course leaves
open. `read_scene_file` returns a plain description (cameras, lights, materials and primitives with
their composed world-from-object matrices) that `SceneFile.to_scene` turns into a `durer.Scene` and
the Blender importer into Blender objects. A malformed file raises `SceneFileError` naming the file,
the line and what was expected; the reader never returns half a scene.
"""

from __future__ import annotations

import dataclasses
import errno
import math
import os
import re
import stat
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import _checks
from ..camera import OrthographicCamera, PerspectiveCamera
from ..material import COURSE_FIELDS, Vec3, material_dataclass
from ..scene import Scene


# `%f` accepts these forms (`-.16`, `.4`, `1e-3`); we refuse inf/nan and Python-only forms like `1_0`.
_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_NUMBER_RE = re.compile(_NUMBER, re.ASCII)
_INTEGER_RE = re.compile(r"[+-]?\d+", re.ASCII)
_OBJ_VERTEX_RE = re.compile(rf"v\s+({_NUMBER})\s+({_NUMBER})\s+({_NUMBER})", re.ASCII)
_OBJ_FACE_RE = re.compile(r"f\s+(\d+)\s+(\d+)\s+(\d+)", re.ASCII)

_MAX_INTEGER_DIGITS = 18  # counts and indices; longer tokens are refused before int() would choke on them
#: Blocks (Groups, Transforms, ...) may nest this deep: the reader recurses once per level, and no
#: course scene nests more than a handful.
MAX_NESTING = 200
_BLOCKS = ("OrthographicCamera", "PerspectiveCamera", "Background", "Lights", "Materials", "Group")
_OBJECTS = ("Group", "Sphere", "Plane", "Triangle", "TriangleMesh", "Transform")
_OPS = ("Scale", "UniformScale", "Translate", "XRotate", "YRotate", "ZRotate", "Rotate", "Matrix")
_LIGHTS = ("DirectionalLight", "PointLight")
_MATERIALS = ("Material", "PhongMaterial")
# field name in the file -> SceneMaterial attribute
_MATERIAL_FIELDS = {
    "diffuseColor": "diffuse",
    "specularColor": "specular",
    "exponent": "exponent",
    "reflectiveColor": "reflective",
    "transparentColor": "transparent",
    "indexOfRefraction": "ior",
}
_MATERIAL_SIZES = {f.name: f.components for f in COURSE_FIELDS}


class SceneFileError(ValueError):
    """A malformed scene or .obj file: `path`, 1-based `line`, and `message` (what was expected)."""

    def __init__(self, path: str | os.PathLike, line: int, message: str) -> None:
        self.path = str(path)
        self.line = line
        # What the file holds is quoted in the message: control characters escaped ('\x01'), not
        # sent raw to the terminal, where they vanish or move the cursor.
        self.message = "".join(c if c.isprintable() else repr(c)[1:-1] for c in message)
        super().__init__(f"{self.path}:{line}: {self.message}")


@dataclass(frozen=True)
class SceneCamera:
    """`size` is the side of the viewed square (orthographic) or the full angle in degrees
    (perspective); `direction` and `up` are as written, not normalised."""

    projection: str
    center: Vec3
    direction: Vec3
    up: Vec3
    size: float

    def to_durer(self) -> OrthographicCamera | PerspectiveCamera:
        """The Dürer camera: orthographic rays count hits from t = -inf, perspective from 0 (6.837)."""
        if self.projection == "orthographic":
            return OrthographicCamera(self.center, self.direction, self.up, size=self.size)
        return PerspectiveCamera(self.center, self.direction, self.up, fov_degrees=self.size)


@dataclass(frozen=True)
class SceneLight:
    """`direction` (directional) is the way the light travels; a point light's colour arrives at
    distance d divided by c0 + c1·d + c2·d² with `attenuation` = (c0, c1, c2)."""

    kind: str
    color: Vec3
    direction: Vec3 | None = None
    position: Vec3 | None = None
    attenuation: Vec3 = (1.0, 0.0, 0.0)


#: The fields of `Material`/`PhongMaterial` (durer.material's, without emission), with the course
#: parser's defaults: they are Dürer's but for the diffuse colour, white in the course.
SceneMaterial = material_dataclass(
    "SceneMaterial", COURSE_FIELDS, defaults={"diffuse": (1.0, 1.0, 1.0)}, frozen=True, module=__name__,
    namespace={"__doc__": "The fields of `Material`/`PhongMaterial`, with the course parser's defaults."})


@dataclass(frozen=True, eq=False)
class ScenePrimitive:
    """One Sphere, Plane, Triangle or TriangleMesh in object space, with `matrix` the (4, 4)
    world-from-object transform composed from every enclosing Transform (identity if none).
    Arrays are read-only; primitives under the same Transform share one matrix object, and meshes
    read from the same .obj share their arrays."""

    kind: str
    material: int
    matrix: np.ndarray
    source: str
    center: Vec3 | None = None
    radius: float | None = None
    normal: Vec3 | None = None
    offset: float | None = None
    vertices: np.ndarray | None = None
    faces: np.ndarray | None = None
    mesh_path: Path | None = None


@dataclass
class SceneFile:
    """Everything a scene file describes. `ambient` is as read; see `effective_ambient`."""

    path: Path
    camera: SceneCamera | None = None
    background: Vec3 = (0.5, 0.5, 0.5)
    ambient: Vec3 = (0.0, 0.0, 0.0)
    lights: list[SceneLight] = field(default_factory=list)
    materials: list[SceneMaterial] = field(default_factory=list)
    primitives: list[ScenePrimitive] = field(default_factory=list)
    #: (line, block keyword, how to make the item alone): for `locate_refusal`.
    items: list[tuple[int, str, Callable[[], object]]] = field(default_factory=list, compare=False, repr=False)

    def locate_refusal(self, error: ValueError, precision: str) -> SceneFileError:
        """The item a render in `precision` refused (`error`: its coordinates or camera window
        beyond what the precision holds), found by making each item alone and checking it in that
        precision, at its line; the camera's line if no item refuses alone."""
        from ..cast import cast
        from ..render import render

        for line, keyword, build in self.items:
            made = build()
            try:
                if isinstance(made, Scene):
                    cast(made, [[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], precision=precision)
                elif made is not None and not isinstance(made, Scene):
                    render(Scene(), made, 1, 1, precision=precision, passes=("depth",))
            except ValueError as alone:
                return SceneFileError(self.path, line, f"Dürer cannot render this {keyword} with precision="
                                                       f"'{precision}': {alone}")
        line = next((line for line, keyword, _ in self.items if keyword.endswith("Camera")), 1)
        return SceneFileError(self.path, line, f"Dürer cannot render this scene with precision='{precision}': {error}")

    @property
    def nothing_to_render(self) -> str | None:
        """Why every pixel will be the background, if the file has no primitive (no Group block, or
        only empty ones: legal, `Group { numObjects 0 }` says so explicitly, but seldom meant); else None."""
        if self.primitives:
            return None
        return (f"{self.path}: nothing to render: no Sphere, Plane, Triangle or TriangleMesh (no Group block, or "
                "only empty ones); the image is the background colour")

    @property
    def effective_ambient(self) -> Vec3:
        """(1, 1, 1) without lights (the A2+ parser forces it so that A1 scenes render flat), else
        `ambient`."""
        return self.ambient if self.lights else (1.0, 1.0, 1.0)

    def to_scene(self, *, shadows: bool = False) -> Scene:
        """The Dürer scene; `shadows` makes every light cast shadows (the -shadows option).

        Without lights Dürer shades flat (diffuse colour), which is what 6.837's forced ambient of
        (1, 1, 1) gives, so the ambient is set only for lit scenes. Spheres and triangles are added
        in one call per distinct matrix, each mesh and plane in a call of its own."""
        scene = Scene()
        scene.background = self.background
        if self.lights:
            scene.ambient = self.effective_ambient
        for light in self.lights:
            if light.kind == "directional":
                scene.add_directional_light(light.direction, light.color, shadows=shadows)
            else:
                scene.add_point_light(light.position, light.color, attenuation=light.attenuation, shadows=shadows)
        # Dürer's material 0 is its built-in default, so file material i gets whatever id comes back.
        ids = np.array([scene.add_material(**dataclasses.asdict(m)) for m in self.materials], dtype=np.int32)
        batches: dict[tuple[str, bytes], list[ScenePrimitive]] = {}
        for primitive in self.primitives:
            if primitive.kind == "mesh":
                scene.add_mesh(primitive.vertices, primitive.faces, int(ids[primitive.material]),
                               transform=_transform_argument(primitive.matrix))
            elif primitive.kind == "plane":
                scene.add_plane(primitive.normal, primitive.offset, int(ids[primitive.material]),
                                transform=_transform_argument(primitive.matrix))
            else:
                batches.setdefault((primitive.kind, primitive.matrix.tobytes()), []).append(primitive)
        for (kind, _), batch in batches.items():
            materials = ids[[p.material for p in batch]]
            transform = _transform_argument(batch[0].matrix)
            if kind == "sphere":
                scene.add_spheres([p.center for p in batch], [p.radius for p in batch], materials, transform=transform)
            else:
                scene.add_triangles(np.stack([p.vertices for p in batch]), materials, transform=transform)
        return scene


def read_scene_file(path: str | os.PathLike) -> SceneFile:
    """Read a 6.837 scene file (and the .obj files it names, relative to its folder).

    Raises SceneFileError for anything malformed, OSError if the scene file itself cannot be read."""
    path = Path(path)
    return _Parser(path, _read_text(path)).parse()


#: The largest scene or .obj file read (a scene file of the course is a few kB, its meshes < 1 MB).
MAX_FILE_BYTES = 256 * 2**20


def _read_text(path: Path) -> str:
    """A regular file's text, at most MAX_FILE_BYTES; OSError otherwise (a device such as /dev/zero
    would never end, a FIFO would block)."""
    if "\0" in str(path):
        raise OSError(errno.EINVAL, "the file name contains a NUL byte")
    with open(path, "rb") as file:
        info = os.fstat(file.fileno())
        if not stat.S_ISREG(info.st_mode):
            raise OSError(errno.EINVAL, f"'{path}' is not a regular file")
        data = file.read(MAX_FILE_BYTES + 1)
    if len(data) > MAX_FILE_BYTES:
        raise OSError(errno.EFBIG, f"'{path}' is larger than {MAX_FILE_BYTES // 2**20} MiB")
    # Windows editors (Notepad) may start a UTF-8 file with a byte order mark: not part of the text.
    return data.decode("utf-8-sig", errors="replace")


# --- transform ops -----------------------------------------------------------------------------

def scale_matrix(x: float, y: float, z: float) -> np.ndarray:
    return np.diag([x, y, z, 1.0])


def translate_matrix(x: float, y: float, z: float) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def axis_rotation_matrix(axis: int, degrees: float) -> np.ndarray:
    """Right-handed rotation about the x (0), y (1) or z (2) axis."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    m = np.eye(4)
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def rodrigues_matrix(axis: Vec3, degrees: float) -> np.ndarray:
    """The course's `Rotate`: the Rodrigues formula c·I + (1 − c)·a·aᵀ + s·[a]× with the axis
    exactly as given. Like the course we do not normalise it, so a non-unit axis also scales."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    a = np.asarray(axis, dtype=np.float64)
    cross = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    m = np.eye(4)
    m[:3, :3] = c * np.eye(3) + (1 - c) * np.outer(a, a) + s * cross
    return m


def _transform_argument(matrix: np.ndarray) -> np.ndarray | None:
    return None if np.array_equal(matrix, _IDENTITY) else matrix


def _frozen(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


_IDENTITY = _frozen(np.eye(4))


# --- .obj files --------------------------------------------------------------------------------

def read_obj(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) float64 and 0-based faces (F, 3) int32 of a .obj file as the course reads
    it: `v x y z` and `f i j k` lines (1-based indices, triangles only, a face using only vertices
    defined above it). Blank lines and `#` comments are skipped; anything else is an error, since
    the course reader would silently misread `vn`/`vt` lines."""
    text = _read_text(path)
    vertex_words: list[str] = []
    vertex_lines: list[int] = []
    face_words: list[str] = []
    face_lines: list[int] = []
    defined_before: list[int] = []  # vertices read before each face
    for number, raw in enumerate(text.splitlines(), 1):  # lines end at \n, \r\n, \r (and Python's other breaks)
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        keyword = line.split(None, 1)[0]
        if keyword == "v":
            match = _OBJ_VERTEX_RE.fullmatch(line)
            if match is None:
                raise SceneFileError(path, number, f"expected 'v x y z' with three numbers, got '{_clip(line)}'")
            vertex_words += match.groups()
            vertex_lines.append(number)
        elif keyword == "f":
            match = _OBJ_FACE_RE.fullmatch(line)
            if match is None:
                raise SceneFileError(path, number, "expected 'f i j k' with three 1-based vertex indices (faces "
                                                   f"are triangles), got '{_clip(line)}'")
            if max(len(index) for index in match.groups()) > _MAX_INTEGER_DIGITS:
                raise SceneFileError(path, number, f"face indices out of range: expected at most {_MAX_INTEGER_DIGITS} "
                                                   f"digits, got '{_clip(line)}'")
            face_words += match.groups()
            face_lines.append(number)
            defined_before.append(len(vertex_lines))
        else:
            raise SceneFileError(path, number, f"expected a 'v x y z' or 'f i j k' line, got '{_clip(line)}' (the "
                                               "6.837 .obj reader understands no other lines)")
    # The regular expressions have vetted every word, so the bulk conversions cannot fail.
    vertices = np.array(vertex_words, dtype=np.float64).reshape(-1, 3)
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        row = int(np.argmax(bad))
        raise SceneFileError(path, vertex_lines[row], f"expected finite vertex coordinates, got {tuple(vertices[row])}")
    faces = np.array(face_words, dtype=np.int64).reshape(-1, 3)
    limits = np.array(defined_before, dtype=np.int64).reshape(-1, 1)
    bad = ((faces < 1) | (faces > limits)).any(axis=1)
    if bad.any():
        row = int(np.argmax(bad))
        raise SceneFileError(path, face_lines[row], f"face indices {tuple(int(i) for i in faces[row])} out of range: "
                                                    f"expected 1..{int(limits[row, 0])} (the vertices defined above)")
    return _frozen(vertices), _frozen((faces - 1).astype(np.int32))


def _clip(text: str, length: int = 40) -> str:
    return text if len(text) <= length else text[: length - 3] + "..."


# --- the scene-file parser ---------------------------------------------------------------------

@dataclass(frozen=True)
class _Token:
    text: str
    line: int


class _Parser:
    """Recursive descent over whitespace-separated tokens, as the course's fscanf("%s") reads them."""

    def __init__(self, path: Path, text: str) -> None:
        self.path = path
        # Lines end at \n, \r\n or \r alike (old Mac editors write \r): line numbers as an editor shows them.
        lines = enumerate(text.splitlines(), 1)
        self.tokens = [_Token(word, number) for number, line in lines for word in line.split()]
        self.pos = 0
        self.open_blocks: list[_Token] = []  # for "… is not closed" at the end of the file
        self.scene = SceneFile(path)
        self.material_count: int | None = None  # until the Materials block is read
        self.unchecked_indices: list[_Token] = []  # MaterialIndex values read before the Materials block
        self.current_material: int | None = None
        self.obj_cache: dict[Path, tuple[np.ndarray, np.ndarray]] = {}

    # --- tokens ---
    def error(self, line: int, message: str) -> SceneFileError:
        return SceneFileError(self.path, line, message)

    def next(self, expected: str) -> _Token:
        if self.pos == len(self.tokens):
            line = self.tokens[-1].line if self.tokens else 1
            unclosed = ""
            if self.open_blocks:
                block = self.open_blocks[-1]
                unclosed = f" (the {block.text} block opened at line {block.line} is not closed)"
            raise self.error(line, f"unexpected end of file: expected {expected}{unclosed}")
        token = self.tokens[self.pos]
        self.pos += 1
        return token

    def expect(self, word: str) -> _Token:
        token = self.next(f"'{word}'")
        if token.text != word:
            where = f" in {self.open_blocks[-1].text}" if self.open_blocks else ""
            raise self.error(token.line, f"expected '{word}'{where}, got '{token.text}'")
        return token

    def open(self, keyword: _Token) -> None:
        token = self.next("'{'")
        if token.text != "{":
            raise self.error(token.line, f"expected '{{' after '{keyword.text}', got '{token.text}'")
        if len(self.open_blocks) >= MAX_NESTING:
            raise self.error(keyword.line, f"'{keyword.text}' nested more than {MAX_NESTING} blocks deep")
        self.open_blocks.append(keyword)

    def core_accepts(self, keyword: _Token, build: Callable[[], object]) -> None:
        """Run `build` (the item alone, made as `to_scene` or the camera makes it) so that what the
        core refuses (it holds the rules: an `up` parallel to the direction once normalised, a
        plane whose offset / |normal| overflows, ...) is refused here, at the item's line."""
        try:
            build()
        except ValueError as error:
            raise self.error(keyword.line, f"Dürer cannot render this {keyword.text}: {error}") from None
        self.scene.items.append((keyword.line, keyword.text, build))

    def close(self) -> None:
        self.expect("}")
        self.open_blocks.pop()

    def number(self, name: str) -> float:
        token = self.next(f"a number for '{name}'")
        if not _NUMBER_RE.fullmatch(token.text):
            raise self.error(token.line, f"expected a number for '{name}', got '{token.text}'")
        value = float(token.text)
        if not math.isfinite(value):
            raise self.error(token.line, f"expected a finite number for '{name}', got '{token.text}'")
        return value

    def integer(self, name: str, minimum: int | None = None) -> int:
        token = self.next(f"an integer for '{name}'")
        if not _INTEGER_RE.fullmatch(token.text):
            raise self.error(token.line, f"expected an integer for '{name}', got '{token.text}'")
        if len(token.text.lstrip("+-")) > _MAX_INTEGER_DIGITS:
            raise self.error(token.line, f"expected an integer for '{name}' of at most {_MAX_INTEGER_DIGITS} digits, "
                                         f"got {len(token.text)} characters")
        value = int(token.text)
        if minimum is not None and value < minimum:
            raise self.error(token.line, f"expected '{name}' >= {minimum}, got {value}")
        return value

    def vector(self, name: str) -> Vec3:
        return self.number(name), self.number(name), self.number(name)

    def vector_field(self, name: str, check: Callable[[Vec3], str | None] | None = None) -> Vec3:
        """`name x y z`; `check` returns what is wrong with the value, if anything."""
        token = self.expect(name)
        value = self.vector(name)
        if check is not None and (problem := check(value)) is not None:
            raise self.error(token.line, f"'{name}' {problem}, got {_format(value)}")
        return value

    def scalar_field(self, name: str) -> tuple[_Token, float]:
        return self.expect(name), self.number(name)

    # --- top level ---
    def parse(self) -> SceneFile:
        seen: dict[str, _Token] = {}
        while self.pos < len(self.tokens):
            token = self.next("a block")
            if token.text not in _BLOCKS:
                raise self.error(token.line, f"expected {_one_of(_BLOCKS)}, got '{token.text}'")
            kind = "camera" if token.text.endswith("Camera") else token.text
            if kind in seen:
                what = "camera" if kind == "camera" else f"{kind} block"
                raise self.error(token.line, f"a second {what}: the first is at line {seen[kind].line}")
            seen[kind] = token
            if kind == "camera":
                self.camera(token)
            elif kind == "Background":
                self.background(token)
            elif kind == "Lights":
                self.lights(token)
            elif kind == "Materials":
                self.materials(token)
            else:
                self.group(token, _IDENTITY)
        for index in self.unchecked_indices:
            self.check_material_index(index)
        return self.scene

    def camera(self, keyword: _Token) -> None:
        self.open(keyword)
        center = self.vector_field("center")
        direction = self.vector_field("direction", _nonzero)
        up_token = self.expect("up")
        up = self.vector("up")
        if not any(up):
            raise self.error(up_token.line, "'up' must not be the zero vector")
        if not np.cross(direction, up).any():
            raise self.error(up_token.line, f"'up' must not be parallel to 'direction', got {_format(up)}")
        if keyword.text == "OrthographicCamera":
            size_token, size = self.scalar_field("size")
            if size <= 0:
                raise self.error(size_token.line, f"expected 'size' > 0, got {size:g}")
            projection = "orthographic"
        else:
            size_token, size = self.scalar_field("angle")
            if not 0 < size < 180:
                raise self.error(size_token.line, f"expected 'angle' in (0, 180) degrees, got {size:g}")
            projection = "perspective"
        self.close()
        camera = SceneCamera(projection, center, direction, up, size)
        self.core_accepts(keyword, camera.to_durer)
        self.scene.camera = camera

    def background(self, keyword: _Token) -> None:
        self.open(keyword)
        while (token := self.next("'color', 'ambientLight' or '}'")).text != "}":
            if token.text not in ("color", "ambientLight"):
                raise self.error(token.line, f"expected 'color', 'ambientLight' or '}}' in Background, "
                                             f"got '{token.text}'")
            self.pos -= 1
            value = self.vector_field(token.text, _non_negative)
            target = "background" if token.text == "color" else "ambient"
            self.core_accepts(keyword, lambda: setattr(Scene(), target, value))
            setattr(self.scene, target, value)
        self.open_blocks.pop()

    def counted(self, keyword: _Token, count_name: str, item: str, kinds: tuple[str, ...],
                parse: Callable[[_Token], None]) -> None:
        """`{ countName n <item> × n }`: the Lights and Materials blocks."""
        self.open(keyword)
        count_token = self.expect(count_name)
        count = self.integer(count_name, 0)
        for i in range(count):
            token = self.next(f"{_one_of(kinds)}")
            if token.text == "}":
                raise self.error(token.line, f"{count_name} is {count} (line {count_token.line}) but the block has "
                                             f"only {i} {item}{'s' if i != 1 else ''}")
            if token.text not in kinds:
                raise self.error(token.line, f"expected {_one_of(kinds)}, got '{token.text}'")
            parse(token)
        token = self.next("'}'")
        if token.text in kinds:
            raise self.error(token.line, f"{count_name} is {count} (line {count_token.line}) but more {item}s follow: "
                                         "expected '}'")
        if token.text != "}":
            raise self.error(token.line, f"expected '}}' to close {keyword.text}, got '{token.text}'")
        self.open_blocks.pop()

    def lights(self, keyword: _Token) -> None:
        self.counted(keyword, "numLights", "light", _LIGHTS, self.light)

    def light(self, keyword: _Token) -> None:
        self.open(keyword)
        if keyword.text == "DirectionalLight":
            direction = self.vector_field("direction", _nonzero)
            color = self.vector_field("color", _non_negative)
            self.close()
            self.add_light(keyword, SceneLight("directional", color, direction=direction))
            return
        position = self.vector_field("position")
        color = self.vector_field("color", _non_negative)
        attenuation = (1.0, 0.0, 0.0)
        token = self.next("'attenuation' or '}'")
        if token.text == "attenuation":
            self.pos -= 1
            attenuation = self.vector_field("attenuation", _attenuation)
            token = self.next("'}'")
        if token.text != "}":
            raise self.error(token.line, f"expected 'attenuation' or '}}' in PointLight, got '{token.text}'")
        self.open_blocks.pop()
        self.add_light(keyword, SceneLight("point", color, position=position, attenuation=attenuation))

    def add_light(self, keyword: _Token, light: SceneLight) -> None:
        self.core_accepts(keyword, SceneFile(self.path, lights=[light]).to_scene)
        self.scene.lights.append(light)

    def materials(self, keyword: _Token) -> None:
        self.counted(keyword, "numMaterials", "material", _MATERIALS, self.material)
        self.material_count = len(self.scene.materials)

    def material(self, keyword: _Token) -> None:
        self.open(keyword)
        values: dict[str, object] = {}
        while (token := self.next("a material field or '}'")).text != "}":
            if token.text not in _MATERIAL_FIELDS:
                raise self.error(token.line, f"expected {_one_of((*_MATERIAL_FIELDS, '}'))} in {keyword.text}, "
                                             f"got '{token.text}'")
            name = _MATERIAL_FIELDS[token.text]
            if _MATERIAL_SIZES[name] == 3:
                self.pos -= 1
                values[name] = self.vector_field(token.text, _non_negative)
                continue
            value = self.number(token.text)
            if name == "exponent" and value < 0:
                raise self.error(token.line, f"expected 'exponent' >= 0, got {value:g}")
            if name == "ior" and value <= 0:
                raise self.error(token.line, f"expected 'indexOfRefraction' > 0, got {value:g}")
            values[name] = value
        self.open_blocks.pop()
        material = SceneMaterial(**values)
        self.core_accepts(keyword, SceneFile(self.path, materials=[material]).to_scene)
        self.scene.materials.append(material)

    # --- objects ---
    def group(self, keyword: _Token, matrix: np.ndarray) -> None:
        self.open(keyword)
        count_token = self.expect("numObjects")
        count = self.integer("numObjects", 0)
        found = 0
        while (token := self.next("an object, 'MaterialIndex' or '}'")).text != "}":
            if token.text == "MaterialIndex":
                index = self.integer("MaterialIndex")
                self.current_material = index
                marker = _Token(str(index), token.line)
                if self.material_count is None:
                    self.unchecked_indices.append(marker)
                else:
                    self.check_material_index(marker)
                continue
            if token.text not in _OBJECTS:
                raise self.error(token.line, f"expected {_one_of(_OBJECTS + ('MaterialIndex', '}'))} in Group, "
                                             f"got '{token.text}'")
            if found == count:
                raise self.error(token.line, f"numObjects is {count} (line {count_token.line}) but more objects "
                                             "follow: expected '}'")
            found += 1
            self.object(token, matrix)
        if found < count:
            raise self.error(token.line, f"numObjects is {count} (line {count_token.line}) but the Group has only "
                                         f"{found} object{'s' if found != 1 else ''}")
        self.open_blocks.pop()

    def check_material_index(self, marker: _Token) -> None:
        count = self.material_count or 0
        index = int(marker.text)
        if not 0 <= index < count:
            valid = f"0..{count - 1}" if count else "none: the file has no materials"
            raise self.error(marker.line, f"MaterialIndex {index} out of range: expected {valid}")

    def object(self, keyword: _Token, matrix: np.ndarray) -> None:
        if keyword.text == "Group":
            self.group(keyword, matrix)
        elif keyword.text == "Transform":
            self.transform(keyword, matrix)
        else:
            if self.current_material is None:
                raise self.error(keyword.line, f"no MaterialIndex before this {keyword.text}: expected "
                                               "'MaterialIndex i' before the first primitive")
            self.open(keyword)
            values = getattr(self, keyword.text.lower())()
            self.close()
            kind = {"Sphere": "sphere", "Plane": "plane", "Triangle": "triangle", "TriangleMesh": "mesh"}[keyword.text]
            primitive = ScenePrimitive(kind, self.current_material, matrix, f"{self.path}:{keyword.line}", **values)
            alone = SceneFile(self.path, materials=[SceneMaterial()], primitives=[dataclasses.replace(primitive, material=0)])
            self.core_accepts(keyword, alone.to_scene)
            self.scene.primitives.append(primitive)

    def sphere(self) -> dict[str, object]:
        center = self.vector_field("center")
        radius_token, radius = self.scalar_field("radius")
        if radius <= 0:
            raise self.error(radius_token.line, f"expected 'radius' > 0, got {radius:g}")
        return {"center": center, "radius": radius}

    def plane(self) -> dict[str, object]:
        normal = self.vector_field("normal", _nonzero)
        return {"normal": normal, "offset": self.scalar_field("offset")[1]}

    def triangle(self) -> dict[str, object]:
        # A degenerate triangle is legal: it is never hit.
        vertices = np.array([self.vector_field("vertex0"), self.vector_field("vertex1"), self.vector_field("vertex2")])
        return {"vertices": _frozen(vertices)}

    def trianglemesh(self) -> dict[str, object]:
        token = self.expect("obj_file")
        name = self.next("an .obj file name")
        path = self.path.parent / name.text
        if path not in self.obj_cache:
            try:
                self.obj_cache[path] = read_obj(path)
            except OSError as error:
                raise self.error(name.line, f"cannot read the .obj file '{path}' named by '{token.text}': "
                                            f"{error.strerror or error}") from None
        vertices, faces = self.obj_cache[path]
        if not len(faces):  # an empty export or the wrong file: a mesh without triangles shows nothing
            raise self.error(name.line, f"the .obj file '{path}' named by '{token.text}' has no faces: expected at "
                                        "least one 'f i j k' line")
        return {"vertices": vertices, "faces": faces, "mesh_path": path}

    def transform(self, keyword: _Token, parent: np.ndarray) -> None:
        """`Transform { op* object }`: M = I, then M = M·Op for each op (the first op listed is
        applied last), except `Matrix`, which the course pre-multiplies."""
        self.open(keyword)
        local = np.eye(4)
        while (token := self.next("a transform op or an object")).text in _OPS:
            op = self.op(token)
            if not _checks.is_invertible(op):
                raise self.error(token.line, f"{token.text} is not invertible: expected a non-singular transform")
            local = op @ local if token.text == "Matrix" else local @ op
        if token.text not in _OBJECTS:
            raise self.error(token.line, f"expected a transform op ({_listing(_OPS)}) or an object "
                                         f"({_listing(_OBJECTS)}) in Transform, got '{token.text}'")
        world = parent @ local
        if not _checks.is_invertible(world):
            raise self.error(keyword.line, "the composed transform is not invertible")
        self.object(token, _frozen(world))
        self.close()

    def op(self, keyword: _Token) -> np.ndarray:
        name = keyword.text
        # Later course parsers wrap every op's values in braces (`Translate { 1 2 3 }`); we accept both.
        braced = name in ("Rotate", "Matrix") or (self.pos < len(self.tokens) and self.tokens[self.pos].text == "{")
        if braced:
            self.open(keyword)
        if name == "Scale":
            m = scale_matrix(*self.vector(name))
        elif name == "UniformScale":
            s = self.number(name)
            m = scale_matrix(s, s, s)
        elif name == "Translate":
            m = translate_matrix(*self.vector(name))
        elif name in ("XRotate", "YRotate", "ZRotate"):
            m = axis_rotation_matrix("XYZ".index(name[0]), self.number(name))
        elif name == "Rotate":
            axis_line = self.tokens[self.pos].line if self.pos < len(self.tokens) else keyword.line
            axis = self.vector("Rotate axis")
            if not any(axis):
                raise self.error(axis_line, "the Rotate axis must not be the zero vector")
            m = rodrigues_matrix(axis, self.number("Rotate angle"))
        else:
            # 16 numbers, row by row (`p' = M p`, column vectors).
            m = np.array([self.number("Matrix") for _ in range(16)]).reshape(4, 4)
            if not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
                raise self.error(keyword.line, f"expected an affine Matrix (last row 0 0 0 1), got last row "
                                               f"{_format(tuple(m[3]))}")
        if braced:
            self.close()
        return m


# --- value checks: each returns what is wrong, or None ---

def _nonzero(v: Vec3) -> str | None:
    return "must not be the zero vector" if not any(v) else None


def _non_negative(v: Vec3) -> str | None:
    return "must be >= 0 in every component (Dürer renders no negative light)" if min(v) < 0 else None


def _attenuation(v: Vec3) -> str | None:
    if min(v) < 0:
        return "must be >= 0 in every component"
    return "must not be all zero (the light would be infinite)" if not any(v) else None


def _format(v: tuple[float, ...]) -> str:
    return " ".join(f"{x:g}" for x in v)


def _one_of(words: tuple[str, ...]) -> str:
    quoted = [f"'{w}'" for w in words]
    return quoted[0] if len(quoted) == 1 else ", ".join(quoted[:-1]) + " or " + quoted[-1]


def _listing(words: tuple[str, ...]) -> str:
    return ", ".join(f"'{w}'" for w in words)
