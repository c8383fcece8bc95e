"""A bpy process beside each Dask worker thread.

bpy must run on a process's main thread (opening a file from another thread crashes Blender), and
Dask runs tasks on worker threads; so a task drives a child Python process that imports bpy, opens
the shipped .blend once and renders frame after frame on its main thread. The child reads requests
from a socket and exits when it closes: when its worker exits or dies, it follows after at most
the frame it is rendering.

    python -m durer.distributed.blender_process FD      (started by `BlenderProcess`)
"""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from .output import is_complete


class BlenderProcess:
    """The child process and its connection; `call` sends a request and returns its reply or raises
    the error it raised. Nothing closes it: the child exits when the connection closes, that is when
    this object is dropped (its worker thread or process ended) or the worker dies."""

    def __init__(self) -> None:
        parent, child = socket.socketpair()
        self.process = subprocess.Popen(
            [sys.executable, "-m", "durer.distributed.blender_process", str(child.fileno())],
            pass_fds=[child.fileno()], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
        child.close()
        self.connection = Connection(parent.detach())
        self.opened: str | None = None  # the key of the .blend it has open

    def alive(self) -> bool:
        return self.process.poll() is None

    def call(self, *request: Any) -> Any:
        try:
            self.connection.send(request)
            ok, value = self.connection.recv()
        except (EOFError, OSError):
            from ..blender.batch import BatchRenderError

            code = self.process.wait()
            raise BatchRenderError(f"Blender's process exited (code {code}) during {request[0]}") from None
        if not ok:
            raise value
        return value


def _open(path: str, scene: str) -> None:
    from ..blender import batch

    batch.open_blend(Path(path), scene)


def _render(scene: str, frame: int, target: str, blend_name: str) -> tuple[bytes, list[str]]:
    import bpy

    from ..blender import batch, engine

    sc = bpy.data.scenes[scene]
    sc.render.use_persistent_data = True  # the frames of a batch: each reuses the last one's scene, as render_file
    sc.frame_set(frame)
    sc.render.filepath, sc.render.use_file_extension = target, False
    path = Path(target)
    try:
        batch._render_frame(bpy, engine, sc, Path(blend_name), frame, 1, False)
        if not is_complete(path):  # Blender says "Saved" even when the disk filled up
            raise batch.BatchRenderError(f"Frame {frame} of {blend_name} rendered but its image was not written "
                                         "whole (a full disk?)")
        return path.read_bytes(), engine.last_render.warnings
    finally:
        path.unlink(missing_ok=True)


_REQUESTS = {"open": _open, "render": _render}


def main(fd: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the client's to handle; EOF ends this process
    connection = Connection(fd)
    while True:
        try:
            name, *args = connection.recv()
        except EOFError:
            return
        try:
            reply = (True, _REQUESTS[name](*args))
        except Exception as error:  # noqa: BLE001 - the task raises it on the worker
            reply = (False, error)
        try:
            connection.send(reply)
        except OSError:  # the worker is gone
            return


if __name__ == "__main__":
    main(int(sys.argv[1]))
