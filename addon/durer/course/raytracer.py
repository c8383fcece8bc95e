"""The 6.837 `raytracer` command: render a course scene file with the course's options.

    python -m durer raytracer -input scene.txt -size 200 200 -output out.tga
        [-depth MIN MAX depth.tga] [-normals normals.tga] [-shade_back] [-shadows]
        [-bounces N] [-weight W] [-spp N] [-precision float|double]

Images are written as the course writes them (image.C): linear colour, int(c·255) truncated and
clamped to [0, 255], as 24-bit PNG or uncompressed TGA by the file's extension. See docs/6837.md.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import sys
import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..render import DEFAULT_PASSES, PRECISIONS, RenderResult, check_options, render
from ..visualize import depth_to_gray, make_folder_for, normal_to_rgb
from .scene_file import SceneFile, SceneFileError, read_scene_file

IMAGE_FORMATS = {".png": "PNG", ".tga": "TGA"}
_NEGATIVE_NUMBER = re.compile(r"-(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
# durer.render's errors begin with the name of the argument; each caller sees its own name for it.
#: render_scene_file's name for each of durer.render's arguments it calls otherwise.
_ARGUMENT_OF_RENDER = {"max_bounces": "bounces", "min_weight": "weight"}
#: The course's option for each of render_scene_file's arguments the command line sets.
_OPTION_OF_ARGUMENT = {"width": "-size WIDTH", "height": "-size HEIGHT", "spp": "-spp", "bounces": "-bounces",
                       "weight": "-weight"}


class EmptySceneWarning(UserWarning):
    """A scene file with nothing to render (`SceneFile.nothing_to_render`): the image is the background."""


@dataclass(frozen=True)
class RaytracerOptions:
    """A parsed command line. `depth` is (near, far, image path)."""

    input: Path
    width: int
    height: int
    output: Path
    depth: tuple[float, float, Path] | None = None
    normals: Path | None = None
    shade_back: bool = False
    shadows: bool = False
    bounces: int = 0
    weight: float = 0.0
    spp: int = 1
    precision: str = "double"
    ignored: tuple[str, ...] = ()

    @property
    def passes(self) -> tuple[str, ...]:
        """Only what the written images need."""
        return ("color",) + (("depth",) if self.depth else ()) + (("normal",) if self.normals else ())


@dataclass
class RaytracerRun:
    """What `run` did: the render, the images written (in the order of the command line) and the
    wall time of parsing the scene, rendering and writing."""

    result: RenderResult
    images: list[Path] = field(default_factory=list)
    seconds: float = 0.0


def render_scene_file(
    scene_file: SceneFile | str | os.PathLike,
    width: int,
    height: int,
    *,
    shade_back: bool = False,
    shadows: bool = False,
    bounces: int = 0,
    weight: float = 0.0,
    spp: int = 1,
    precision: str = "double",
    passes: str | Iterable[str] = DEFAULT_PASSES,
) -> RenderResult:
    """Render a 6.837 scene (a SceneFile or its path) through its own camera, with the course's
    defaults: one sample at each pixel centre, no bounces; `passes` is a pass name or names.

    Raises TypeError or ValueError naming the argument for a bad option (before the file is read),
    SceneFileError for a malformed file and ValueError for a scene without a camera; warns
    (EmptySceneWarning) when the file has nothing to render."""
    options = {"spp": spp, "precision": precision, "passes": passes, "shade_back": shade_back, "bounces": bounces,
               "weight": weight}
    _check_arguments(width, height, **options)
    if not isinstance(scene_file, SceneFile):
        scene_file = read_scene_file(scene_file)
    if scene_file.camera is None:
        raise ValueError(f"{scene_file.path}: the scene has no camera (an OrthographicCamera or PerspectiveCamera "
                         "block)")
    if scene_file.nothing_to_render:
        warnings.warn(scene_file.nothing_to_render, EmptySceneWarning, stacklevel=2)
    scene = scene_file.to_scene(shadows=shadows)
    try:
        return render(scene, scene_file.camera.to_durer(), width, height, **_render_arguments(options))
    except ValueError as error:
        # The options passed their checks, so what is refused now is the file's: its items in this
        # precision (the core's range messages say "with precision='...'"), at an item's line.
        if "precision=" not in str(error):
            raise
        raise scene_file.locate_refusal(error, precision) from None


def _check_arguments(width: int, height: int, **options: Any) -> None:
    """Raise the TypeError or ValueError `render_scene_file` would raise for these options (by
    durer.render's own checks), naming its argument as the caller calls it."""
    try:
        check_options(width, height, **_render_arguments(options))
    except (TypeError, ValueError) as error:
        argument, space, rest = str(error).partition(" ")
        if argument not in _ARGUMENT_OF_RENDER:
            raise
        raise type(error)(f"{_ARGUMENT_OF_RENDER[argument]}{space}{rest}") from None


def _render_arguments(options: dict[str, Any]) -> dict[str, Any]:
    """render_scene_file's options under durer.render's names."""
    render_names = {ours: theirs for theirs, ours in _ARGUMENT_OF_RENDER.items()}
    return {render_names.get(name, name): value for name, value in options.items()}


def to_bytes(values: np.ndarray) -> np.ndarray:
    """Floats in [0, 1] to 8-bit as image.C does: int(c·255), truncated, then clamped to [0, 255]."""
    scaled = np.trunc(np.asarray(values, dtype=np.float64) * 255)
    return np.clip(np.nan_to_num(scaled, nan=0.0), 0, 255).astype(np.uint8)


def write_image(path: Path, rgb: np.ndarray) -> Path:
    """Write (H, W, 3) uint8, top row first, as PNG or 24-bit uncompressed TGA (top-left origin,
    like the course's SaveTGA)."""
    from PIL import Image

    path = Path(path)
    image_format = IMAGE_FORMATS.get(path.suffix.lower())
    if image_format is None:
        raise ValueError(f"{path}: the image must end in .png or .tga")
    make_folder_for(path)
    image = Image.fromarray(np.ascontiguousarray(rgb), mode="RGB")
    if image_format == "TGA":
        image.save(path, format="TGA", rle=False, orientation=1)
    else:
        image.save(path, format="PNG")
    return path


def images(result: RenderResult, options: RaytracerOptions) -> list[tuple[Path, np.ndarray]]:
    """The (path, RGB bytes) of every image the options ask for."""
    out = [(options.output, to_bytes(result.color[..., :3]))]
    if options.depth is not None:
        near, far, path = options.depth
        grey = to_bytes(depth_to_gray(result.depth, near, far))
        out.append((path, np.repeat(grey[..., None], 3, axis=2)))
    if options.normals is not None:
        out.append((options.normals, to_bytes(normal_to_rgb(result.normal))))
    return out


def run(options: RaytracerOptions, log: Callable[[str], Any] = print) -> RaytracerRun:
    """Read, render and write what `options` say; `log` gets one line per image and the timing."""
    start = time.perf_counter()
    if options.ignored:
        log(f"note: ignoring {', '.join(options.ignored)} (options of the course's OpenGL preview)")
    scene_file = read_scene_file(options.input)
    result = render_scene_file(scene_file, options.width, options.height, shade_back=options.shade_back,
                               shadows=options.shadows, bounces=options.bounces, weight=options.weight,
                               spp=options.spp, precision=options.precision, passes=options.passes)
    outcome = RaytracerRun(result)
    for path, rgb in images(result, options):
        outcome.images.append(write_image(path, rgb))
        log(str(path))
    outcome.seconds = time.perf_counter() - start
    stats = result.stats
    log(f"rendered {options.width}x{options.height}, {options.spp} spp in {stats['milliseconds']:.1f} ms "
        f"({outcome.seconds * 1000:.0f} ms with reading and writing); effects: {', '.join(stats['effects'])}")
    return outcome


def argument_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m durer raytracer", allow_abbrev=False,
        description="Render an MIT 6.837 scene file with the course's command-line options (docs/6837.md).",
        epilog="-gui, -tessellation THETA PHI and -gouraud are accepted and ignored (the course's OpenGL preview).")
    actions = [
        parser.add_argument("-input", required=True, metavar="FILE", help="the scene file"),
        parser.add_argument("-size", required=True, nargs=2, type=int, metavar=("WIDTH", "HEIGHT")),
        parser.add_argument("-output", required=True, metavar="IMAGE", help="colour image, .png or .tga"),
        parser.add_argument("-depth", nargs=3, metavar=("MIN", "MAX", "IMAGE"),
                            help="depth image: t from MIN (white) to MAX (black), clamped; misses black"),
        parser.add_argument("-normals", metavar="IMAGE", help="normal image: |n| per component; misses black"),
        parser.add_argument("-shade_back", action="store_true", help="shade back faces with the flipped normal"),
        parser.add_argument("-shadows", action="store_true", help="every light casts shadows"),
        parser.add_argument("-bounces", type=int, default=0, metavar="N",
                            help="reflection/refraction depth (default 0)"),
        parser.add_argument("-weight", type=float, default=0.0, metavar="W",
                            help="skip secondary rays whose weight in the pixel falls below W (default 0)"),
        parser.add_argument("-spp", type=int, default=1, metavar="N",
                            help="samples per pixel (ours; default 1: the pixel centre, as the course)"),
        parser.add_argument("-precision", choices=PRECISIONS, default="double",
                            help="(ours; default double)"),
        parser.add_argument("-gui", action="store_true", help=argparse.SUPPRESS),
        parser.add_argument("-tessellation", nargs=2, metavar=("THETA", "PHI"), help=argparse.SUPPRESS),
        parser.add_argument("-gouraud", action="store_true", help=argparse.SUPPRESS),
    ]
    # Python 3.11's argparse matches single-dash abbreviations ("-inp" for "-input") despite
    # allow_abbrev=False; parse_arguments refuses any option not spelled out.
    parser.set_defaults(_options=frozenset(["-h", "--help", *(s for a in actions for s in a.option_strings)]))
    return parser


def parse_arguments(argv: Sequence[str], parser: argparse.ArgumentParser | None = None) -> RaytracerOptions:
    """The options of a command line (without the program name); a usage error exits with code 2."""
    parser = parser or argument_parser()
    argv = list(argv)
    known = parser.get_default("_options")
    for word in argv:
        if word.startswith("-") and word not in known and not _NEGATIVE_NUMBER.fullmatch(word):
            parser.error(f"unrecognized option: {word}")
    args = parser.parse_args(argv)
    width, height = args.size
    try:  # render's own limits (the core's among them), before the scene is read
        _check_arguments(width, height, spp=args.spp, bounces=args.bounces, weight=args.weight,
                        precision=args.precision)
    except ValueError as error:
        argument, _, rest = str(error).partition(" ")
        parser.error(f"{_OPTION_OF_ARGUMENT.get(argument, argument)} {rest}")
    depth = None
    if args.depth is not None:
        near, far = _real(parser, "-depth MIN", args.depth[0]), _real(parser, "-depth MAX", args.depth[1])
        if not near < far:
            parser.error(f"-depth needs MIN < MAX, got {args.depth[0]} {args.depth[1]}")
        depth = (near, far, _image_path(parser, "-depth", args.depth[2], width, height))
    ignored = tuple(name for name, given in (("-gui", args.gui), ("-tessellation", args.tessellation is not None),
                                             ("-gouraud", args.gouraud)) if given)
    output = _image_path(parser, "-output", args.output, width, height)
    normals = None if args.normals is None else _image_path(parser, "-normals", args.normals, width, height)
    images = {"-output": output, "-depth": None if depth is None else depth[2], "-normals": normals}
    for i, (option, path) in enumerate(images.items()):
        for other, other_path in list(images.items())[i + 1:]:
            if path is not None and other_path is not None and path.resolve() == other_path.resolve():
                parser.error(f"{option} and {other} name the same image {path}: the second would overwrite the first")
    return RaytracerOptions(
        input=Path(args.input), width=width, height=height, output=output, depth=depth, normals=normals,
        shade_back=args.shade_back, shadows=args.shadows, bounces=args.bounces, weight=args.weight, spp=args.spp,
        precision=args.precision, ignored=ignored)


def _real(parser: argparse.ArgumentParser, name: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        parser.error(f"{name} must be a number, got {text!r}")
    if not math.isfinite(value):
        parser.error(f"{name} must be finite, got {text!r}")
    return value


#: The widest and tallest image a format holds (a TGA header's sizes are 16-bit).
_MOST_PIXELS = {"TGA": 65535}


def _image_path(parser: argparse.ArgumentParser, option: str, text: str, width: int, height: int) -> Path:
    path = Path(text)
    image_format = IMAGE_FORMATS.get(path.suffix.lower())
    if image_format is None:
        parser.error(f"{option} {text}: the image must end in .png or .tga")
    most = _MOST_PIXELS.get(image_format)
    if most is not None and max(width, height) > most:
        parser.error(f"{option} {text}: a {image_format} image is at most {most} pixels wide and tall, "
                     f"got -size {width} {height}")
    return path


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    options = parse_arguments(argv)
    try:
        with warnings.catch_warnings():  # whatever the caller's filters: the command always says it
            warnings.simplefilter("always", EmptySceneWarning)
            warnings.showwarning = _show_warning
            run(options)
    except (SceneFileError, OSError, ValueError) as error:
        print(f"raytracer: error: {error}", file=sys.stderr)
        return 1
    except MemoryError:
        print(f"raytracer: error: not enough memory for a {options.width}x{options.height} image", file=sys.stderr)
        return 1
    return 0


def _show_warning(message: Warning | str, *_: Any) -> None:
    """A warning as one line on stderr, like the command's errors (not Python's file and line)."""
    print(f"raytracer: warning: {message}", file=sys.stderr)
