"""The hardening fuzz (issue 18): the three surfaces a user reaches, driven by fuzz bytes.

Each surface is a function of one `bytes` input, so the same code runs under atheris (coverage-guided
bytes, bench/fuzz_hardening.py --engine atheris), under the bench's own random bytes and under
hypothesis in the suite (tests/test_hardening_fuzz.py). `Source` turns the bytes into choices: which
call, which argument, which of the interesting numbers; bytes that run out read as zeros (the first
option, no rare branch), so every input is a case and a shorter input a plainer one.

- `api_case`: a `durer.Scene` built by a sequence of add_* calls and setters with fuzzed arguments
  (numbers from the extremes of both precisions, arrays of wrong shapes and dtypes, ids beyond int32),
  then `render` and `cast` (and `occluded` of the same rays, which must agree with it) with fuzzed
  options, cameras and rays.
- `reader_case`: a scene of scenes/6837/ mutated byte by byte (flips, insertions, deletions, splices)
  and by its grammar (numbers replaced by extremes or odd spellings, tokens dropped, duplicated or
  swapped, keywords exchanged, blocks wrapped in Transforms and Groups, counts changed, .obj files
  mutated or replaced by devices and folders), read and, if it reads, rendered at 4x4.
- `cli_case`: `python -m durer` (the dispatcher, `raytracer`, `demo`, `render`) with fuzzed argv,
  in-process.

The oracle (`Finding` when it fails): only the documented exceptions (the API's ValueError and
TypeError; the reader's one-line SceneFileError with file:line; a command's exit status 0, 1 or 2
with one error line and no traceback), and finite colour, normal and depth in every rendered pass
(depth +inf where the pixel missed: the documented miss value, with a zero normal). `NonFinite`
marks a NaN or inf from a case that drew an extreme number (issue 18 item 3's). Crashes (signals)
and hangs are the bench's to see: it runs the cases in a child process and saves the input that
killed or stalled it.
"""

from __future__ import annotations

import contextlib
import io
import math
import random
import re
import shutil
import struct
import traceback
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

import durer
from durer.cast import CastResult
from durer.course.raytracer import render_scene_file
from durer.course.scene_file import SceneFileError, read_scene_file
from durer.render import PRECISIONS, SAMPLERS, SPHERE_METHODS

from . import CORPUS

SEEDS = sorted(p for p in CORPUS.glob("*.txt") if p.name != "commands.txt")
OBJS = sorted(CORPUS.glob("*.obj"))
SURFACES = ("api", "reader", "cli")

# The extremes of both precisions and of the integer types, and ordinary values to keep cases valid.
NUMBERS = (
    0.0, -0.0, 1.0, -1.0, 0.5, 2.0, 3.0, -2.5, 10.0, 100.0, 1e-3,
    5e-324, 1e-320, 2.2250738585072014e-308, 1e-300, 1e-160, 1e-154, 1.2e-38, 1e-40, 1e-30, 1e-8,
    1e8, 1e15, 1e30, 3.4028234663852886e38, 3.5e38, 1e39, 1e150, 1e154, 1e200, 1e300, 1e307, 1e308,
    1.7976931348623157e308, math.inf, -math.inf, math.nan, -1e308, -1e39, 2.0**31, 2.0**32 + 1, 2.0**63,
)
#: Python integers, some beyond every float (10**400: float() of it overflows).
INTEGERS = (0, 1, 2, 3, 4, -1, 7, 8, 16, 2**31 - 1, 2**31, -(2**31) - 1, 2**32 + 1, 2**63, 2**64, -(2**63), 10**30,
            10**400, -(10**400))
#: Extreme numbers give finite passes or are refused; without `extremes` the cases keep every number
#: in 1e-6..1e6 in magnitude (or 0, or refused forms).
ORDINARY = 1e6


def ordinary(x: float) -> bool:
    if isinstance(x, int):  # exact: no float of 10**400
        return abs(x) <= ORDINARY
    return x == 0 or not math.isfinite(x) or 1 / ORDINARY <= abs(x) <= ORDINARY


# Spellings of numbers in a scene file: odd forms the reader must refuse or read exactly.
NUMBER_WORDS = ("1e400", "-1e400", "1e-400", "1e-320", "1e308", "1e39", "1e300", "-0", ".5", "5.", "-.0", "0x10", "1_0",
                "nan", "inf", "-inf", "1e", "e5", "+-1", "1,5", "9" * 30, "9" * 19, "-" + "9" * 18, "1e+308",
                "4.9e-324", "00000000000000000000001", "1e00000000000000000000001", "١", "１", "1e-5", "123456.5")
KEYWORDS = ("OrthographicCamera", "PerspectiveCamera", "Background", "Lights", "Materials", "Group", "Sphere",
            "Plane", "Triangle", "TriangleMesh", "Transform", "Scale", "UniformScale", "Translate", "XRotate",
            "YRotate", "ZRotate", "Rotate", "Matrix", "DirectionalLight", "PointLight", "Material",
            "PhongMaterial", "center", "direction", "up", "size", "angle", "color", "ambientLight", "numLights",
            "numMaterials", "numObjects", "MaterialIndex", "radius", "normal", "offset", "vertex0", "vertex1",
            "vertex2", "obj_file", "position", "attenuation", "diffuseColor", "specularColor", "exponent",
            "reflectiveColor", "transparentColor", "indexOfRefraction", "{", "}")
DTYPES = (np.float64, np.float32, np.float16, np.int64, np.int32, np.uint8, np.bool_, np.complex128, object, "U3")
PASS_SETS = (("color",), ("depth",), ("normal",), ("color", "depth", "normal"), ("depth", "object_id", "material_id"),
             (), ("colour",), "color", None)


class Finding(AssertionError):
    """The oracle failed: an undocumented exception, a bad exit, a traceback or a non-finite pass."""


class NonFinite(Finding):
    """NaN or infinity in a rendered pass or a cast (what issue 18 item 3 is to end)."""


@dataclass
class Tally:
    """What the cases did: inputs per surface and what became of them (rendered, or which error)."""

    inputs: Counter = field(default_factory=Counter)
    outcomes: Counter = field(default_factory=Counter)
    renders: int = 0
    pixels: int = 0

    def __str__(self) -> str:
        common = ", ".join(f"{k} {v}" for k, v in self.outcomes.most_common(8))
        return (f"inputs {dict(self.inputs)}, {self.renders} renders ({self.pixels} pixels checked); "
                f"outcomes: {common}")


def random_input(rng: random.Random) -> bytes:
    """Random bytes of a random length: the inputs of the suite and of the bench's random engine."""
    return rng.randbytes(rng.choice((8, 32, 128, 512, 2048)))


class Source:
    """Choices read from fuzz bytes, front to back; past the end every byte reads as 0."""

    def __init__(self, data: bytes, extremes: bool = True) -> None:
        self.data = data
        self.pos = 0
        self.extremes = extremes
        self.drew_extreme = False  # whether any number drawn was out of the ordinary range

    def byte(self) -> int:
        value = self.data[self.pos] if self.pos < len(self.data) else 0
        self.pos += 1
        return value

    def below(self, n: int) -> int:
        """0..n-1 (n <= 65536)."""
        if n <= 256:
            return self.byte() % n
        return (self.byte() << 8 | self.byte()) % n

    def chance(self, in_256: int) -> bool:
        """True with probability in_256/256; False once the bytes have run out."""
        return self.byte() >= 256 - in_256

    def choice(self, options: Sequence[Any]) -> Any:
        return options[self.below(len(options))]

    def number(self) -> float:
        """Mostly the table's extremes and ordinary values, sometimes any double from 8 bytes."""
        if self.chance(32):
            x = struct.unpack("<d", bytes(self.byte() for _ in range(8)))[0]
        else:
            x = self.choice(NUMBERS)
        return self.checked(x) if self.extremes or ordinary(x) else self.small()

    def checked(self, x: float) -> float:
        """`x`, noting whether it is extreme."""
        self.drew_extreme |= not ordinary(x)
        return x

    def word(self) -> str:
        """A spelling of a number from NUMBER_WORDS (within ORDINARY without `extremes`)."""
        word = self.choice(NUMBER_WORDS)
        try:
            x = float(word)
        except ValueError:
            return word
        if self.extremes or ordinary(x):
            self.checked(x)
            return word
        return ".5"

    def small(self) -> float:
        """An ordinary value: the building blocks of cases that render."""
        return (self.byte() - 128) / 16

    def value(self, ordinary: Callable[[], Any]) -> Any:
        """Usually `ordinary()`, else an extreme number, an integer, or a value of the wrong type."""
        roll = self.byte()
        if roll < 224:
            return ordinary()
        if roll < 244:
            return self.number()
        if roll < 250:
            n = self.choice(INTEGERS)
            return self.checked(n) if self.extremes or abs(n) <= ORDINARY else self.below(8)
        return self.choice((None, "1", True, [1.0], (1.0, 2.0), {}, np.float32(2.5), np.int64(3), 1 + 2j, b"x",
                            np.array(1.5), (x for x in (1.0, 2.0, 3.0))))

    def array(self, shape: tuple[int, ...], ordinary: Callable[[], float]) -> Any:
        """An array of `shape`, or now and then of another shape or dtype, ragged, or a scalar."""
        roll = self.byte()
        if roll < 232:
            values = [self.value(ordinary) if self.chance(8) else ordinary() for _ in range(int(np.prod(shape)))]
            return _natural(np.array(values, dtype=object).reshape(shape))
        if roll < 240:
            wrong = tuple(max(0, s + self.below(3) - 1) for s in shape) + ((self.below(3) + 1,) if self.chance(40) else ())
            return np.full(wrong, ordinary())
        if roll < 246:
            dtype = self.choice(DTYPES)
            try:
                return np.full(shape, ordinary()).astype(dtype)
            except (TypeError, ValueError):
                return np.zeros(shape, dtype=dtype)
        if roll < 250:  # other buffers and layouts of the same numbers: a memoryview, a strided or big-endian view
            values = np.full(shape, ordinary())
            return self.choice((memoryview(values), np.asfortranarray(values), values.astype(">f8"),
                                np.repeat(values, 2, axis=-1)[..., ::2] if values.ndim else values))
        return self.choice(([[1, 2], [3]], "abc", None, 7, [[[]]], [np.nan] * 3, ()))


def _natural(array: np.ndarray) -> np.ndarray:
    """An object array as the array numpy would make of its values (ints, floats), if it can."""
    try:
        return np.array(array.tolist()).reshape(array.shape)
    except (TypeError, ValueError):
        return array


# --- the oracle ----------------------------------------------------------------------------------

def check_result(result: durer.RenderResult, tally: Tally) -> None:
    """Finite colour and normal; depth finite, or +inf on a miss (with a zero normal and object id -1)."""
    tally.renders += 1
    if result.color is not None:
        tally.pixels += result.color.shape[0] * result.color.shape[1]
        if not np.isfinite(result.color).all():
            raise NonFinite(f"non-finite colour\n{result.color[~np.isfinite(result.color)][:8]}")
    if result.normal is not None and not np.isfinite(result.normal).all():
        raise NonFinite(f"non-finite normal\n{result.normal[~np.isfinite(result.normal)][:8]}")
    if result.depth is not None:
        depth = result.depth
        bad = ~np.isfinite(depth) & ~(depth == np.inf)
        if bad.any():
            raise NonFinite(f"depth -inf or NaN (only +inf, a miss, may be non-finite)\n{depth[bad][:8]}")
        if result.normal is not None and (result.normal[depth == np.inf] != 0).any():
            raise NonFinite("depth +inf (a miss) on a pixel with a normal: a hit at infinite depth")
        if result.object_id is not None and ((result.object_id == -1) != (depth == np.inf)).any():
            raise NonFinite("object id -1 (a miss) where the depth is finite, or an id at infinite depth")


def check_cast(hits: CastResult) -> None:
    """t finite, or +inf on a miss (object id -1); finite normals."""
    t = hits.t
    bad = ~np.isfinite(t) & ~(t == np.inf)
    if bad.any():
        raise NonFinite(f"cast t -inf or NaN (only +inf, a miss, may be non-finite)\n{t[bad][:8]}")
    if not np.isfinite(hits.normal).all():
        raise NonFinite("non-finite cast normal")
    if ((t == np.inf) != (hits.object_id == -1)).any():
        raise NonFinite("a cast hit at t = inf, or a miss with an object id")


def _judged(finding: Finding, src: Source) -> type[Finding]:
    """A non-finite pass is issue 18 item 3's (NonFinite) only if the case drew an extreme number;
    from ordinary numbers it is a bug like any other (Finding)."""
    if isinstance(finding, NonFinite) and src.drew_extreme:
        return NonFinite
    return Finding


def _documented(error: BaseException, tally: Tally, surface: str) -> None:
    """The API's errors: ValueError or TypeError (with a message); anything else is a finding."""
    if isinstance(error, Finding):
        raise error
    if type(error) not in (ValueError, TypeError) or not str(error):
        raise Finding(f"{surface}: undocumented {type(error).__name__}: {error}\n"
                      + "".join(traceback.format_exception(error))) from error
    tally.outcomes[f"{surface} {type(error).__name__}"] += 1


# --- surface (a): the Python API -----------------------------------------------------------------

def _vec(src: Source) -> Any:
    return src.array((3,), src.small)


def _color(src: Source) -> Any:
    return src.array((3,), lambda: src.byte() / 128)


def _transform(src: Source) -> Any:
    if not src.chance(60):
        return None
    if src.chance(40):
        return src.array(src.choice(((4, 4), (3, 4))), src.small)
    m = np.eye(4, dtype=object)
    scale = [src.value(lambda: 0.5 + src.byte() / 64) for _ in range(3)]
    m[:3, :3] = np.diag(scale) if src.chance(128) else np.eye(3) + np.array([[src.small() / 4] * 3] * 3)
    m[:3, 3] = [src.small() for _ in range(3)]
    return _natural(m)


def _count(src: Source) -> int:
    return src.choice((1, 1, 2, 3, 5, 0, 20))


def _api_call(scene: durer.Scene, src: Source) -> None:
    kind = src.below(13)
    material = lambda n: src.value(lambda: src.below(scene.material_count + 1)) if not src.chance(56) else \
        src.array((n,), lambda: src.below(scene.material_count))  # noqa: E731
    if kind == 0:
        kwargs = {"diffuse": _color(src)}
        for name in ("emission", "specular", "reflective", "transparent"):
            if src.chance(60):
                kwargs[name] = _color(src)
        if src.chance(60):
            kwargs["exponent"] = src.value(lambda: src.byte() / 4)
        if src.chance(60):
            kwargs["ior"] = src.value(lambda: 1 + src.byte() / 128)
        scene.add_material(**kwargs)
    elif kind in (1, 2):
        n = _count(src)
        radii = src.value(lambda: 0.1 + src.byte() / 64) if src.chance(128) else src.array((n,), lambda: 0.1 + src.byte() / 64)
        scene.add_spheres(src.array((n, 3), src.small), radii, material(n), transform=_transform(src))
    elif kind == 3:
        bounds = None
        if src.chance(80):
            bounds = (_vec(src), _vec(src), _vec(src))
        scene.add_plane(_vec(src), src.value(src.small), material(1) if src.chance(20) else src.value(lambda: 0),
                        bounds, transform=_transform(src))
    elif kind in (4, 5):
        n = _count(src)
        scene.add_triangles(src.array((n, 3, 3), src.small), material(n), transform=_transform(src))
    elif kind == 6:
        v = _count(src) + 2
        faces = np.asarray(src.array((_count(src), 3), lambda: src.below(v + 1)))
        if not src.chance(56) and faces.dtype.kind == "f" and np.isfinite(faces).all():
            faces = faces.astype(np.int64)
        normals = None
        if src.chance(96):  # a smooth mesh: per vertex or per corner, of any length, now and then zero
            shape = (v, 3) if src.chance(128) else (np.shape(faces)[0] if np.ndim(faces) else 0, 3, 3)
            normals = src.array(shape, lambda: src.small() if src.chance(240) else 0.0)
        scene.add_mesh(src.array((v, 3), src.small), faces, src.value(lambda: 0), transform=_transform(src),
                       normals=normals)
    elif kind == 7:
        n = _count(src)
        lo = src.array((n, 3), src.small)
        extent = src.array((n, 3), lambda: 0.1 + src.byte() / 32)
        numeric = all(np.asarray(a).dtype.kind in "iuf" and np.shape(a) == (n, 3) for a in (lo, extent))
        hi = lo + extent if numeric and not src.chance(56) else src.array((n, 3), src.small)
        scene.add_boxes(lo, hi, material(n), transform=_transform(src))
    elif kind == 8:
        scene.add_directional_light(_vec(src), _color(src), shadows=src.value(lambda: src.chance(128)),
                                    **_soft(src, "angle_degrees", lambda: src.byte() * 0.8))
    elif kind == 9:
        scene.add_point_light(_vec(src), _color(src), attenuation=src.array((3,), lambda: src.byte() / 64),
                              shadows=src.value(lambda: src.chance(128)),
                              **_soft(src, "radius", lambda: abs(src.small())))
    elif kind == 10 and src.chance(100):
        scene.add_area_light(_vec(src), _vec(src), _vec(src), _color(src), ellipse=src.value(lambda: src.chance(128)),
                             samples=src.value(lambda: src.below(5)), shadows=src.value(lambda: src.chance(128)))
    elif kind == 10:
        scene.add_spot_light(_vec(src), _vec(src), _color(src), half_angle_degrees=src.value(lambda: src.byte() / 1.5),
                             blend=src.value(lambda: src.byte() / 255), shadows=src.value(lambda: src.chance(128)),
                             **_soft(src, "radius", lambda: abs(src.small())))
    elif kind == 11:
        setattr(scene, src.choice(("background", "ambient")),
                src.array((src.choice((3, 4)),), lambda: src.byte() / 255))
    else:
        scene.shading = src.value(lambda: src.choice(("auto", "flat", "lit", "Lit", "")))


def _soft(src: Source, size: str, ordinary: Callable[[], Any]) -> dict[str, Any]:
    """A light's size, half the time (radius or angle: highlights spread over it), with a few samples
    for soft shadows or none (soft_shadows=False)."""
    if not src.chance(128):
        return {}
    return {size: src.value(ordinary), "samples": src.value(lambda: src.below(5)),
            "soft_shadows": src.value(lambda: src.chance(192))}


def _camera(src: Source, api: Any) -> Any:
    cls = src.choice(("OrthographicCamera", "PerspectiveCamera"))
    center = src.array((3,), lambda: src.small() + (8 if not src.chance(56) else 0))
    kwargs: dict[str, Any] = {}
    if src.chance(80):
        kwargs["fit"] = src.value(lambda: src.choice(("auto", "horizontal", "vertical")))
    if src.chance(60):
        kwargs["shift"] = src.array((2,), lambda: src.small() / 8)
    if src.chance(60):
        kwargs["pixel_aspect"] = src.value(lambda: 0.25 + src.byte() / 64)
    if src.chance(40):
        kwargs[src.choice(("t_min", "t_max"))] = src.value(src.small)
    orthographic = cls == "OrthographicCamera"
    if not orthographic and src.chance(80):
        kwargs["clip_planes"] = src.value(lambda: src.chance(128))
    kwargs["size" if orthographic else "fov_degrees"] = src.value(lambda: 1 + src.byte() / 16 if orthographic else
                                                                  10 + src.byte() / 2)
    direction = src.array((3,), lambda: src.small() - (8 if not src.chance(56) else 0))
    up = src.array((3,), lambda: src.small() / 16 + 0.5) if src.chance(26) else (src.small() / 16, 1.0, 0.3)
    return getattr(api, cls)(center, direction, up, **kwargs)


class _Logged:
    """An object whose calls are written to `log` as Python (with exact floats): a reproduction."""

    def __init__(self, target: Any, name: str, log: list[str]) -> None:
        object.__setattr__(self, "_target", (target, name, log))

    def __getattr__(self, attribute: str) -> Any:
        target, name, log = self._target
        value = getattr(target, attribute)
        if not callable(value):
            return value

        def call(*args: Any, **kwargs: Any) -> Any:
            log.append(f"{name}.{attribute}({_arguments(args, kwargs)})")
            try:
                return value(*args, **kwargs)
            except Exception as error:
                log[-1] = f"# {type(error).__name__}: {log[-1]}"
                raise
        return call

    def __setattr__(self, attribute: str, value: Any) -> None:
        target, name, log = self._target
        log.append(f"{name}.{attribute} = {_arguments((value,), {})}")
        setattr(target, attribute, value)


def _arguments(args: tuple, kwargs: dict) -> str:
    with np.printoptions(floatmode="unique", threshold=10**6):
        return ", ".join([repr(a) for a in args] + [f"{k}={v!r}" for k, v in kwargs.items()])


def api_case(data: bytes, tally: Tally, extremes: bool = True) -> None:
    """A scene from up to 12 fuzzed calls, one render and one cast: errors must be documented ones.
    A finding carries the calls, as Python that repeats them."""
    tally.inputs["api"] += 1
    log = ["import durer, numpy as np", "from numpy import array, float64, float32, int64, int32", "",
           "scene = durer.Scene()"]
    src = Source(data, extremes)
    try:
        _api_calls(src, tally, log)
    except Finding as finding:
        raise _judged(finding, src)(f"{finding}\nthe calls:\n" + "\n".join(log)) from None


def _api_calls(src: Source, tally: Tally, log: list[str]) -> None:
    scene = durer.Scene()
    logged = _Logged(scene, "scene", log)
    api = _Logged(durer, "durer", log)
    for _ in range(1 + src.below(12)):
        try:
            _api_call(logged, src)
        except Exception as error:  # noqa: BLE001 - the oracle judges every exception
            _documented(error, tally, "api")
    try:
        camera = _camera(src, api)
        log[-1] = "camera = " + log[-1]
        options: dict[str, Any] = {"threads": src.value(lambda: src.choice((1, 2)))}
        for name, ordinary in (("spp", lambda: src.choice((1, 2, 4, 9))), ("sampler", lambda: src.choice(SAMPLERS)),
                               ("precision", lambda: src.choice(PRECISIONS)),
                               ("sphere_method", lambda: src.choice(SPHERE_METHODS)),
                               ("max_bounces", lambda: src.choice((0, 1, 4, 30))), ("min_weight", lambda: src.byte() / 2550),
                               ("shade_back", lambda: src.chance(128)), ("depth", lambda: src.choice(("ray", "planar"))),
                               ("seed", lambda: src.byte()), ("target_error", lambda: src.byte() / 1000)):
            if src.chance(100):
                options[name] = src.value(ordinary)
        if src.chance(60):
            options["passes"] = src.choice(PASS_SETS)
        width, height = (src.value(lambda: 1 + src.below(8)) for _ in range(2))
        if src.chance(30):
            options["region"] = tuple(src.value(lambda: src.below(9)) for _ in range(src.choice((4, 4, 3))))
        result = api.render(scene, camera, width, height, **options)
        log[-1] = "result = " + log[-1].replace("<durer.scene.Scene object", "scene  # <").replace(
            repr(camera), "camera")
        check_result(result, tally)
        tally.outcomes["api rendered"] += 1
    except Exception as error:  # noqa: BLE001
        _documented(error, tally, "api")
    try:
        n = src.below(9)
        origins = src.array((n, 3), lambda: src.small() * 2)
        directions = src.array((n, 3), src.small)
        kwargs = {name: src.value(ordinary) for name, ordinary in (
            ("t_min", lambda: src.choice((0.0, -math.inf, 1e-3))), ("t_max", lambda: src.choice((math.inf, 10.0))),
            ("precision", lambda: src.choice(PRECISIONS)), ("check", lambda: not src.chance(56)))
            if src.chance(60)}
        hits = api.cast(scene, origins, directions, **kwargs)
        check_cast(hits)
        # The any-hit query of the same rays: a hit exactly where cast found one.
        if not np.array_equal(api.occluded(scene, origins, directions, **kwargs), np.isfinite(hits.t)):
            raise Finding("occluded differs from where cast hits")
        tally.outcomes["api cast"] += 1
    except Exception as error:  # noqa: BLE001
        _documented(error, tally, "api")


# --- surface (b): the 6.837 scene-file reader ----------------------------------------------------

_TOKEN_RE = re.compile(rb"\S+")
_NUMBER_TOKEN_RE = re.compile(rb"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


def prepare_folder(folder: Path) -> None:
    """The .obj files the seeds name, linked into `folder` (the reader reads them beside the scene)."""
    folder.mkdir(parents=True, exist_ok=True)
    for obj in OBJS:
        link = folder / obj.name
        if not link.exists():
            link.symlink_to(obj)
    (folder / "a_folder.obj").mkdir(exist_ok=True)
    (folder / "garbage.blend").write_bytes(b"BLENDER-v500" + bytes(range(256)))


def _token_spans(text: bytes) -> list[tuple[int, int]]:
    return [m.span() for m in _TOKEN_RE.finditer(text)]


def _mutate_bytes(text: bytearray, src: Source) -> bytearray:
    kind = src.below(5)
    at = src.below(len(text) + 1) if len(text) < 65536 else src.below(65536) * len(text) // 65536
    if kind == 0 and text:
        text[min(at, len(text) - 1)] ^= 1 << src.below(8)
    elif kind == 1:
        text[at:at] = bytes(src.byte() for _ in range(1 + src.below(4)))
    elif kind == 2:
        del text[at:at + 1 + src.below(16)]
    elif kind == 3:
        text[at:at] = src.choice((b"\0", b"\xff\xfe", b"\r", b"\t", b"{", b"}", b" -", b"#", "\u00e9".encode()))
    else:  # splice a piece of another seed
        other = src.choice(SEEDS).read_bytes()
        start = src.below(len(other))
        text[at:at] = other[start:start + 1 + src.below(200)]
    return text


def _mutate_grammar(text: bytearray, src: Source, folder: Path) -> bytearray:
    spans = _token_spans(bytes(text))
    if not spans:
        return bytearray(src.choice(KEYWORDS).encode())
    i = src.below(len(spans))
    start, end = spans[i]
    token = bytes(text[start:end])
    kind = src.below(9)
    if kind in (0, 1, 2):  # a number becomes an extreme: the commonest way values reach the core
        numbers = [s for s in spans if _NUMBER_TOKEN_RE.fullmatch(text[s[0]:s[1]])]
        if numbers:
            start, end = src.choice(numbers)
        word = src.word() if kind == 2 else repr(src.number() * (1 if not src.chance(56) else -1))
        replacement = word.encode()
    elif kind == 3:
        replacement = b""
    elif kind == 4:
        j = min(len(spans) - 1, i + src.below(40))
        replacement = text[start:spans[j][1]] + b" " + text[start:spans[j][1]]
        end = spans[j][1]
    elif kind == 5:
        replacement = src.choice(KEYWORDS).encode()
    elif kind == 6:  # wrap an object in Transforms or Groups, maybe deeply
        depth = src.choice((1, 2, 3, 50, 199, 200, 201, 600))
        op = src.choice(_WRAPPERS if src.extremes else _WRAPPERS[:4])
        src.drew_extreme |= op in _WRAPPERS[4:]
        if token in (b"Sphere", b"Plane", b"Triangle", b"TriangleMesh", b"Transform"):
            replacement = op * depth + token
            tail = bytes(text[end:])
            close = _matching_close(tail)
            if close is not None:
                text[end + close:end + close] = b" }" * depth
        else:
            replacement = token
    elif kind == 7:  # counts and indices change
        counts = [s for s in spans if text[s[0]:s[1]] in (b"numObjects", b"numLights", b"numMaterials", b"MaterialIndex")]
        if counts:
            s = src.choice(counts)
            j = spans.index(s) + 1
            if j < len(spans):
                start, end = spans[j]
        replacement = str(src.choice((0, 1, 2, 3, -1, 10**6, 2**31, 10**18, 10**19))).encode()
    else:  # the .obj a mesh reads: a mutated copy, a device, a folder, a missing file
        names = [s for s in spans if text[s[0]:s[1]].endswith(b".obj")]
        if not names:
            return text
        start, end = src.choice(names)
        replacement = _obj_name(src, folder)
    text[start:end] = replacement
    return text


_WRAPPERS = (b"Group { numObjects 1 ", b"Transform { UniformScale 0.5 ", b"Transform { Rotate { 1 1 0 30 } ",
             b"Transform { Matrix { 1 1 0 0 1 1 0 0 0 0 1 0 0 0 0 1 } ",  # singular
             b"Transform { UniformScale 1e-160 ", b"Transform { Scale 1e200 1 1 ", b"Transform { Rotate { 0 0 1e-170 90 } ",
             b"Transform { Translate 1e308 0 0 ")


def _matching_close(tail: bytes) -> int | None:
    """Where the '}' closing the block that starts `tail` (after its keyword) ends, if anywhere."""
    depth = 0
    for m in _TOKEN_RE.finditer(tail):
        if m.group() == b"{":
            depth += 1
        elif m.group() == b"}":
            depth -= 1
            if depth == 0:
                return m.end()
    return None


def _obj_name(src: Source, folder: Path) -> bytes:
    choice = src.below(6)
    if choice == 0:
        return src.choice((b"/dev/zero", b"/dev/null", b"a_folder.obj", b"missing.obj", b"/proc/self/status"))
    text = bytearray(src.choice(OBJS).read_bytes())
    lines = text.split(b"\n")
    for _ in range(1 + src.below(4)):
        j = src.below(len(lines))
        roll = src.below(4)
        if roll == 0:
            lines[j] = b"f " + b" ".join(str(src.choice(INTEGERS)).encode() for _ in range(3))
        elif roll == 1:
            lines[j] = b"v " + b" ".join(src.word().encode() for _ in range(3))
        elif roll == 2:
            lines[j] = b"v " + b" ".join(repr(src.number()).encode() for _ in range(3))
        else:
            lines[j] = bytes(_mutate_bytes(bytearray(lines[j]), src))
    name = f"mutated_{choice}.obj"
    (folder / name).write_bytes(b"\n".join(lines))
    return name.encode()


def mutated_scene(src: Source, folder: Path) -> bytes:
    """A seed scene with one to eight byte-level or grammar-aware mutations (mostly one)."""
    text = bytearray(src.choice(SEEDS).read_bytes())
    for _ in range(src.choice((1, 1, 1, 2, 3, 8))):
        text = _mutate_grammar(text, src, folder) if not src.chance(86) else _mutate_bytes(text, src)
    return bytes(text)


def reader_case(data: bytes, tally: Tally, folder: Path, extremes: bool = True) -> None:
    """Read a mutated scene; if it reads, render it at 4x4 with every pass (and maybe a bounce)."""
    tally.inputs["reader"] += 1
    src = Source(data, extremes)
    path = folder / "scene.txt"
    path.write_bytes(mutated_scene(src, folder))
    try:
        scene_file = read_scene_file(path)
    except SceneFileError as error:
        _check_located(error)
        tally.outcomes["reader SceneFileError"] += 1
        return
    except Exception as error:  # noqa: BLE001
        raise Finding(f"reader: {type(error).__name__} instead of a SceneFileError: {error}\n"
                      + "".join(traceback.format_exception(error))) from error
    try:
        result = render_scene_file(scene_file, 4, 4, shadows=src.chance(128), bounces=src.choice((0, 0, 2, 5)),
                                   shade_back=src.chance(128), precision=src.choice(PRECISIONS),
                                   spp=src.choice((1, 1, 4)))
    except SceneFileError as error:
        _check_located(error)
        tally.outcomes["reader SceneFileError at render"] += 1
        return
    except ValueError as error:
        if scene_file.camera is None and "has no camera" in str(error):
            tally.outcomes["reader no camera"] += 1
            return
        raise Finding(f"reader: the file read but the core refused it without file:line: {error}") from error
    try:
        check_result(result, tally)
    except Finding as finding:
        raise _judged(finding, src)(f"{finding}\nthe scene file:\n{path.read_text(errors='replace')[:6000]}") from None
    tally.outcomes["reader rendered"] += 1


def _check_located(error: SceneFileError) -> None:
    """The scene's or an .obj's path, a line, a one-line message."""
    if not (error.path and error.line >= 1 and error.message and "\n" not in error.message):
        raise Finding(f"reader: a SceneFileError without one-line file:line: {error!r}")


# --- surface (c): the command lines --------------------------------------------------------------

_ERROR_LINE = re.compile(r"^(python -m durer( \w+)?|raytracer): error: .+$")


def _argv(src: Source, folder: Path) -> list[str]:
    command = src.choice(("raytracer",) * 10 + ("demo",) * 3 + ("render",) * 2 + ("", "-h", "nonsense", "RAYTRACER"))
    argv = [command] if command else []
    if command == "render":
        # Files Blender cannot open, so nothing renders (that is the Blender tests' part); no --workers
        # or --scheduler, which start or reach a Dask cluster.
        options = {"FILE": lambda: src.choice(("garbage.blend", "missing.blend", "a_folder.obj", "/dev/zero", "scene.txt",
                                               "", "x" * 300)),
                   "--frames": lambda: src.choice(("1", "1-3", "3-1", "1,5,10-12", "x", "-1", "1-", str(2**63), "0")),
                   "--samples": lambda: _word(src, (1, 4)), "--scene": lambda: src.choice(("Scene", "", "nope")),
                   "-o": lambda: src.choice(("r/", "r.png", "r####.png", "scene.txt/r.png")), "--quiet": lambda: "",
                   "--resume": lambda: "", "--no-resume": lambda: ""}
        required: tuple[str, ...] = ("FILE",)
    elif command == "demo":
        options = {"--output": lambda: str(folder / src.choice(("d.png", "d.jpg", "d.xyz", "d", "sub/d.png",
                                                                   "scene.txt/d.png", "a_folder.obj", "x" * 300 + ".png"))),
                   "--width": lambda: str(src.value(lambda: 1 + src.below(8))),
                   "--height": lambda: str(src.value(lambda: 1 + src.below(8))),
                   "--spp": lambda: str(src.value(lambda: 1 + src.below(4))),
                   "--precision": lambda: src.choice(("float", "double", "half"))}
        required = ("--width", "--height", "--output")
    else:
        image = lambda: str(folder / src.choice(("o.png", "o.tga") * 4 + ("o.TGA", "o.jpg", "o", "sub/o.png",  # noqa: E731
                                                                        "scene.txt/o.png", "a_folder.obj", "",
                                                                        "x" * 300 + ".png")))
        options = {"-input": lambda: _input(src, folder), "-size": lambda: f"{_size(src)} {_size(src)}",
                   "-output": image, "-depth": lambda: f"{_word(src)} {_word(src)} {image()}", "-normals": image,
                   "-shade_back": lambda: "", "-shadows": lambda: "", "-bounces": lambda: _word(src, (0, 1, 3, 1001)),
                   "-weight": lambda: _word(src, (0, 0.1, 1)), "-spp": lambda: _word(src, (1, 4)),
                   "-precision": lambda: src.choice(("float", "double", "quad")), "-gui": lambda: "",
                   "-tessellation": lambda: "10 10", "-gouraud": lambda: ""}
        required = ("-input", "-size", "-output")
    names = list(options)
    chosen = [name for name in required if not src.chance(16)] + [src.choice(names) for _ in range(src.below(5))]
    for name in chosen:
        argv += [] if name == "FILE" else [name]
        argv += options[name]().split(" ") if name not in ("-input", "FILE") else [options[name]()]
        argv = [a for a in argv if a != ""] if not src.chance(6) else argv
    if src.chance(20):
        argv.insert(src.below(len(argv) + 1), src.choice(("-", "--", "-1e400", "-nan", "\udcff", "x" * 300, "-h", "-inp",
                                                           "--input", "-size=2")))
    return argv


def _size(src: Source) -> str:
    return _word(src, (1, 2, 3, 4, 8)) if src.chance(24) else str(src.choice((1, 2, 3, 4, 8)))


def _word(src: Source, ordinary: Sequence[float] = (0, 1, 2, 5, 10)) -> str:
    value = src.value(lambda: src.choice(ordinary))
    return src.word() if src.chance(16) else str(value)


def _input(src: Source, folder: Path) -> str:
    roll = src.below(8)
    if roll < 5:
        path = folder / "scene.txt"
        path.write_bytes(mutated_scene(src, folder) if roll < 4 else src.choice(SEEDS).read_bytes())
        return str(path)
    return src.choice(("/dev/zero", str(folder / "a_folder.obj"), str(folder / "missing.txt"), "/dev/null", "",
                       "x" * 300))


def cli_case(data: bytes, tally: Tally, folder: Path, extremes: bool = True) -> None:
    """`python -m durer` in-process: exit 0, or 1/2 with one error line and no traceback."""
    tally.inputs["cli"] += 1
    argv = _argv(Source(data, extremes), folder)
    with contextlib.chdir(folder):  # what a command writes by default (demo's out/demo.png) goes there
        status, stderr = run_cli(argv)
    if status not in (0, 1, 2):
        raise Finding(f"cli {argv}: exit status {status!r}\n{stderr}")
    if "Traceback" in stderr:
        raise Finding(f"cli {argv}: a traceback\n{stderr}")
    if status:
        errors = [line for line in stderr.splitlines() if ": error: " in line]
        if argv and argv[0] in ("raytracer", "demo", "render") and (len(errors) != 1 or not _ERROR_LINE.match(errors[0])):
            raise Finding(f"cli {argv}: exit {status} without exactly one error line\n{stderr}")
    tally.outcomes[f"cli exit {status}"] += 1
    _clean(folder)


def run_cli(argv: list[str]) -> tuple[Any, str]:
    """`python -m durer ARGV` in this process: (exit status, stderr); an exception escaping it is a
    traceback (what the interpreter would print)."""
    from durer.__main__ import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main(argv)
        except SystemExit as exit_:
            status = exit_.code
        except Exception as error:  # noqa: BLE001 - what escapes becomes a traceback
            return 1, "".join(traceback.format_exception(error))
    return (0 if status is None else status), err.getvalue()


def _clean(folder: Path) -> None:
    """Remove what a command wrote, keeping the linked .obj files and the folder fixture."""
    for path in folder.iterdir():
        if path.is_dir() and not path.is_symlink() and path.name != "a_folder.obj":
            shutil.rmtree(path)
        elif path.suffix.lower() in (".png", ".tga", ".jpg", ".xyz", "") and path.is_file() or path.name == "r.png":
            path.unlink()


def run_case(surface: str, data: bytes, tally: Tally, folder: Path, extremes: bool = True) -> None:
    """One input of `surface`; `folder` is where files are written (see `prepare_folder`)."""
    if surface == "api":
        api_case(data, tally, extremes)
    else:
        {"reader": reader_case, "cli": cli_case}[surface](data, tally, folder, extremes)
