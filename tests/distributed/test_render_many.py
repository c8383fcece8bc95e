"""render_many: many cameras or scenes, locally or on a real local Dask cluster."""

from __future__ import annotations

import pickle
import signal
import subprocess
import sys

import pytest

import durer

from helpers.distributed import assert_same_image, every_kind_scene, orbit_cameras

SCENE = every_kind_scene()
OPTIONS = {"spp": 4, "seed": 3}


def test_fifty_cameras_on_a_cluster_equal_sequential_renders_in_order(client):
    cameras = orbit_cameras(50)
    results = list(durer.render_many(SCENE, cameras, 32, 24, client=client, **OPTIONS))
    assert [i for i, _ in results] == list(range(50))
    for (i, result), camera in zip(results, cameras):
        assert_same_image(result, durer.render(SCENE, camera, 32, 24, **OPTIONS))
    workers = {r.stats["worker"] for _, r in results}
    assert len(workers) == 2 and workers <= set(client.nthreads())


def test_as_completed_yields_every_index_once(client):
    cameras = orbit_cameras(12)
    results = dict(durer.render_many(SCENE, cameras, 16, 16, client=client, ordered=False, **OPTIONS))
    assert sorted(results) == list(range(12))
    assert_same_image(results[7], durer.render(SCENE, cameras[7], 16, 16, **OPTIONS))


def _count_unpickled_scenes():
    """Installed on each worker: counts Scene.__setstate__ calls there."""
    import durer.scene

    original = durer.scene.Scene.__setstate__
    durer.scene._unpickled = 0

    def counting(self, state):
        durer.scene._unpickled += 1
        original(self, state)

    durer.scene.Scene.__setstate__ = counting


def _unpickled():
    import durer.scene

    return durer.scene._unpickled


def test_a_scene_is_unpickled_once_per_worker_not_per_task(client):
    # Dask's active memory manager drops, every 2 s, a replica that no task queued on its worker
    # waits for, and the worker fetches it again later: on a slow machine that made a second unpickle
    # (documented). Stopped here so the test sees what render_many itself sends.
    client.amm.stop()
    try:
        client.run(_count_unpickled_scenes)
        cameras = orbit_cameras(20)
        assert len(list(durer.render_many(SCENE, cameras, 8, 8, client=client))) == 20
        counts = client.run(_unpickled)
    finally:
        client.amm.start()
    assert len(counts) == 2 and all(0 <= c <= 1 for c in counts.values()) and sum(counts.values()) >= 1, counts


def test_many_scenes_with_one_camera_locally_and_on_the_cluster(client):
    scenes = [every_kind_scene(seed) for seed in range(4)]
    camera = orbit_cameras(1)[0]
    local = list(durer.render_many(scenes, camera, 24, 16, **OPTIONS))
    remote = list(durer.render_many(scenes, camera, 24, 16, client=client, **OPTIONS))
    for (i, a), (j, b), scene in zip(local, remote, scenes):
        assert i == j and a.stats["worker"] == "local"
        assert_same_image(a, b)
        assert_same_image(a, durer.render(scene, camera, 24, 16, **OPTIONS))


def test_bad_arguments_raise_before_any_task_and_task_errors_come_back(client):
    camera = orbit_cameras(1)[0]
    with pytest.raises(TypeError, match="unexpected options: colour"):
        next(durer.render_many(SCENE, camera, 8, 8, colour=True))
    with pytest.raises(ValueError, match="2 scenes and 3 cameras"):
        next(durer.render_many([SCENE, SCENE], orbit_cameras(3), 8, 8))
    with pytest.raises(TypeError, match="cameras must be"):
        next(durer.render_many(SCENE, ["camera"], 8, 8))
    with pytest.raises(ValueError, match=r"spp must be in \[1, "):
        list(durer.render_many(SCENE, orbit_cameras(3), 8, 8, client=client, spp=0))
    assert pickle.loads(pickle.dumps(camera)) == camera


@pytest.mark.parametrize("options, error, message", [
    ({"sampler": "bogus"}, ValueError, "sampler must be 'center', "),
    ({"threads": 0}, ValueError, "threads must be >= 1"),
    ({"spp": 0}, ValueError, r"spp must be in \[1, "), ({"max_bounces": 5000}, ValueError, "max_bounces must be in"),
    ({"progress": "yes"}, TypeError, "progress must be True or False"),
    ({"ordered": None}, TypeError, "ordered must be True or False"),
])
def test_bad_arguments_raise_at_the_call_not_at_the_first_result(options, error, message):
    # render_many returns a generator: without checking first, these waited for next()
    with pytest.raises(error, match=message):
        durer.render_many(SCENE, orbit_cameras(2), 8, 8, **options)
    with pytest.raises(ValueError, match="height must be <= 1048576"):
        durer.render_many(SCENE, orbit_cameras(2), 8, 2**20 + 1)


def test_every_camera_is_checked_at_the_call():
    """A camera beyond float's range after good ones: refused before the first render (it raised in
    the loop, after the renders before it)."""
    far = durer.PerspectiveCamera((0, 0, 1e20), (0, 0, -1), (0, 1, 0))
    with pytest.raises(ValueError, match=r"with precision='float'"):
        durer.render_many(SCENE, orbit_cameras(2) + [far], 8, 8, precision="float")
    assert len(list(durer.render_many(SCENE, orbit_cameras(2) + [far], 8, 8))) == 3  # double holds it


class _CtrlCInAFinaliser:
    """Ctrl-C pressed while the garbage collector finalises an object (a Dask future, say): its
    KeyboardInterrupt is raised in __del__, where Python prints and drops it."""

    def __del__(self):
        signal.raise_signal(signal.SIGINT)


@pytest.fixture
def python_sigint():
    """SIGINT with Python's own handler, as in a script (importing dask_jobqueue, as the session's
    tests do, installs one that exits)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def test_ctrl_c_dropped_by_a_finaliser_still_stops_the_batch(client, python_sigint, capsys):
    hook = sys.unraisablehook
    renders = durer.render_many(SCENE, orbit_cameras(40), 16, 16, client=client, **OPTIONS)
    received = [next(renders)[0]]
    _CtrlCInAFinaliser()
    with pytest.raises(KeyboardInterrupt):
        for i, _ in renders:
            received.append(i)
    assert received == list(range(len(received))) and len(received) < 10
    assert "Exception ignored" not in capsys.readouterr().err
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler and sys.unraisablehook is hook
    assert [i for i, _ in durer.render_many(SCENE, orbit_cameras(3), 16, 16, client=client, **OPTIONS)] == [0, 1, 2]


def test_progress_bar_counts_renders(capsys):
    list(durer.render_many(SCENE, orbit_cameras(3), 8, 8, progress=True))
    err = capsys.readouterr().err
    assert "3/3" in err and "render/s" in err


def test_durer_batches_locally_without_dask_and_says_how_to_get_it():
    code = """if True:
        import sys
        sys.modules["distributed"] = sys.modules["dask"] = None  # as on a machine without Dask
        import durer
        from durer.distributed import cluster
        scene = durer.Scene()
        scene.add_spheres([[0, 0, 0]], 1.0)
        camera = durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), size=3)
        (i, result), = durer.render_many(scene, [camera], 8, 8)
        print(i, result.stats["worker"], result.depth.tobytes().hex())
        try:
            with cluster(workers=1):
                pass
        except ImportError as error:
            print(error)
    """
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    scene = durer.Scene()
    scene.add_spheres([[0, 0, 0]], 1.0)
    depth = durer.render(scene, durer.OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), size=3), 8, 8).depth
    assert done.stdout.splitlines() == [f"0 local {depth.tobytes().hex()}",
                                        "distributed rendering needs Dask: pip install 'durer[distributed]'"]
