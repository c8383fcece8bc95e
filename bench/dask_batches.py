"""Distributed rendering overhead: 48 frames of a moving 100k-sphere scene at 1080p, rendered
(a) sequentially in one process on 2 threads and (b) as `durer.render_many` tasks on a local Dask
cluster of 2 worker processes x 1 thread, with the distributed path's per-frame overhead.

    python bench/dask_batches.py [--frames 48] [--spheres 100000] [--size 1920x1080] [--spp 1]

Each frame is its own scene (the spheres move), so every task carries its scene to a worker: the
figures include the scene transfer (pickle, network, unpickle on the worker) and the result's way
back (the colour pass by default: 33 MB of float32 RGBA a 1080p frame). Printed: frames/s of both
paths; then, each measured alone on one otherwise idle worker, a frame's render on one thread and
the parts of the distributed path's overhead per frame: the task round trip, the scene's transfer
and the result's, and their share of the frame. (On a 2-core machine the client shares the cores
with the workers, so the end-to-end rate also pays for the client's work.)
"""

from __future__ import annotations

import os

os.environ["OPENBLAS_NUM_THREADS"] = "1"  # idle BLAS threads would steal a core (before numpy)

import argparse  # noqa: E402
import pickle  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import durer  # noqa: E402
from durer.distributed import cluster  # noqa: E402


def moving_scenes(frames: int, spheres: int, seed: int = 48) -> list[durer.Scene]:
    """A cloud of `spheres` spheres drifting with constant velocities, one scene per frame."""
    rng = np.random.default_rng(seed)
    start = rng.uniform(-10, 10, (spheres, 3))
    velocity = rng.normal(0, 0.05, (spheres, 3))
    radii = rng.uniform(0.05, 0.15, spheres)
    scenes = []
    for frame in range(frames):
        scene = durer.Scene()
        colors = [scene.add_material((0.9, 0.3, 0.2)), scene.add_material((0.2, 0.5, 0.9))]
        scene.add_spheres(start + frame * velocity, radii, np.array(colors)[np.arange(spheres) % 2])
        scene.add_directional_light((-1, -2, -1), (1, 1, 1))
        scene.ambient = (0.1, 0.1, 0.1)
        scenes.append(scene)
    return scenes


def _object_count(scene: durer.Scene) -> int:
    return scene.object_count


def _blank_result(width: int, height: int, passes: tuple[str, ...]) -> dict:
    """A result of a frame's size and passes as render_many's tasks send it, made without
    rendering: its transfer costs the same."""
    shapes = {"color": (height, width, 4), "depth": (height, width), "normal": (height, width, 3)}
    arrays = [np.ones(shapes[p], np.float32) if p in passes else None for p in ("color", "depth", "normal")]
    return vars(durer.RenderResult(*arrays, {}))


def _timed(function, repeats: int) -> float:
    """Median seconds of `function()` over `repeats` calls."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def moving_cloud_blend(path: Path, frames: int, spheres: int, width: int, height: int, threads: int) -> Path:
    """A .blend of `spheres` points (a mesh through a Mesh to Points modifier) turning about the
    camera's axis over `frames` frames, with a sun: Dürer renders each point as a sphere."""
    import bpy

    import durer.blender
    from durer.blender.point_cloud import point_cloud_object

    bpy.ops.wm.read_factory_settings(use_empty=True)
    durer.blender.register()
    s = bpy.context.scene
    s.render.engine = "DURER"
    s.render.resolution_x, s.render.resolution_y, s.render.resolution_percentage = width, height, 100
    s.durer.samples, s.durer.threads = 1, threads
    s.frame_start, s.frame_end = 1, frames
    positions = np.random.default_rng(48).uniform(-10, 10, (spheres, 3))
    cloud = point_cloud_object(s.collection, "Cloud", positions, radius=0.1)
    for frame, angle in ((1, 0.0), (frames, 1.0)):
        cloud.rotation_euler = (0.0, 0.0, angle)
        cloud.keyframe_insert("rotation_euler", frame=frame)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = (0.6, 0.2, 0.3)
    s.collection.objects.link(sun)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location, camera.rotation_euler = (0, -35, 0), (1.5708, 0, 0)
    s.collection.objects.link(camera)
    s.camera = camera
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def blender_frames(args: argparse.Namespace, width: int, height: int) -> None:
    """The .blend path: `python -m durer render` sequentially (one process, 2 render threads) and
    with --workers 2 (1 thread each), and the distributed path's own costs per frame."""
    from durer.blender import batch
    from durer.distributed.frames import render_frames
    from durer.distributed.output import write_atomic

    with tempfile.TemporaryDirectory(prefix="durer-bench-") as folder:
        out = Path(folder)
        blend = moving_cloud_blend(out / "cloud.blend", args.frames, args.spheres, width, height, args.workers)
        frames = f"1-{args.frames}"
        start = time.perf_counter()
        batch.render_file(blend, frames, out / "seq" / "f_####.png")
        sequential = time.perf_counter() - start
        with cluster(workers=args.workers, log=None) as client:
            render_frames(blend, "1", out / "warm" / "f_####.png", client=client, progress=False, log=None)
            start = time.perf_counter()
            report = render_frames(blend, frames, out / "dask" / "f_####.png", client=client, progress=False,
                                   log=None)
            distributed = time.perf_counter() - start
            assert len(report.written) == args.frames, report.failed
            size = statistics.median(f.stat().st_size for f in report.written.values())
            trip = _timed(lambda: client.submit(int, 0, pure=False).result(), 20)
            image_trip = _timed(lambda: client.submit(bytes, int(size), pure=False).result(), 10)
            write = _timed(lambda: write_atomic(out / "probe.png", bytes(int(size))), 10)
            blend_size = blend.stat().st_size
            ship = _timed(lambda: client.scatter(blend.read_bytes(), hash=False, broadcast=True), 3)
        import bpy

        bpy.ops.wm.open_mainfile(filepath=str(blend))  # a frame's time on one thread, for the overhead's share
        bpy.context.scene.durer.threads = 1
        bpy.ops.wm.save_mainfile()
        start = time.perf_counter()
        batch.render_file(blend, "1-3", out / "one" / "f_####.png")
        one_thread = (time.perf_counter() - start) / 3
    overhead = trip + (image_trip - trip) + write
    print(f".blend frames ({args.frames} frames of {args.spheres} points as spheres, {width}x{height}, 1 spp, PNG):")
    print(f"  sequential, 1 process x {args.workers} threads: {args.frames / sequential:.2f} frames/s")
    print(f"  --workers {args.workers} (1 thread each):        {args.frames / distributed:.2f} frames/s "
          f"({sequential / distributed:.2f}x)")
    print(f"  a frame (export + render + PNG) on one thread alone: {one_thread * 1000:.0f} ms; distributed overhead:")
    print(f"    task round trip {trip * 1000:.1f} ms + image back ({size / 1e6:.2f} MB) "
          f"{(image_trip - trip) * 1000:.1f} ms"
          f" + atomic write {write * 1000:.1f} ms = {overhead * 1000:.1f} ms = {overhead / one_thread * 100:.1f} % "
          f"of a frame; the .blend ({blend_size / 1e6:.1f} MB) goes to the workers once: "
          f"{ship * 1000:.0f} ms")


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--frames", type=int, default=48)
    p.add_argument("--spheres", type=int, default=100_000)
    p.add_argument("--size", default="1920x1080")
    p.add_argument("--spp", type=int, default=1)
    p.add_argument("--passes", default="color", help="comma-separated passes to render and send back (default color)")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--only", choices=("numpy", "blender"), help="run one of the two parts (default both)")
    args = p.parse_args(argv)
    width, height = (int(v) for v in args.size.split("x"))
    if args.only != "numpy":
        blender_frames(args, width, height)
    if args.only == "blender":
        return 0
    passes = tuple(args.passes.split(","))
    scenes = moving_scenes(args.frames, args.spheres)
    camera = durer.PerspectiveCamera((0, 0, 30), (0, 0, -1), (0, 1, 0), fov_degrees=45)
    options = {"spp": args.spp, "passes": passes}
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python "
          f"{sys.version.split()[0]}; {args.frames} frames of {args.spheres} moving spheres, {width}x{height}, "
          f"{args.spp} spp, passes {'+'.join(passes)}")

    durer.render(scenes[0], camera, 64, 36)  # warm-up (lazy initialisation, first arrays)
    start = time.perf_counter()
    sequential_ms = [durer.render(s, camera, width, height, threads=args.workers, **options).stats["milliseconds"]
                     for s in scenes]
    sequential = time.perf_counter() - start

    with cluster(workers=args.workers, log=None) as client:
        workers = list(client.nthreads())
        for worker in workers:  # each worker imports durer and renders once before any clock starts
            client.submit(durer.render, scenes[0], camera, 64, 36, workers=[worker], pure=False).result()
        one = workers[:1]
        # The parts of the overhead, one at a time on one otherwise idle worker:
        trip = _timed(lambda: client.submit(int, 0, workers=one, pure=False).result(), 20)
        scene_trip = _timed(lambda: client.submit(_object_count, client.scatter(scenes[1], workers=one, hash=False),
                                                  workers=one, pure=False).result(), 5)
        result_trip = _timed(lambda: client.submit(_blank_result, width, height, passes, workers=one,
                                                   pure=False).result(), 5)
        alone_ms = statistics.median(
            client.submit(durer.render, client.scatter(scenes[i], workers=one, hash=False), camera, width, height,
                          threads=1, workers=one, pure=False, **options).result().stats["milliseconds"]
            for i in range(3))
        start = time.perf_counter()
        worker_ms = [r.stats["milliseconds"] for _, r in
                     durer.render_many(scenes, camera, width, height, client=client, ordered=False, **options)]
        distributed = time.perf_counter() - start

    overhead = trip + (scene_trip - trip) + (result_trip - trip)
    print(f"sequential, 1 process x {args.workers} threads: {args.frames / sequential:.2f} frames/s "
          f"(median render {statistics.median(sequential_ms):.0f} ms a frame)")
    print(f"distributed, {args.workers} workers x 1 thread:  {args.frames / distributed:.2f} frames/s "
          f"(median render on a worker, all busy: {statistics.median(worker_ms):.0f} ms a frame); "
          f"{sequential / distributed:.2f}x the sequential rate")
    print(f"a frame on one thread of an otherwise idle worker: {alone_ms:.0f} ms; "
          "its overhead on the distributed path:")
    print(f"  task round trip (empty task):          {trip * 1000:6.1f} ms")
    print(f"  scene transfer ({len(pickle.dumps(scenes[1])) / 1e6:.1f} MB pickled, unpickled): "
          f"{(scene_trip - trip) * 1000:6.1f} ms")
    print(f"  result transfer ({'+'.join(passes)}):          {(result_trip - trip) * 1000:6.1f} ms")
    print(f"  total: {overhead * 1000:.1f} ms = {overhead * 1000 / alone_ms * 100:.1f} % of the frame's render")
    return 0


if __name__ == "__main__":
    sys.exit(main())
