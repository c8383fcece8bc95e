"""Progress, cancel and the GIL: long renders behave like a good citizen of the Python process."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import numpy as np
import pytest

import durer


def heavy_scene(n: int = 20000) -> tuple[durer.Scene, durer.OrthographicCamera]:
    """20,000 small mirror-like spheres under a sun casting shadows: with many samples per pixel a
    render takes seconds (the shadow and mirror rays, which no camera view serves)."""
    rng = np.random.default_rng(1)
    scene = durer.Scene()
    mirror = scene.add_material(diffuse=(0.5, 0.5, 0.5), reflective=(0.5, 0.5, 0.5))
    scene.add_spheres(rng.uniform(-5, 5, (n, 3)), rng.uniform(0.01, 0.05, n), material=mirror)
    scene.add_directional_light((-1, -2, -1), (1, 1, 1), shadows=True)
    return scene, durer.OrthographicCamera((0, 0, 10), (0, 0, -1), (0, 1, 0), 10.0)


def test_progress_is_reported_in_order_and_ends_at_one():
    scene, camera = heavy_scene(3000)
    fractions: list[float] = []
    durer.render(scene, camera, 128, 128, progress=fractions.append)
    assert len(fractions) >= 2
    assert fractions == sorted(fractions)
    assert fractions[-1] == 1.0 and all(0 <= f <= 1 for f in fractions)


@pytest.mark.parametrize("kind", ["callable", "event"])
def test_cancel_stops_promptly_and_says_so(kind):
    scene, camera = heavy_scene()
    event = threading.Event()
    cancelled_at: list[float] = []

    def cancel_later():
        time.sleep(0.3)
        cancelled_at.append(time.perf_counter())
        event.set()

    timer = threading.Thread(target=cancel_later)
    timer.start()
    cancel = event if kind == "event" else event.is_set
    with pytest.raises(durer.RenderCancelled) as info:
        durer.render(scene, camera, 400, 400, spp=256, cancel=cancel)  # tens of seconds uncancelled
    stopped_at = time.perf_counter()
    timer.join()
    # The contract is 0.1 s; the bound leaves room for a loaded 2-core CI machine.
    assert stopped_at - cancelled_at[0] < 0.25
    partial = info.value.result
    assert partial.stats["cancelled"] is True
    assert 0 < partial.stats["rays"] < 400 * 400 * 256
    assert partial.color.shape == (400, 400, 4)
    assert "cancelled" in str(info.value)


def test_cancel_before_start_renders_nothing():
    scene, camera = heavy_scene(100)
    with pytest.raises(durer.RenderCancelled) as info:
        durer.render(scene, camera, 64, 64, cancel=lambda: True)
    assert info.value.result.stats["rays"] == 0  # the core polls once before any worker starts


def test_a_cancelled_renders_id_passes_are_misses_where_it_did_not_reach():
    scene, camera = heavy_scene()
    scene.add_plane((0, 0, 1), -6.0)  # behind everything: every pixel rendered hits something
    stop = threading.Event()
    timer = threading.Timer(0.3, stop.set)
    timer.start()
    with pytest.raises(durer.RenderCancelled) as info:
        durer.render(scene, camera, 400, 400, spp=256, passes=("object_id",), cancel=stop)
    timer.join()
    partial = info.value.result
    assert 0 < partial.stats["rays"] < 400 * 400 * 256
    # A tile is written whole or not at all: 256 camera rays per pixel reached, -1 everywhere else.
    assert (partial.object_id != -1).sum() * 256 == partial.stats["rays"]


@pytest.mark.parametrize("sampler", ["stratified", "adaptive"])
def test_the_pixels_a_cancel_left_unreached_are_marked_so(sampler):
    """Depth and error NaN (a value no rendered pixel has; misses are inf), colour (0, 0, 0, 0),
    normal 0, ids -1, samples 0 -- also in buffers reused through `out`, which held the render
    before's (they held whatever the memory held, or depth 0, which looks like a hit)."""
    scene, camera = heavy_scene()
    scene.add_plane((0, 0, 1), -6.0)  # behind everything: every pixel rendered hits something
    passes = ("color", "depth", "normal", "object_id", "material_id")
    before = durer.render(scene, camera, 96, 96, spp=1, passes=passes)
    stop = threading.Event()

    def stop_once_some_are_done(fraction: float) -> None:  # not after a fixed time: a loaded machine
        if fraction > 0:                                     # may finish no tile in it
            stop.set()

    with pytest.raises(durer.RenderCancelled) as info:
        durer.render(scene, camera, 96, 96, spp=4096, sampler=sampler, min_spp=4096, passes=passes, cancel=stop,
                     progress=stop_once_some_are_done, out=before)
    partial = info.value.result
    reached = np.isfinite(partial.depth)
    # Stratified writes each tile once done (some were); adaptive its tiles after its last round.
    assert 0 < reached.mean() < 0.9 if sampler == "stratified" else not reached.any()
    assert (partial.color[~reached] == 0).all() and (partial.normal[~reached] == 0).all()
    assert (partial.object_id[~reached] == -1).all() and (partial.material_id[~reached] == -1).all()
    assert (partial.object_id[reached] >= 0).all() and (partial.depth[reached] > 0).all()
    if sampler == "adaptive":
        assert (partial.samples == 0).all() and np.isnan(partial.error).all()


@contextmanager
def ticking() -> Iterator[Callable[[], int]]:
    """A Python thread counting its turns (one every 1-2 ms) while the block runs; yields the count since
    the block began. It can only advance while the main thread's native call has released the GIL."""
    ticks = 0
    stop = threading.Event()

    def count():
        nonlocal ticks
        while not stop.is_set():
            ticks += 1
            time.sleep(0.001)

    counter = threading.Thread(target=count)
    counter.start()
    start = ticks
    try:
        yield lambda: ticks - start
    finally:
        stop.set()
        counter.join()


def test_a_python_thread_runs_while_rendering():
    scene, camera = heavy_scene()
    with ticking() as ticks:
        result = durer.render(scene, camera, 160, 160, spp=64, threads=1)
        during = ticks()
    seconds = result.stats["milliseconds"] / 1000
    # The render lasted long enough for the proportional check to mean something (~430 ticks here); unlike a
    # bound on seconds this cannot fail on a faster machine, only on one 40 times faster.
    assert during >= 10
    assert during >= 0.3 * seconds / 0.002  # the counter thread kept running (~1 tick per 1-2 ms)


def test_exceptions_in_callbacks_propagate_and_stop_the_render():
    scene, camera = heavy_scene(3000)

    def broken(fraction: float) -> None:
        raise KeyError("from progress")

    with pytest.raises(KeyError, match="from progress"):
        durer.render(scene, camera, 256, 256, progress=broken)
    # the engine is still usable afterwards
    assert durer.render(scene, camera, 8, 8).stats["rays"] == 64


def test_cast_releases_the_gil_and_can_be_cancelled():
    scene, _ = heavy_scene()
    rng = np.random.default_rng(2)
    n = 4_000_000  # uncancelled ~0.8 s here, about 700 counter ticks: many times the 50 the cancel waits for
    origins, directions = rng.uniform(-5, 5, (n, 3)), rng.normal(size=(n, 3))
    with ticking() as ticks:
        # The cancel fires only once the counter thread has run 50 times during the cast, which it can only
        # do if the cast released the GIL; a cast holding it would finish instead of raising.
        with pytest.raises(RuntimeError, match="^cast cancelled$"):
            durer.cast(scene, origins, directions, cancel=lambda: ticks() >= 50)
        assert ticks() >= 50


LIMITED = """
import resource, sys
import numpy as np, durer
scene = durer.Scene(); scene.add_spheres([[0, 0, 0]], 1.0)
camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 3)
if sys.argv[2] == "after a render":
    durer.render(scene, camera, 8, 8, threads=1)  # its worker's stack is kept for the next render
used = int(open("/proc/self/statm").read().split()[0]) * resource.getpagesize()
soft, hard = resource.getrlimit(resource.RLIMIT_AS)
resource.setrlimit(resource.RLIMIT_AS, (used + int(sys.argv[1]) * 2**20, hard))
try:
    image = durer.render(scene, camera, 64, 64, threads=150).color
except RuntimeError as error:
    print(f"RuntimeError: {error}")
    sys.exit(0)
finally:
    resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
print("same" if np.array_equal(image, durer.render(scene, camera, 64, 64, threads=1).color) else "different")
"""


@pytest.mark.parametrize("headroom_mib, before, expected", [
    (1024, "first", "same"),  # room for some of the 150 threads' stacks: fewer workers render the same image
    (8, "first", "RuntimeError: threads: could not start a render thread"),  # room for none: an error, not std::terminate
    (8, "after a render", "same"),  # the stack kept from the render before: one worker
])
def test_threads_that_cannot_be_created_shrink_the_pool_or_raise(headroom_mib, before, expected):
    done = subprocess.run([sys.executable, "-c", LIMITED, str(headroom_mib), before], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(expected)


def test_a_grid_made_on_three_threads_finds_what_one_threads_finds():
    # 200,000 spheres fill their box evenly: incoherent rays walk a grid of them, made by the first
    # cast on the scene's threads, a chunk of the spheres each (three chunks here). Two scenes, as the
    # prepared spheres and their grid are kept per scene.
    rng = np.random.default_rng(5)
    centers, radii = rng.uniform(-10, 10, (200_000, 3)), rng.uniform(0.02, 0.1, 200_000)
    origins, directions = rng.uniform(-11, 11, (20_000, 3)), rng.normal(size=(20_000, 3))
    hits = []
    for threads in (1, 3):
        scene = durer.Scene()
        scene.add_spheres(centers, radii)
        hits.append(durer.cast(scene, origins, directions, threads=threads))
    assert np.isfinite(hits[0].t).mean() > 0.5  # most rays meet a sphere: the grid's records are read
    assert np.array_equal(hits[0].t, hits[1].t) and np.array_equal(hits[0].object_id, hits[1].object_id)
