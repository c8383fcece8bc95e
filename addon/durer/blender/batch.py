"""Batch rendering of .blend files with Dürer through the ``bpy`` module.

``python -m durer render FILE.blend [--frames 1-48] [--output out/frame_####.png] [--samples N]``
calls `main`; scripts call `render_file`.
"""

from __future__ import annotations

import argparse
import numbers
import os
import re
import signal
import sys
import threading
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from .. import _checks
from ..distributed.output import is_complete, temporary_path
from ..visualize import make_folder_for

if TYPE_CHECKING:
    import bpy

#: Image formats chosen from the output file's extension.
FORMATS = {
    ".png": "PNG",
    ".exr": "OPEN_EXR",
    ".jpg": "JPEG",
    ".jpeg": "JPEG",
    ".tif": "TIFF",
    ".tiff": "TIFF",
    ".bmp": "BMP",
    ".hdr": "HDR",
    ".webp": "WEBP",
}


class BatchRenderError(RuntimeError):
    """Frames failed to render (the message says which and why); `written` holds the files the
    other frames wrote."""

    def __init__(self, message: str, written: list[Path] | None = None) -> None:
        super().__init__(message)
        self.written = written or []


def _hard_range(owner: type, name: str) -> tuple[int, int]:
    """The hard bounds of the integer property `name` of the Blender type `owner`: the property is their
    one home (Blender would clamp a value beyond them silently)."""
    setting = owner.bl_rna.properties[name]
    return setting.hard_min, setting.hard_max


def frame_range() -> tuple[int, int]:
    """The frames Blender renders: the hard bounds of scene.frame_current (frame_set would clamp a
    frame beyond them)."""
    import bpy

    return _hard_range(bpy.types.Scene, "frame_current")


def parse_frames(spec: str | int | Iterable[int] | None) -> list[int] | None:
    """'1-48' -> [1..48]; '1,5,10-12' -> [1, 5, 10, 11, 12]; 7 -> [7]; None -> None (current frame).

    Every frame is an integer in `frame_range` (a range's ends are checked before it is expanded); a
    frame given twice is rendered once, where it first appears. Errors name `frames`."""
    if spec is None:
        return None
    low, high = frame_range()
    if isinstance(spec, str):
        frames = _frames_of_text(spec, low, high)
    elif isinstance(spec, numbers.Integral):  # bool included: _checks.integer refuses it
        frames = [_checks.integer(spec, "frames", low, high)]
    else:
        try:
            items = list(spec)
        except TypeError:
            raise TypeError(f"frames must be a string such as 1-48, an integer or integers, got "
                            f"{type(spec).__name__}") from None
        frames = [_checks.integer(f, f"frames[{i}]", low, high) for i, f in enumerate(items)]
        if not frames:
            raise ValueError("frames must not be empty")
    return list(dict.fromkeys(frames))


def _frames_of_text(spec: str, low: int, high: int) -> list[int]:
    usage = f"frames must look like 1-48 or 1,5,10-12, got {spec!r}"
    frames: list[int] = []
    for part in spec.replace(" ", "").split(","):
        if not part:
            continue
        dash = part.find("-", 1)  # a leading "-" is a negative first frame's
        try:
            first, last = (int(part[:dash]), int(part[dash + 1 :])) if dash > 0 else (int(part), int(part))
        except ValueError:
            raise ValueError(usage) from None
        if last < first:
            raise ValueError(usage)
        first, last = _checks.integer(first, "frames", low, high), _checks.integer(last, "frames", low, high)
        frames.extend(range(first, last + 1))
    if not frames:
        raise ValueError(usage)
    return frames


def _progress_bar(enabled: bool, frame: int, count: int):
    if not enabled:
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm(
        total=100,
        desc=f"frame {frame} ({count} left)" if count > 1 else f"frame {frame}",
        unit="%",
        leave=True,
        file=sys.stderr,
        bar_format="{desc}: {percentage:3.0f}%|{bar}| {elapsed}",
    )


def render_file(
    path: str | os.PathLike,
    frames: str | int | Iterable[int] | None = None,
    output: str | os.PathLike | None = None,
    samples: int | None = None,
    *,
    progress: bool | Callable[[int, float], object] = False,
    scene: str | None = None,
    resume: bool = False,
    threads: int | None = None,
    on_written: Callable[[Path], object] | None = None,
    on_warning: Callable[[str], object] | None = None,
) -> list[Path]:
    """Render frames of a .blend file with Dürer and write them; returns the written files.

    frames:  "1-48", "1,5,10-12", an int, an iterable of ints, or None (the file's current frame).
    output:  output path; "#" runs become the zero-padded frame number (Blender's convention, so
             "out/frame_####.png"), a missing "#" gets the frame appended when rendering several
             frames; the extension picks the format (.png, .exr, .jpg, .tif, ...). None: the
             file's own output path.
    samples: overrides scene.durer.samples.
    progress: True draws a progress bar per frame (stderr); a callable gets (frame, fraction).
    scene:   the scene to render (default: the file's active scene).
    resume:  skip frames whose output file exists and is complete (not in the returned list).
    threads: render threads per frame, overriding scene.durer.threads.
    on_written: called with each file as soon as it is in place (the command line names it then:
             Blender's own "Saved:" line names the temporary file the frame is written to first).
    on_warning: called with each warning of the frames' renders (skipped geometry, materials Dürer
             approximates), once per message in the batch (Blender shows them in its window only).

    Raises FileNotFoundError for a missing file, ValueError for a file Blender cannot open or a
    scene it does not have, and BatchRenderError once every frame was tried if some failed (the
    others are written: the error's `written`).
    """
    import bpy

    from . import engine

    blend = Path(path).expanduser().resolve()
    frame_list = parse_frames(frames)
    sc = open_blend(blend, scene, samples, threads)
    if frame_list is None:
        frame_list = [sc.frame_current]
    explicit = configure_output(sc, output, len(frame_list))
    bake_simulations(max(frame_list))  # each frame the one history from the scene's start, in any order, as on a cluster

    written: list[Path] = []
    failed: dict[int, str] = {}
    warned: set[str] = set()
    pattern, use_extension = sc.render.filepath, sc.render.use_file_extension
    # Frames in a row: each reuses the last one's scene where only spheres and the camera moved.
    persistent = sc.render.use_persistent_data
    sc.render.use_persistent_data = True
    restore = _catch_interrupts()
    try:
        for i, frame in enumerate(frame_list):
            if engine.interrupt.is_set():
                raise KeyboardInterrupt
            target = frame_target(sc, explicit, frame)
            if resume and is_complete(target):
                continue
            make_folder_for(target)
            sc.frame_set(frame)
            # Blender writes the frame in place: under another name, renamed once whole, so that a
            # process killed mid-write leaves no partial file for --resume to take as done.
            partial = temporary_path(target)
            partial.unlink(missing_ok=True)
            sc.render.filepath, sc.render.use_file_extension = str(partial), False
            try:
                _render_frame(bpy, engine, sc, blend, frame, len(frame_list) - i, progress)
            except BatchRenderError as exc:  # the other frames still render, as on a cluster
                failed[frame] = str(exc)
                continue
            finally:
                sc.render.filepath, sc.render.use_file_extension = pattern, use_extension
            for message in engine.last_render.warnings:
                if on_warning is not None and message not in warned:
                    warned.add(message)
                    on_warning(message)
            if not is_complete(partial, target.suffix):  # Blender says "Saved" even when the disk filled up
                partial.unlink(missing_ok=True)
                failed[frame] = f"Frame {frame} of {blend} rendered but {target} was not written whole (a full disk?)"
                continue
            os.replace(partial, target)
            written.append(target)
            if on_written is not None:
                on_written(target)
    finally:
        sc.render.filepath, sc.render.use_file_extension = pattern, use_extension
        sc.render.use_persistent_data = persistent
        for key in [key for key in engine.persistent if key[0] == sc.name]:
            del engine.persistent[key]
        restore()
        engine.interrupt.clear()
    if failed:
        first = min(failed)
        raise BatchRenderError(f"{len(failed)} of {len(frame_list)} frames failed: "
                               f"{','.join(str(f) for f in sorted(failed))} ({failed[first]})", written)
    return written


def bake_simulations(last: int) -> None:
    """Bakes the open file's simulations that may not be baked, in memory (point caches: particles,
    cloth, rigid bodies; Simulation Zones, packed into the file), from the scene's start up to frame
    `last` (the last one rendered; beyond it nothing is asked): each steps from the frame before,
    so frames rendered one by one in any order, or by workers given some each, would each see
    another history; baked, every frame reads the one history from the scene's start."""
    import bpy

    unbaked, zones = unbaked_point_caches(), simulation_zones()
    if not unbaked and not zones:
        return
    scene = bpy.context.scene  # the scene the bake operators step through
    end = scene.frame_end
    scene.frame_end = max(min(end, last), scene.frame_start)
    try:
        if unbaked:
            for cache in unbaked:
                cache.use_disk_cache = False
            bpy.ops.ptcache.bake_all(bake=True)
        if zones:
            for modifier in zones:
                modifier.bake_target = "PACKED"
                for bake in modifier.bakes:
                    bake.bake_target = "INHERIT"
            owner = zones[0].id_data  # the operator asks for an active object, then bakes every one
            with bpy.context.temp_override(active_object=owner, object=owner, selected_objects=[owner]):
                bpy.ops.object.simulation_nodes_cache_bake(selected=False)
    finally:
        scene.frame_end = end


def simulation_zones() -> list:
    """The geometry-nodes modifiers of the open file whose trees (or groups in them) hold a
    Simulation Zone."""
    import bpy

    return [modifier for obj in bpy.data.objects for modifier in obj.modifiers
            if modifier.type == "NODES" and modifier.node_group is not None
            and _has_simulation_zone(modifier.node_group, set())]


def _has_simulation_zone(tree, seen: set) -> bool:
    if tree.as_pointer() in seen:
        return False
    seen.add(tree.as_pointer())
    return any(node.bl_idname == "GeometryNodeSimulationInput"
               or (getattr(node, "node_tree", None) is not None and _has_simulation_zone(node.node_tree, seen))
               for node in tree.nodes)


def unbaked_point_caches() -> list:
    """The caches of simulations not baked: particle systems with physics (hair only with its
    dynamics on), point-cache modifiers such as cloth and soft bodies, rigid bodies."""
    import bpy

    caches = [scene.rigidbody_world.point_cache for scene in bpy.data.scenes if scene.rigidbody_world]
    for obj in bpy.data.objects:
        caches += [system.point_cache for system in getattr(obj, "particle_systems", ())
                   if system.settings.physics_type != "NO"
                   and (system.settings.type != "HAIR" or system.use_hair_dynamics)]
        caches += [modifier.point_cache for modifier in obj.modifiers if hasattr(modifier, "point_cache")]
    return [cache for cache in caches if not cache.is_baked]


def _catch_interrupts() -> Callable[[], object]:
    """Ctrl-C sets engine.interrupt for the batch's duration instead of raising KeyboardInterrupt
    wherever Python happens to be (inside Blender's own calls into the engine it was printed and
    ignored, and the frame written blank); returns what puts the previous handler back (nothing to
    do off the main thread, where signals cannot be caught, where the handler is not Python's, or
    where Ctrl-C is ignored: a batch started in the background)."""
    from . import engine

    engine.interrupt.clear()
    previous = signal.getsignal(signal.SIGINT) if threading.current_thread() is threading.main_thread() else None
    if previous in (None, signal.SIG_IGN):  # not Python's (off the main thread, a handler from C) or ignored
        return lambda: None
    signal.signal(signal.SIGINT, lambda *_: engine.interrupt.set())
    return lambda: signal.signal(signal.SIGINT, previous)


def setting_range(name: str) -> tuple[int, int]:
    """The hard bounds of the integer Dürer scene setting `name`."""
    from . import register
    from .properties import DurerSceneSettings

    register()
    return _hard_range(DurerSceneSettings, name)


def checked_overrides(samples: int | None, threads: int | None) -> tuple[int | None, int | None]:
    """`samples` and `threads` overriding a file's settings, checked (None: the file's own)."""
    if samples is not None:
        samples = _checks.integer(samples, "samples", *setting_range("samples"))
    if threads is not None:  # None, not 0, is "the file's setting" here
        threads = _checks.integer(threads, "threads", 1, setting_range("threads")[1])
    return samples, threads


def open_blend(
    blend: Path, scene: str | None = None, samples: int | None = None, threads: int | None = None
) -> bpy.types.Scene:
    """Open `blend` (an absolute path) in bpy with Dürer registered and return the scene to render
    (`scene` or the active one) with the DURER engine and `samples` and `threads`, if given, set."""
    import bpy

    from . import register

    try:
        found = blend.is_file()
    except OSError as error:  # a name the system cannot look up (too long, ...)
        raise ValueError(f"cannot open {blend}: {error.strerror}") from None
    if not found:
        raise FileNotFoundError(f"No such .blend file: {blend}")
    samples, threads = checked_overrides(samples, threads)
    register()
    try:
        bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
    except RuntimeError as exc:
        raise ValueError(f"Cannot open {blend}: {str(exc).strip()}") from None
    sc = bpy.data.scenes.get(scene) if scene else bpy.context.scene
    if sc is None:
        raise ValueError(f"{blend} has no scene named {scene!r}")
    if bpy.context.window is not None and bpy.context.window.scene != sc:
        bpy.context.window.scene = sc
    sc.render.engine = "DURER"
    if samples is not None:
        sc.durer.samples = samples
    if threads is not None:
        sc.durer.threads = threads
    if sc.camera is None:
        raise BatchRenderError(f"Scene '{sc.name}' in {blend} has no camera")
    return sc


def configure_output(sc: bpy.types.Scene, output: str | os.PathLike | None, frame_count: int) -> str | None:
    """Set the scene's output path and format from `output` (see `render_file`); returns the output
    pattern when it has a known image extension ("#" runs become the frame), else None (Blender's
    own frame_path numbering and extension apply)."""
    if output is None:
        return _image_format_needed(sc)
    out = str(Path(output).expanduser().resolve()) if not str(output).startswith("//") else str(output)
    if str(output).endswith(("/", os.sep)) or Path(out).is_dir():
        # A directory: frames are numbered inside it, as Blender does for an output path "dir/".
        out = os.path.join(out, "####")
    ext = Path(out).suffix.lower()
    if ext in FORMATS:
        from .engine import layer_passes

        settings = sc.render.image_settings
        # Blender 5 sorts formats by media (image, multilayer image, video): pick the medium first.
        # ".exr" keeps the passes: multilayer where the file writes multilayer EXRs or its view
        # layers ask for passes beyond Combined (a single-layer EXR would drop them).
        multilayer = ext == ".exr" and (settings.file_format == "OPEN_EXR_MULTILAYER" or
                                        any(layer.use and layer_passes(layer) for layer in sc.view_layers))
        if hasattr(settings, "media_type"):
            settings.media_type = "MULTI_LAYER_IMAGE" if multilayer else "IMAGE"
        settings.file_format = "OPEN_EXR_MULTILAYER" if multilayer else FORMATS[ext]
        if ext == ".exr":
            settings.color_depth = "32"
    elif ext:
        raise ValueError(f"Unknown image extension {ext!r}: use one of {', '.join(sorted(FORMATS))}")
    if frame_count > 1 and "#" not in Path(out).name:
        stem = Path(out)
        out = str(stem.with_name(stem.stem + "_####" + stem.suffix))
    sc.render.filepath = out
    sc.render.use_file_extension = True
    return out if ext in FORMATS else _image_format_needed(sc)


def _image_format_needed(sc: bpy.types.Scene) -> None:
    """None (the file's own format names the frames), unless that format is a video: a batch
    writes frames one by one, which a video file cannot take."""
    if sc.render.is_movie_format:
        raise ValueError(f"The file writes a video ({sc.render.image_settings.file_format}), which a batch of "
                         "frames cannot: give --output with an image extension, e.g. out/frame_####.png")


def frame_number(frame: int, digits: int) -> str:
    """`frame` zero-padded to `digits` digits, a minus sign before them (Blender's %0*d: -0001)."""
    return ("-" if frame < 0 else "") + f"{abs(frame):0{digits}d}"


def frame_target(sc: bpy.types.Scene, explicit: str | None, frame: int) -> Path:
    """The file frame `frame` is written to."""
    import bpy

    # write_still does not number stills: resolve "#" and the extension per frame ourselves.
    if explicit is not None:  # the last "#" run of the file name, as Blender's frame_path
        folder, name = os.path.split(explicit)
        name = re.sub(r"#+(?!.*#)", lambda m: frame_number(frame, len(m.group())), name)
        return Path(bpy.path.abspath(os.path.join(folder, name)))
    return Path(bpy.path.abspath(sc.render.frame_path(frame=frame)))


def _render_frame(bpy, engine, sc, blend: Path, frame: int, left: int, progress) -> None:
    bar = _progress_bar(progress is True, frame, left)
    last = [0.0]

    def hook(fraction: float) -> None:
        if bar is not None:
            bar.update(max(0.0, 100.0 * fraction - last[0]))
            last[0] = max(last[0], 100.0 * fraction)
        elif callable(progress):
            progress(frame, fraction)

    engine.progress_hooks.append(hook)
    # A path of the caller's own, not there yet (render_file's hidden name, a worker's temporary file):
    # Blender writes the empty image of a failed render there, removed as it stands.
    target = Path(bpy.path.abspath(sc.render.filepath))
    engine.last_render = engine.RenderInfo()  # a frame Blender fails before the engine runs keeps no stale error

    def remove_written() -> None:
        target.unlink(missing_ok=True)

    try:
        bpy.ops.render.render(write_still=True, scene=sc.name)
    except RuntimeError as exc:  # Blender's report ("Error: Dürer: ..."), unless the engine's own is there
        remove_written()
        if engine.last_render.interrupted:
            raise KeyboardInterrupt from None
        raise BatchRenderError(f"Frame {frame} of {blend} failed: {engine.last_render.error or exc}") from None
    finally:
        engine.progress_hooks.remove(hook)
        if bar is not None:
            bar.close()
    info = engine.last_render
    if info.error or info.cancelled:
        remove_written()
    if info.interrupted:
        raise KeyboardInterrupt
    if info.error:
        raise BatchRenderError(f"Frame {frame} of {blend} failed: {info.error}")
    if info.cancelled:
        raise BatchRenderError(f"Frame {frame} of {blend} was cancelled")


def build_parser(prog: str = "python -m durer render") -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=prog, description="Render a .blend file with Dürer (through the bpy module).")
    p.add_argument("file", help="the .blend file")
    p.add_argument("--frames", "-f", help="frames to render: 7, 1-48 or 1,5,10-12 (default: the file's current frame)")
    p.add_argument(
        "--output", "-o", help="output path; #### becomes the frame number (default: the file's output path)"
    )
    p.add_argument("--samples", "-s", type=int, help="samples per pixel (default: the file's Dürer setting)")
    p.add_argument("--scene", help="scene to render (default: the active scene)")
    p.add_argument("--threads", type=int, metavar="T",
                   help="render threads per frame (default: the file's Dürer setting; on a cluster 1)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bars")
    cluster = p.add_argument_group("distributed (Dask; docs/distributed.md)")
    cluster.add_argument("--workers", "-w", type=int, nargs="?", const=0, metavar="N",
                         help="render on a local Dask cluster of N worker processes (N omitted or 0: one per core; "
                              "1: this process, as without the option)")
    cluster.add_argument("--scheduler", metavar="ADDRESS", help="render on an existing Dask cluster (tcp://host:8786)")
    cluster.add_argument("--resume", action=argparse.BooleanOptionalAction, default=None,
                         help="skip frames whose output exists and is complete (default on a cluster; "
                              "--no-resume renders them again)")
    return p


def _main_distributed(args: argparse.Namespace, prog: str) -> int:
    """--workers / --scheduler: the frames as Dask tasks (durer.distributed.frames)."""
    try:
        from ..distributed.client import cluster, require_distributed
        from ..distributed.frames import prepare_frames, run_frames

        require_distributed()
        if args.workers is not None and args.workers < 0:
            raise ValueError(f"--workers must be >= 1, got {args.workers}")
        # The arguments are checked before a cluster starts (the file's scenes once it is open).
        parse_frames(args.frames)
        checked_overrides(args.samples, None)  # main checked --threads
        blend = Path(args.file)
        if not blend.is_file():
            raise FileNotFoundError(f"No such .blend file: {blend.resolve()}")
        if args.output is not None:  # a file standing where its folder goes; "//": beside the .blend
            output = args.output
            make_folder_for(blend.resolve().parent / output[2:] if output.startswith("//") else Path(output).expanduser())
        # The file is prepared before a cluster starts: its simulations' bakes are Blender operators,
        # which must not run beside a local cluster's threads in this process.
        job = prepare_frames(args.file, frames=args.frames, output=args.output, samples=args.samples,
                             scene=args.scene, threads=args.threads)
        with cluster(args.scheduler, args.workers or None) as client:
            report = run_frames(job, client=client, resume=args.resume is not False, progress=not args.quiet)
    except (OSError, ValueError, ImportError) as exc:  # OSError: a missing file, an unreachable scheduler
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    except BatchRenderError as exc:
        for f in exc.written:
            print(f"image written to {f}")
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"{prog}: interrupted: the frames written so far are complete; run again to resume", file=sys.stderr)
        return 130
    if report.failed:
        frames = ",".join(str(f) for f in sorted(report.failed))
        print(f"{prog}: error: {len(report.failed)} frames failed: {frames}", file=sys.stderr)
        return 1
    return 0


def main(argv: Sequence[str] | None = None, prog: str = "python -m durer render") -> int:
    """The command line: returns the exit code (0 on success, 1 on a render error, 2 on bad input)."""
    args = build_parser(prog).parse_args(argv)
    try:
        import bpy  # noqa: F401
    except ImportError:
        print(
            f"{prog}: error: rendering .blend files needs Blender's bpy module: pip install bpy==5.0.1", file=sys.stderr
        )
        return 2
    if args.threads is not None:
        try:
            _checks.integer(args.threads, "--threads", 1, setting_range("threads")[1])
        except ValueError as exc:
            print(f"{prog}: error: {exc}", file=sys.stderr)
            return 2
    if args.scheduler is not None or (args.workers is not None and args.workers != 1):
        return _main_distributed(args, prog)
    try:
        render_file(
            args.file,
            frames=args.frames,
            output=args.output,
            samples=args.samples,
            progress=not args.quiet,
            scene=args.scene,
            resume=bool(args.resume),
            threads=args.threads,
            on_written=lambda f: print(f"image written to {f}", flush=True),
            on_warning=lambda message: print(f"warning: {message}", file=sys.stderr),
        )
    except (OSError, ValueError) as exc:  # OSError: a missing file, an output path that cannot be made
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    except BatchRenderError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"{prog}: interrupted: the frames written so far are complete; run again with --resume to go on",
              file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
