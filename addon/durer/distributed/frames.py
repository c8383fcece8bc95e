"""Frames of a .blend file rendered as Dask tasks (``python -m durer render FILE --workers N``).

The client opens the file, applies the command's settings (engine, samples, output format,
threads), packs external data and saves a self-contained copy, which goes to the cluster once. A
worker thread writes that copy to a temporary directory and has its bpy process
(`blender_process`) open it on its first task and keep it open: each task sets the frame and
renders it through the sequential path (`durer.blender.batch`) to a file there, and returns the
file's bytes. The client writes them atomically, so an output file is
either absent or whole, and a resumed run skips every output that is complete.
"""

from __future__ import annotations

import hashlib
import shutil
import sys
import tempfile
import threading
import weakref
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from .batch import stream
from .blender_process import BlenderProcess
from .client import worker_name
from .output import is_complete, write_atomic
from .progress import Tally, progress_bar


@dataclass
class FramesReport:
    """What `render_frames` did: files written and skipped, failed frames with their errors."""

    written: dict[int, Path] = field(default_factory=dict)
    skipped: dict[int, Path] = field(default_factory=dict)
    failed: dict[int, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)  # what the renders warned of, each once
    summary: str = ""


@dataclass
class FramesJob:
    """The frames of a .blend file as `prepare_frames` leaves them for a cluster: each frame's output
    file and the file's self-contained copy, which goes to the cluster once."""

    targets: dict[int, Path]  # frame -> its output file
    payload: bytes            # the .blend bytes every worker opens
    scene: str                # the scene rendered
    blend_name: str           # the user's file's name (the workers' copy keeps it)


def render_frames(
    path: str | Path,
    frames: Any = None,
    output: str | Path | None = None,
    samples: int | None = None,
    *,
    client: Any,
    scene: str | None = None,
    resume: bool = True,
    threads: int | None = None,
    progress: bool = True,
    log: TextIO | None = sys.stderr,
) -> FramesReport:
    """Render frames of a .blend file on the cluster of `client` (a `distributed.Client`):
    `prepare_frames`, then `run_frames`.

    frames, output, samples and scene as in `durer.blender.batch.render_file`; every format it
    writes (PNG, EXR with the view layer's passes, ...) comes out with the same pixels and passes,
    bit for bit (Blender's File metadata stamp names the worker's copy of the .blend). `resume`
    skips frames whose output exists and is complete (`output.is_complete`). Each frame renders on
    `threads` threads (None: 1 per task). A frame that fails is reported in `failed` with its error
    (and on `log`) and the others go on; a worker that dies has its frame re-run on another. What
    the renders warn of (skipped geometry, materials Dürer approximates) goes to `warnings` and
    `log`, each message once. One progress bar counts frames (rate and ETA); `summary` is the
    closing line, also written to `log`.

    The preparation runs Blender's operators (the copy's simulation bakes), which must not run
    beside other Python threads: with a local cluster in this process, call `prepare_frames` before
    starting it, then `run_frames` (as `python -m durer render --workers` does).
    """
    job = prepare_frames(path, frames, output, samples, scene=scene, threads=threads)
    return run_frames(job, client=client, resume=resume, progress=progress, log=log)


def prepare_frames(
    path: str | Path,
    frames: Any = None,
    output: str | Path | None = None,
    samples: int | None = None,
    *,
    scene: str | None = None,
    threads: int | None = None,
) -> FramesJob:
    """Open the .blend file in this process, apply the settings (as `render_frames` takes them), name
    each frame's output file and make the file's self-contained copy (external data packed, linked
    data made local, simulations baked into it), all without a cluster."""
    from ..blender import batch

    blend = Path(path).expanduser().resolve()
    frame_list = batch.parse_frames(frames)
    sc = batch.open_blend(blend, scene, samples, 1 if threads is None else threads)
    if frame_list is None:
        frame_list = [sc.frame_current]
    explicit = batch.configure_output(sc, output, len(frame_list))
    targets = {frame: batch.frame_target(sc, explicit, frame) for frame in frame_list}
    return FramesJob(targets, _self_contained_copy(max(frame_list)), sc.name, blend.name)


def run_frames(
    job: FramesJob, *, client: Any, resume: bool = True, progress: bool = True, log: TextIO | None = sys.stderr
) -> FramesReport:
    """Render a prepared job's frames on the cluster of `client`, as `render_frames` says."""
    targets, payload = job.targets, job.payload
    report = FramesReport()
    todo = []
    for frame, target in targets.items():
        if resume and is_complete(target):
            report.skipped[frame] = target
        else:
            todo.append(frame)
    tally = Tally("frame", len(targets), skipped=len(report.skipped), failed=report.failed)
    bar = progress_bar(progress, len(todo), "frame", log)
    try:
        if todo:
            shared = client.scatter(payload, hash=False)
            task = dict(digest=hashlib.sha256(payload).hexdigest(), scene=job.scene, blend_name=job.blend_name)

            def submit(i: int) -> Any:
                return client.submit(render_frame_task, shared, todo[i], targets[todo[i]].suffix, pure=False, **task)

            for i, future in stream(client, len(todo), submit, ordered=False):
                frame = todo[i]
                if future.status == "error":
                    error = future.exception()
                    report.failed[frame] = f"{type(error).__name__}: {error}"
                    _say(bar, log, f"frame {frame} failed: {report.failed[frame]}")
                else:
                    data, worker, warnings = future.result()
                    for message in warnings:
                        if message not in report.warnings:
                            report.warnings.append(message)
                            _say(bar, log, f"warning: {message}")
                    try:
                        write_atomic(targets[frame], data)
                    except OSError as error:  # a full disk here: that frame failed, the others go on
                        report.failed[frame] = f"{type(error).__name__}: {error}"
                        _say(bar, log, f"frame {frame} failed: {report.failed[frame]}")
                    else:
                        report.written[frame] = targets[frame]
                        tally.done_by[worker] += 1
                if bar is not None:
                    bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    report.summary = tally.summary()
    if log is not None:
        print(report.summary, file=log)
    return report


def _say(bar: Any, log: TextIO | None, message: str) -> None:
    if bar is not None:
        bar.write(message, file=log)
    elif log is not None:
        print(message, file=log)


def _self_contained_copy(last: int) -> bytes:
    """The open file with its external data packed, linked data made local and its simulations baked
    up to frame `last`, as .blend bytes."""
    import bpy

    from ..blender.batch import BatchRenderError, bake_simulations

    linked = _linked_blocks()
    while linked:  # a block still used by linked blocks stays linked: users first, then their data
        for block in linked:
            block.make_local()
        remaining = _linked_blocks()
        if len(remaining) >= len(linked):
            raise BatchRenderError(f"Cannot make linked data local: {', '.join(b.name for b in remaining)}")
        linked = remaining
    for library in list(bpy.data.libraries):
        bpy.data.libraries.remove(library)
    if any(image.source == "FILE" and image.packed_file is None for image in bpy.data.images):
        bpy.ops.file.pack_all()
    bake_simulations(last)  # into the copy, not to disk beside the user's file, which the workers do not have
    with tempfile.TemporaryDirectory(prefix="durer-ship-") as folder:
        copy = Path(folder) / "scene.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(copy), copy=True, compress=False)
        return copy.read_bytes()


def _linked_blocks() -> list[Any]:
    import bpy

    collections = (getattr(bpy.data, name) for name in dir(bpy.data))
    return [block for collection in collections if isinstance(collection, bpy.types.bpy_prop_collection)
            for block in collection if getattr(block, "library", None) is not None]


#: Per worker thread: {"process": its BlenderProcess, "folder": the temporary directory of the copy}.
_local = threading.local()


def render_frame_task(
    payload: bytes, frame: int, suffix: str, *, digest: str, scene: str, blend_name: str
) -> tuple[bytes, str, list[str]]:
    """A Dask task: render `frame` of the shipped .blend through the sequential path in this worker
    thread's bpy process (which opens the file on its first task and keeps it open); returns the
    image file's bytes, the worker's name and the render's warnings."""
    process = getattr(_local, "process", None)
    if process is None or not process.alive():
        process = _local.process = BlenderProcess()
        _local.folder = Path(tempfile.mkdtemp(prefix="durer-worker-"))
        weakref.finalize(process, shutil.rmtree, _local.folder, True)
    if process.opened != digest:
        blend = _local.folder / blend_name
        blend.write_bytes(payload)
        process.call("open", str(blend), scene)
        process.opened = digest
    data, warnings = process.call("render", scene, frame, str(_local.folder / f"frame_{frame}{suffix}"), blend_name)
    return data, worker_name(), warnings
