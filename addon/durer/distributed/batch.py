"""`render_many`: one scene from many cameras, or many scenes, locally or on a Dask cluster."""

from __future__ import annotations

import inspect
import signal
import sys
import threading
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from .. import _checks
from ..camera import Camera, OrthographicCamera, PerspectiveCamera
from ..render import RenderResult, check_options, render
from ..scene import Scene
from .client import require_distributed, worker_name
from .progress import progress_bar

#: Options `render` takes that a batch passes through unchanged to every render.
_RENDER_OPTIONS = set(inspect.signature(render).parameters) - {
    "scene", "camera", "width", "height", "threads", "progress", "cancel", "out", "region"}


def render_many(
    scene: Scene | Sequence[Scene],
    cameras: Camera | Sequence[Camera],
    width: int,
    height: int,
    *,
    client: Any = None,
    ordered: bool = True,
    progress: bool = False,
    threads: int | None = None,
    **options: Any,
) -> Iterator[tuple[int, RenderResult]]:
    """Render a scene from many cameras (or many scenes, from one camera each, or one camera for
    all): yields (index, RenderResult) pairs, index counting the cameras/scenes from 0.

    Without `client` the renders run one after another in this process, each on `threads` threads
    (None: all cores). With a `distributed.Client` each render is a task on the cluster: every
    distinct scene is sent to the cluster with its first task (a worker unpickles it once, whatever
    the number of tasks, unless Dask's memory manager dropped its replica; it is dropped after its
    last), cameras go with their tasks, and each task renders on `threads` threads (None: 1, Dask's
    threads being the parallelism; start workers with ``--nthreads`` = cores). `ordered=True` yields in index order, False as renders complete; at
    most a few tasks per worker thread are in flight (results wait on the workers, not in memory
    here). `progress=True` draws one bar over all renders (stderr). `options` are `durer.render`'s
    (spp, seed, sampler, precision, passes, ...); results equal `durer.render`'s bit for bit and
    `result.stats["worker"]` names the worker ("local" without a client). A failing render raises
    its error here after the remaining tasks are cancelled; bad arguments (the options, any camera)
    raise at the call, before any render.
    """
    scenes, camera_list = _pairs(scene, cameras)
    unknown = set(options) - _RENDER_OPTIONS
    if unknown:
        raise TypeError(f"render_many got unexpected options: {', '.join(sorted(unknown))}")
    ordered = _checks.boolean(ordered, "ordered")
    progress = _checks.boolean(progress, "progress")
    for camera in {id(c): c for c in camera_list}.values():  # ~0.1 ms each
        check_options(width, height, camera, threads=threads, **options)
    jobs = [dict(options, camera=c, width=width, height=height) for c in camera_list]
    return run_renders(scenes, jobs, client=client, ordered=ordered, progress=progress, threads=threads,
                       unit="render")



def _pairs(scene: Any, cameras: Any) -> tuple[list[Scene], list[Camera]]:
    scenes = [scene] if isinstance(scene, Scene) else list(scene) if isinstance(scene, Sequence) else None
    if not scenes or not all(isinstance(s, Scene) for s in scenes):
        raise TypeError("scene must be a durer.Scene or a non-empty sequence of them")
    camera_types = (OrthographicCamera, PerspectiveCamera)
    camera_list = [cameras] if isinstance(cameras, camera_types) else \
        list(cameras) if isinstance(cameras, Sequence) else None
    if not camera_list or not all(isinstance(c, camera_types) for c in camera_list):
        raise TypeError("cameras must be a camera or a non-empty sequence of OrthographicCamera/PerspectiveCamera")
    if len(scenes) == 1:
        scenes = scenes * len(camera_list)
    elif len(camera_list) == 1:
        camera_list = camera_list * len(scenes)
    elif len(scenes) != len(camera_list):
        raise ValueError(f"scene and cameras must be one, or as many as each other: got {len(scenes)} scenes "
                         f"and {len(camera_list)} cameras")
    return scenes, camera_list


def run_renders(
    scenes: list[Scene], jobs: list[dict[str, Any]], *, client: Any, ordered: bool, progress: bool,
    threads: int | None, unit: str,
) -> Iterator[tuple[int, RenderResult]]:
    """Render job i (render's keyword arguments) of scenes[i]: locally or as tasks on `client`."""
    bar = progress_bar(progress, len(jobs), unit)
    try:
        if client is None:
            for i, (scene, job) in enumerate(zip(scenes, jobs)):
                result = render_task(scene, threads=threads, **job)
                if bar is not None:
                    bar.update(1)
                yield i, result
            return
        sent: dict[int, Any] = {}  # id(scene) -> its future on the cluster: each scene sent once

        def submit(i: int) -> Any:
            scene = scenes[i]
            if id(scene) not in sent:  # sent with its first task, not all up front
                sent[id(scene)] = client.scatter(scene, hash=False)
            return client.submit(_remote_render, sent[id(scene)], threads=1 if threads is None else threads,
                                 pure=False, **jobs[i])

        uses = Counter(id(scene) for scene in scenes)
        for i, future in stream(client, len(jobs), submit, ordered=ordered):
            result = RenderResult(**future.result())
            uses[id(scenes[i])] -= 1
            if not uses[id(scenes[i])]:  # its last task is done: the cluster may forget it
                del sent[id(scenes[i])]
            if bar is not None:
                bar.update(1)
            yield i, result
    finally:
        if bar is not None:
            bar.close()


def render_task(scene: Scene, *, threads: int | None, **job: Any) -> RenderResult:
    """One render (a Dask task, or a local call): `durer.render` with the worker's name in stats."""
    result = render(scene, threads=threads, **job)
    result.stats["worker"] = worker_name()
    return result


def _remote_render(scene: Scene, **job: Any) -> dict[str, Any]:
    """`render_task` on a worker: the result travels as a dict of its fields, which Dask sends with
    its arrays out of band (a RenderResult itself would be pickled with copies: twice the time)."""
    return vars(render_task(scene, **job))


def stream(
    client: Any, count: int, submit: Callable[[int], Any], *, ordered: bool, window: int | None = None
) -> Iterator[tuple[int, Any]]:
    """Submit tasks 0..count-1 with `submit(i)` -> future, keeping at most `window` (default: four
    per worker thread) submitted but not yet yielded, and yield (i, finished future) in index order
    or as they finish. Tasks still pending when the caller stops (an error, Ctrl-C) are cancelled.
    Ctrl-C raises KeyboardInterrupt here even when it lands in a finaliser (`_ctrl_c_kept`)."""
    distributed = require_distributed()
    if window is None:
        window = 4 * max(1, sum(client.nthreads().values()))
    done = distributed.as_completed()
    index: dict[Any, int] = {}
    ready: dict[int, Any] = {}
    submitted = yielded = 0

    def top_up() -> None:
        nonlocal submitted
        while submitted < count and submitted - yielded < window:
            future = submit(submitted)
            index[future.key] = submitted
            done.add(future)
            submitted += 1

    with _ctrl_c_kept() as pressed:
        try:
            top_up()
            for future in done:
                if pressed.is_set():  # a Ctrl-C whose KeyboardInterrupt a finaliser dropped
                    raise KeyboardInterrupt
                i = index.pop(future.key)
                if not ordered:
                    yielded += 1
                    yield i, future
                else:
                    ready[i] = future
                    while yielded in ready:
                        yielded += 1
                        yield yielded - 1, ready.pop(yielded - 1)
                top_up()
            if pressed.is_set():
                raise KeyboardInterrupt
        finally:
            pending = list(done.futures)
            done.clear()
            if pending:
                client.cancel(pending)


@contextmanager
def _ctrl_c_kept() -> Iterator[threading.Event]:
    """An event set by Ctrl-C while the block runs. Python raises KeyboardInterrupt wherever the main
    thread is, and one raised inside a finaliser (a Dask future's __del__, run by the garbage
    collector at any moment) is printed as "Exception ignored" and dropped: the loop would go on
    rendering every frame. Here the handler also records the press for the loop to raise again, and
    a KeyboardInterrupt dropped that way is not printed. Outside the main thread, or when SIGINT has
    a handler other than Python's default, the event is never set and nothing changes."""
    pressed = threading.Event()
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        yield pressed
        return

    def on_sigint(signum: int, frame: Any) -> None:
        pressed.set()
        raise KeyboardInterrupt

    def on_unraisable(unraisable: Any) -> None:
        if not isinstance(unraisable.exc_value, KeyboardInterrupt):
            previous_hook(unraisable)

    previous_hook = sys.unraisablehook
    signal.signal(signal.SIGINT, on_sigint)
    sys.unraisablehook = on_unraisable
    try:
        yield pressed
    finally:  # each put back only if still ours (a generator may be closed late, from any thread)
        if sys.unraisablehook is on_unraisable:
            sys.unraisablehook = previous_hook
        if threading.current_thread() is threading.main_thread() and signal.getsignal(signal.SIGINT) is on_sigint:
            signal.signal(signal.SIGINT, signal.default_int_handler)
