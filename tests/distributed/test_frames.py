"""Frames of a .blend on real Dask clusters: identical to the sequential path, atomic, resumable,
robust to a killed worker, a broken frame and Ctrl-C."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from PIL import Image

from helpers.blend import animated_blend, bpy, falling_particles_blend

import psutil

from durer.blender import batch
from durer.blender.batch import unbaked_point_caches
from durer.distributed.frames import _self_contained_copy, prepare_frames, render_frames, run_frames
from durer.distributed.output import TEMP_SUFFIX, is_complete

from helpers.distributed import TIMEOUT, assert_same_image_file

pytestmark = [pytest.mark.blender, pytest.mark.slow]


def durer_render(*args: str, timeout: float = TIMEOUT) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "durer", "render", *args], capture_output=True, text=True,
                          timeout=timeout, check=False)


@pytest.fixture(scope="module")
def animation(tmp_path_factory):
    """The 12-frame animation and its frames rendered by the sequential path (PNG)."""
    folder = tmp_path_factory.mktemp("animation")
    blend = animated_blend(folder / "anim.blend")
    files = batch.render_file(blend, frames="1-12", output=folder / "seq" / "f_####.png")
    assert len({np.asarray(Image.open(f)).tobytes() for f in files}) == 12  # every frame differs
    return blend, {int(f.stem[2:]): f for f in files}


def test_workers_render_frames_identical_to_sequential_and_resume(animation, tmp_path):
    blend, sequential = animation
    out = tmp_path / "out" / "f_####.png"
    done = durer_render(str(blend), "--frames", "1-12", "--output", str(out), "--workers", "2", "-q")
    assert done.returncode == 0, done.stderr
    assert "12 frames: 12 rendered, 0 failed" in done.stderr and "per worker: tcp://127.0.0.1:" in done.stderr
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [f.name for f in sequential.values()]
    for frame, f in sequential.items():
        assert_same_image_file(tmp_path / "out" / f.name, f)
    # Resume: complete outputs are skipped; a truncated one is rendered again.
    damaged = tmp_path / "out" / "f_0005.png"
    damaged.write_bytes(sequential[5].read_bytes()[:300])
    assert not is_complete(damaged)
    stamp = (tmp_path / "out" / "f_0001.png").stat().st_mtime_ns
    done = durer_render(str(blend), "--frames", "1-12", "--output", str(out), "--workers", "2", "-q")
    assert done.returncode == 0, done.stderr
    assert "12 frames: 1 rendered, 11 skipped (complete), 0 failed" in done.stderr
    assert_same_image_file(damaged, sequential[5])
    assert (tmp_path / "out" / "f_0001.png").stat().st_mtime_ns == stamp


# The bakes below run before any test of this module starts the session's local cluster: Blender's
# bake operators must not run beside other Python threads (the cluster's event loop in this
# process; a simulation zone's bake beside it crashed the interpreter once in CI).
def test_the_shipped_copy_holds_the_bake_even_of_a_disk_cache(tmp_path):
    """A simulation set to cache on disk (beside the user's file, where workers cannot read it) is
    baked into the shipped copy itself; hair without dynamics is no simulation to bake."""
    blend = falling_particles_blend(tmp_path / "particles.blend")
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    emitter = bpy.data.objects["Emitter"]
    emitter.particle_systems[0].point_cache.use_disk_cache = True
    emitter.modifiers.new("Hair", "PARTICLE_SYSTEM")
    emitter.particle_systems[1].settings.type = "HAIR"
    bpy.ops.wm.save_mainfile()
    assert len(unbaked_point_caches()) == 1  # the falling particles, not the hair
    (tmp_path / "ship.blend").write_bytes(_self_contained_copy(bpy.context.scene.frame_end))
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "ship.blend"))
    cache = bpy.data.objects["Emitter"].particle_systems[0].point_cache
    assert cache.is_baked and not cache.use_disk_cache and "in memory" in cache.info
    assert unbaked_point_caches() == []


def test_the_shipped_copy_holds_the_bake_of_a_simulation_zone(tmp_path):
    """A geometry-nodes Simulation Zone (points falling 0.05 a frame from z = 5) is baked, packed,
    into the shipped copy: a worker setting frame 5 directly gets the points where 5 frames of
    stepping put them (unbaked, it got them where the simulation starts)."""
    import numpy as np
    from helpers.blend import falling_points

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(scene.camera)
    falling_points(scene)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "falling.blend"))
    (tmp_path / "ship.blend").write_bytes(_self_contained_copy(bpy.context.scene.frame_end))
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "ship.blend"))
    bpy.context.scene.frame_set(5)
    sim = bpy.data.objects["Sim"].evaluated_get(bpy.context.evaluated_depsgraph_get())
    geometry = bpy.types.GeometrySet.from_evaluated_object(sim)  # kept while its cloud is read
    cloud = geometry.pointcloud
    z = np.empty(len(cloud.points) * 3, np.float32)
    cloud.attributes["position"].data.foreach_get("vector", z)
    np.testing.assert_allclose(z[2::3], 5 - 5 * 0.05, atol=1e-5)


def test_multilayer_exr_with_passes_in_the_files_own_format_equals_sequential(client, tmp_path):
    blend = animated_blend(tmp_path / "passes.blend", frames=3)
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    sc = bpy.context.scene
    sc.view_layers[0].use_pass_z = sc.view_layers[0].use_pass_normal = True
    sc.view_layers[0].use_pass_diffuse_color = True  # a pass Dürer does not write: warned, once a batch
    settings = sc.render.image_settings
    settings.media_type, settings.file_format = "MULTI_LAYER_IMAGE", "OPEN_EXR_MULTILAYER"
    settings.exr_codec, settings.color_depth = "NONE", "32"
    bpy.ops.wm.save_mainfile()
    # No extension: the file's own format (multilayer EXR), named by Blender's frame_path.
    warned = []
    sequential = batch.render_file(blend, frames="1-3", output=tmp_path / "seq" / "f_##", on_warning=warned.append)
    report = render_frames(blend, "1-3", tmp_path / "dask" / "f_##", client=client, progress=False, log=None)
    assert sorted(report.written) == [1, 2, 3] and not report.failed
    assert warned == report.warnings == ["View layer 'ViewLayer' asks for passes Dürer does not write: Diffuse Color"]
    assert [f.name for f in sequential] == ["f_01.exr", "f_02.exr", "f_03.exr"]
    for f in sequential:
        assert_same_image_file(tmp_path / "dask" / f.name, f)
        assert is_complete(tmp_path / "dask" / f.name)


def test_a_simulation_renders_the_same_frames_on_workers_as_in_one_process(client, tmp_path):
    """Falling particles, not baked: a worker given the frames in another order simulates them from
    the cache baked on the client, so every frame is the sequential path's, bit for bit."""
    blend = falling_particles_blend(tmp_path / "particles.blend")
    sequential = batch.render_file(blend, frames="1-8", output=tmp_path / "seq" / "f_#.png")
    assert len({np.asarray(Image.open(f)).tobytes() for f in sequential}) == 8
    report = render_frames(blend, "8,3,6,1,5,2,7,4", tmp_path / "dask" / "f_#.png", client=client, progress=False,
                           log=None)
    assert sorted(report.written) == list(range(1, 9)) and not report.failed
    for f in sequential:
        assert_same_image_file(tmp_path / "dask" / f.name, f)


def test_existing_scheduler_and_workers_started_as_processes(animation, external_scheduler, tmp_path):
    blend, sequential = animation
    done = durer_render(str(blend), "-f", "3-6", "-o", str(tmp_path / "f_####.png"), "--scheduler",
                        external_scheduler)
    assert done.returncode == 0, done.stderr
    assert f"dask: {external_scheduler}, 2 workers" in done.stderr
    assert "4/4" in done.stderr and "frame/s" in done.stderr  # the progress bar
    for frame in range(3, 7):
        assert_same_image_file(tmp_path / f"f_{frame:04d}.png", sequential[frame])


def test_killed_worker_has_its_frame_rerun_and_every_frame_is_written_once(animation, client, tmp_path):
    blend = animated_blend(tmp_path / "slow.blend", frames=16, width=160, height=120, samples=16)
    expected = batch.render_file(blend, frames="1-16", output=tmp_path / "seq" / "f_##.png")
    client.wait_for_workers(2, timeout=TIMEOUT)
    pids = client.run(os.getpid)
    before = client.run_on_scheduler(_frames_taken_from_a_lost_worker)
    killed = []

    def kill_one_busy_worker() -> None:
        deadline = time.monotonic() + TIMEOUT
        while time.monotonic() < deadline and not killed:
            busy = [w for w, tasks in client.processing().items() if tasks]
            if len(list((tmp_path / "dask").glob("*.png"))) >= 2 and busy:
                os.kill(pids[busy[0]], signal.SIGKILL)
                killed.append(len(list((tmp_path / "dask").glob("*.png"))))
            time.sleep(0.01)

    killer = threading.Thread(target=kill_one_busy_worker)
    killer.start()
    report = render_frames(blend, "1-16", tmp_path / "dask" / "f_##.png", client=client, progress=False, log=None)
    killer.join(timeout=TIMEOUT)
    assert killed and killed[0] < 16  # killed mid-run
    assert client.run_on_scheduler(_frames_taken_from_a_lost_worker) > before  # ... during a frame: rerun
    assert not report.failed and sorted(report.written) == list(range(1, 17))
    assert sorted(p.name for p in (tmp_path / "dask").iterdir()) == [f.name for f in expected]
    for f in expected:
        assert_same_image_file(tmp_path / "dask" / f.name, f)
    client.wait_for_workers(2, timeout=TIMEOUT)  # the nanny restarted it


def _frames_taken_from_a_lost_worker(dask_scheduler) -> int:
    """Frame tasks the scheduler moved from processing back to waiting or released: their worker died."""
    return sum(1 for t in dask_scheduler.transition_log if "render_frame_task" in str(t.key)
               and t.start == "processing" and t.finish in ("waiting", "released"))


def test_broken_frame_is_reported_and_the_others_finish(animation, tmp_path):
    blend, sequential = animation
    broken = tmp_path / "broken.blend"
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    camera = bpy.context.scene.camera.data
    camera.type = "PERSP"
    camera.keyframe_insert("type", frame=1)
    camera.type = "PANO"
    camera.keyframe_insert("type", frame=4)
    camera.type = "PERSP"
    camera.keyframe_insert("type", frame=5)
    bpy.ops.wm.save_as_mainfile(filepath=str(broken))
    done = durer_render(str(broken), "-f", "1-6", "-o", str(tmp_path / "f_####.png"), "--workers", "2", "-q")
    assert done.returncode == 1
    assert "frame 4 failed: BatchRenderError: Frame 4 of broken.blend failed:" in done.stderr
    assert "is panoramic" in done.stderr and "1 frames failed: 4" in done.stderr
    assert "6 frames: 5 rendered, 1 failed" in done.stderr
    assert sorted(p.name for p in tmp_path.glob("f_*.png")) == [f"f_{f:04d}.png" for f in (1, 2, 3, 5, 6)]
    for frame in (1, 2, 3, 5, 6):
        assert_same_image_file(tmp_path / f"f_{frame:04d}.png", sequential[frame])


def test_ctrl_c_leaves_no_partial_files_and_no_worker_processes(tmp_path):
    """Ctrl-C mid-run: exit code 130, only whole images, every worker (and bpy) process gone."""
    blend = animated_blend(tmp_path / "long.blend", frames=200, width=160, height=120, samples=16)
    out = tmp_path / "out"
    client = subprocess.Popen(
        [sys.executable, "-m", "durer", "render", str(blend), "-f", "1-200", "-o", str(out / "f_###.png"),
         "--workers", "2"], stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + TIMEOUT
        while len(list(out.glob("f_*.png"))) < 3:
            assert time.monotonic() < deadline and client.poll() is None
            time.sleep(0.05)
        children = psutil.Process(client.pid).children(recursive=True)
        assert len(children) >= 2  # the worker processes (and their nannies)
        os.killpg(client.pid, signal.SIGINT)  # as Ctrl-C in a terminal: the client and its workers
        _, err = client.communicate(timeout=TIMEOUT)
    finally:
        if client.poll() is None:
            client.kill()
    assert client.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    gone, alive = psutil.wait_procs(children, timeout=30)
    assert not alive, alive
    files = sorted(out.iterdir())
    assert 3 <= len(files) < 200
    assert all(f.name.startswith("f_") and not f.name.endswith(TEMP_SUFFIX) and is_complete(f) for f in files)


def test_cluster_options_are_checked_before_a_cluster_starts(animation, tmp_path):
    blend, _ = animation
    (tmp_path / "single.png").write_bytes(b"")
    in_the_way = str(tmp_path / "single.png" / "f_####.png")
    for args, message in ((["--workers", "-1"], "--workers must be >= 1, got -1"),
                          (["--workers", "2", "--threads", "0"], "--threads must be >= 1, got 0"),
                          (["--workers", "2", "--frames", "3-1"], "frames must look like"),
                          (["--workers", "2", "--samples", "-1"], "samples must be >= 1, got -1"),
                          (["--workers", "2", "--output", in_the_way], "single.png' is a file, not a folder")):
        done = durer_render(str(blend), *args)
        assert done.returncode == 2 and message in done.stderr, done.stderr
        assert "dask:" not in done.stderr


def test_sequential_resume_skips_complete_frames_only(animation, tmp_path):
    blend, sequential = animation
    for frame in (1, 2):
        (tmp_path / f"f_{frame:04d}.png").write_bytes(sequential[frame].read_bytes())
    (tmp_path / "f_0003.png").write_bytes(sequential[3].read_bytes()[:200])  # a half-written file
    stamp = (tmp_path / "f_0001.png").stat().st_mtime_ns
    files = batch.render_file(blend, frames="1-4", output=tmp_path / "f_####.png", resume=True)
    assert [f.name for f in files] == ["f_0003.png", "f_0004.png"]
    assert (tmp_path / "f_0001.png").stat().st_mtime_ns == stamp
    for frame in (3, 4):
        assert_same_image_file(tmp_path / f"f_{frame:04d}.png", sequential[frame])


def test_linked_library_data_travels_with_the_file(client, tmp_path):
    """A ball linked from another .blend by a relative path, which the workers' copy could not follow."""
    (tmp_path / "lib").mkdir()
    library = animated_blend(tmp_path / "lib" / "library.blend", frames=2)
    main = animated_blend(tmp_path / "main.blend", frames=2)
    bpy.ops.wm.open_mainfile(filepath=str(main))
    bpy.data.objects.remove(bpy.data.objects["Red"])
    bpy.ops.wm.save_mainfile()
    without = batch.render_file(main, frames="1", output=tmp_path / "without.png")[0]
    bpy.ops.wm.open_mainfile(filepath=str(main))
    with bpy.data.libraries.load(str(library), link=True, relative=True) as (source, target):
        target.objects = ["Red"]
    bpy.context.scene.collection.objects.link(target.objects[0])
    assert target.objects[0].library is not None
    bpy.ops.wm.save_mainfile()
    sequential = batch.render_file(main, frames="1-2", output=tmp_path / "seq" / "f_#.png")
    assert not np.array_equal(np.asarray(Image.open(sequential[0])), np.asarray(Image.open(without)))
    report = render_frames(main, "1-2", tmp_path / "dask" / "f_#.png", client=client, progress=False, log=None)
    assert sorted(report.written) == [1, 2] and not report.failed
    for f in sequential:
        assert_same_image_file(tmp_path / "dask" / f.name, f)
    bpy.ops.wm.open_mainfile(filepath=str(main))  # what went to the workers holds the ball itself
    (tmp_path / "shipped.blend").write_bytes(_self_contained_copy(bpy.context.scene.frame_end))
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "shipped.blend"))
    linked = [block.name for name in dir(bpy.data) if isinstance(getattr(bpy.data, name), bpy.types.bpy_prop_collection)
              for block in getattr(bpy.data, name) if getattr(block, "library", None) is not None]
    assert "Red" in bpy.data.objects and not linked and not list(bpy.data.libraries)


def test_frames_prepared_without_a_cluster_render_on_one_started_after(animation, client, tmp_path):
    """prepare_frames needs no cluster (as the render command runs it, before starting one): the
    outputs named, the copy made; run_frames then renders what render_frames renders."""
    blend, sequential = animation
    job = prepare_frames(blend, "2,3", tmp_path / "f_####.png")
    assert job.targets == {2: tmp_path / "f_0002.png", 3: tmp_path / "f_0003.png"}
    assert job.payload.startswith(b"BLENDER") and job.blend_name == blend.name
    assert not any(path.exists() for path in job.targets.values())
    report = run_frames(job, client=client, progress=False, log=None)
    assert sorted(report.written) == [2, 3]
    for frame in (2, 3):
        assert_same_image_file(tmp_path / f"f_{frame:04d}.png", sequential[frame])


def test_a_finished_run_resumes_to_nothing_and_no_resume_renders_again(animation, client, tmp_path):
    blend, sequential = animation
    first = render_frames(blend, "1-3", tmp_path / "f_####.png", client=client, progress=False, log=None)
    again = render_frames(blend, "1-3", tmp_path / "f_####.png", client=client, progress=False, log=None)
    assert sorted(first.written) == [1, 2, 3] and not again.written and sorted(again.skipped) == [1, 2, 3]
    assert again.summary.startswith("3 frames: 0 rendered, 3 skipped (complete), 0 failed in ")
    forced = render_frames(blend, "1-3", tmp_path / "f_####.png", client=client, resume=False, progress=False,
                           log=None)
    assert sorted(forced.written) == [1, 2, 3] and not forced.skipped
    for frame in (1, 2, 3):
        assert_same_image_file(tmp_path / f"f_{frame:04d}.png", sequential[frame])
