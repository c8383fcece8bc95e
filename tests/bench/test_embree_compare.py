"""bench/embree_compare.py: the driver's own logic (always), and the C++ benchmark's agreement check on
small workloads when Intel Embree 3 is installed (it is a benchmark dependency, never the package's)."""

from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "bench" / "embree_compare.py"


def _load_driver():
    spec = importlib.util.spec_from_file_location("embree_compare", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


bench = _load_driver()


def test_workloads_are_chosen_by_name_in_the_given_order():
    assert [w.name for w in bench.workloads_named("slab-sun-1m, cube-1")] == ["slab-sun-1m", "cube-1"]
    with pytest.raises(argparse.ArgumentTypeError, match=r"unknown workload\(s\) cube-2; choose from cube-1, "):
        bench.workloads_named("cube-1,cube-2")
    with pytest.raises(argparse.ArgumentTypeError, match="none given"):
        bench.workloads_named(" , ")


def test_quick_runs_trace_a_hundredth_of_the_spheres():
    by_name = {w.name: w for w in bench.WORKLOADS}
    assert by_name["cube-10m"].scaled(quick=True).spheres == 100_000
    assert by_name["cube-1k"].scaled(quick=True).spheres == 10
    assert by_name["cube-1"].scaled(quick=True).spheres == 1
    assert by_name["slab-1m"].scaled(quick=False).spheres == 1_000_000


def test_embree_is_found_where_cmake_would_look(tmp_path):
    config = tmp_path / "lib" / "cmake" / "embree-3.13.5"
    config.mkdir(parents=True)
    (config / "embree-config.cmake").write_text("")
    pattern = str(tmp_path / "lib" / "cmake" / "embree-3*" / "embree-config.cmake")
    assert bench.find_embree({}, [pattern]) == config
    assert bench.embree_version(config) == "3.13.5"
    assert bench.find_embree({}, [str(tmp_path / "nowhere" / "embree-config.cmake")]) is None
    # embree_DIR, as CMake reads it, wins over the usual places, and must hold the config file.
    assert bench.find_embree({"embree_DIR": str(config)}, []) == config
    assert bench.find_embree({"embree_DIR": str(tmp_path)}, [pattern]) is None


def test_the_report_names_the_native_flags_cmake_sets():
    assert bench.native_flags_text().split()[0] == "-march=native"  # the value, not the line around it


def test_durer_native_chooses_the_flags_as_for_the_package(tmp_path, monkeypatch):
    assert bench.native_flags({"DURER_NATIVE": "1"}) is True
    assert bench.native_flags({"DURER_NATIVE": "0"}) is False
    assert bench.native_flags({"DURER_NATIVE": "ON"}) is True
    # Unset: as the package was built (its CMake cache), so that the benchmark measures the core as installed;
    # set, the variable wins over the cache, as it would for a new package build.
    cache = tmp_path / "CMakeCache.txt"
    monkeypatch.setattr(bench, "package_cache", lambda: cache)
    for value, native in (("ON", True), ("OFF", False)):
        cache.write_text(f"# comment\nDURER_NATIVE:BOOL={value}\n")
        assert bench.native_flags({}) is native
        assert bench.native_flags({"DURER_NATIVE": "0" if native else "1"}) is not native
    monkeypatch.setattr(bench, "package_cache", lambda: None)
    assert bench.native_flags({}) is False  # no package build: CMake's default, OFF


def test_the_package_build_is_the_one_scikit_build_configured(tmp_path):
    # pyproject's build-dir, and a developer's own folders around it (a profiling build configured
    # like the package's but native, sorting after it): the package's is the one its tag names.
    assert (bench.ROOT / "build" / bench.wheel_tag() / "CMakeCache.txt").is_file()  # the set-up's build
    caches = {bench.wheel_tag(): "SKBUILD:STRING=2\nDURER_NATIVE:BOOL=OFF\n",
              "prof": "SKBUILD:BOOL=ON\nDURER_NATIVE:BOOL=ON\n", "cpp-tests": "DURER_NATIVE:BOOL=ON\n"}
    for folder, lines in caches.items():
        (tmp_path / "build" / folder).mkdir(parents=True)
        (tmp_path / "build" / folder / "CMakeCache.txt").write_text("# comment\n" + lines)
    cache = bench.package_cache(tmp_path)
    assert cache == tmp_path / "build" / bench.wheel_tag() / "CMakeCache.txt"
    assert bench.cache_value(cache, "DURER_NATIVE") == "OFF" and bench.cache_value(cache, "CMAKE_CXX_COMPILER") is None
    assert bench.package_cache(tmp_path / "elsewhere") is None


def test_without_embree_the_driver_says_how_to_install_it(tmp_path):
    env = {**os.environ, "embree_DIR": str(tmp_path)}  # a folder without embree-config.cmake
    run = subprocess.run([sys.executable, str(SCRIPT), "--quick"], env=env, capture_output=True, text=True, timeout=60)
    assert run.returncode == 2
    assert "apt-get install libembree-dev" in run.stderr and run.stdout == ""


def _report(spheres: int = 1_000_000, disagreeing: int = 13) -> dict:
    """A report as durer_embree_bench writes it, with round numbers."""
    agreement = {
        "pixels": 2_073_600, "hit_mismatches": disagreeing, "both_hit": 2_000_000, "depth_mismatches": 0,
        "lit_mismatches": 0, "passed": disagreeing <= 2073,
    }
    return {
        "spheres": spheres,
        "rays": {"embree": 2_073_600, "durer_float": 2_073_600, "durer_double": 2_073_600},
        "embree": {"build_ms": [12.0, 10.0, 11.0], "trace_ms": [90.0, 100.0, 110.0], "pose_ms": [100.0] * 3,
                   "frame_ms": [300.0, 310.0, 290.0]},
        "durer_float": {"first_ms": [111.0, 120.0, 100.0], "cached_ms": [40.0, 50.0, 60.0], "pose_ms": [80.0] * 3,
                        "frame_ms": [150.0] * 3},
        "durer_double": {"first_ms": [222.0, 222.0, 222.0], "cached_ms": [200.0, 200.0, 200.0], "pose_ms": [250.0] * 3,
                         "frame_ms": [600.0] * 3},
        "agreement": {"float": agreement, "double": agreement},
        "memory": {
            "embree": {"retained_bytes": 56_000_000, "peak_bytes": 60_000_000},
            "durer_float": {"retained_bytes": 120_000_000, "peak_bytes": 140_000_000, "scene_bytes": 40_000_000},
            "durer_double": {"retained_bytes": 186_000_000, "peak_bytes": 220_000_000, "scene_bytes": 40_000_000},
            "process_peak_rss_bytes": 300 * 2**20,
        },
    }


def test_a_row_shows_medians_ratios_agreement_and_memory():
    row = dict(zip(bench.HEADER, bench.row_cells(bench.Result(bench.WORKLOADS[3], _report(), 0.05, 0)), strict=True))
    assert row["Spheres"] == "1,000,000"
    assert row["Embree build + trace ms"] == "11 + 100"
    assert row["Embree Mrays/s"] == "20.7"  # 2,073,600 rays in 100 ms
    assert row["Dürer float ms: cached (first)"] == "50 (111)"
    assert row["Dürer Mrays/s f / d"] == "41.5 / 10.4"
    assert row["Dürer / Embree f / d"] == "2.00x / 0.50x"  # Embree's 100 ms trace over Dürer's cached render
    assert row["First render f / d"] == "1.00x / 0.50x"  # Embree's 111 ms build + trace over Dürer's first render
    assert row["New pose ms: Embree, Dürer f / d"] == "100, 80 / 250"
    assert row["New pose f / d"] == "1.25x / 0.40x"  # Embree's trace of the pose over Dürer's render with its view
    assert row["Moved frame ms: Embree, Dürer f / d"] == "300, 150 / 600"
    assert row["Moved frame f / d"] == "2.00x / 0.50x"  # Embree's refit + trace over Dürer's move + render
    assert row["Hits agree f / d"] == "99.999% / 99.999%"
    assert row["B/sphere: Dürer f / d + scene (Embree)"] == "80 / 146 + 40 (56)"
    assert row["Peak RSS MB"] == "300" and row["Others"] == "0.05"


def test_with_a_sun_the_row_also_shows_how_many_pixels_agree_on_light():
    report = _report()
    report["agreement"]["float"] = {**report["agreement"]["float"], "lit_mismatches": 2074}  # 0.1 % of 2,073,600
    cell = bench.agreement_cell(report)
    assert cell == "99.999% / 99.999%; light 99.900% / 100.000%"


def test_a_row_whose_images_disagree_shows_no_timings():
    result = bench.Result(bench.WORKLOADS[3], _report(disagreeing=5000), 0.5, 3)
    row = dict(zip(bench.HEADER, bench.row_cells(result), strict=True))
    assert not result.agrees
    assert row["Hits agree f / d"] == "99.759% FAIL / 99.759% FAIL"
    assert row["Dürer / Embree f / d"] == "-" and row["Embree build + trace ms"] == "-"
    assert row["Others"] == "0.50 !"
    text, _ = bench.report([result], ["Machine: test"], [])
    assert "DISAGREEMENT in cube-1m" in text


def test_given_rays_have_no_pose_or_frame_and_a_pose_or_frame_disagreement_stops_the_timings():
    report = _report()
    for tracer in ("embree", "durer_float", "durer_double"):
        report[tracer]["pose_ms"] = report[tracer]["frame_ms"] = []  # given rays: no poses or frames timed
    row = dict(zip(bench.HEADER, bench.row_cells(bench.Result(bench.WORKLOADS[8], report, 0.0, 0)), strict=True))
    assert row["Moved frame ms: Embree, Dürer f / d"] == "-" and row["Moved frame f / d"] == "-"
    assert row["New pose ms: Embree, Dürer f / d"] == "-" and row["New pose f / d"] == "-"
    moved = _report()
    moved["frame_agreement"] = {"float": {**moved["agreement"]["float"], "passed": False}, "double": moved["agreement"]["double"]}
    assert not bench.Result(bench.WORKLOADS[3], moved, 0.0, 3).agrees
    posed = _report()
    posed["pose_agreement"] = {"float": posed["agreement"]["float"], "double": {**posed["agreement"]["double"], "passed": False}}
    assert not bench.Result(bench.WORKLOADS[3], posed, 0.0, 3).agrees
    assert bench.Result(bench.WORKLOADS[3], _report(), 0.0, 0).agrees


def test_memory_per_sphere_is_left_out_for_small_scenes():
    row = bench.row_cells(bench.Result(bench.WORKLOADS[1], _report(spheres=1000), None, 0))
    assert row[bench.HEADER.index("B/sphere: Dürer f / d + scene (Embree)")] == "-"
    assert row[-1] == "n/a"


# --- the C++ benchmark itself --------------------------------------------------------------------------
EMBREE = bench.find_embree()


@pytest.mark.slow
@pytest.mark.skipif(EMBREE is None, reason="Intel Embree 3 is not installed (a benchmark dependency: libembree-dev)")
def test_the_benchmark_checks_that_embree_and_durer_agree(import_bench):
    executable = bench.build_executable(EMBREE, bench.native_flags())
    for workload in (bench.Workload("cube-1k", "cube", 1000), bench.Workload("slab-sun", "slab-sun", 3000),
                     bench.Workload("bounce", "bounce", 20_000)):
        result = bench.run_workload(executable, workload, (160, 96), runs=2)
        report = result.report
        assert result.exit_code == 0 and result.agrees, report["agreement"]
        assert report["spheres"] == workload.spheres
        assert all(len(report["embree"][key]) == 2 for key in ("build_ms", "trace_ms"))
        frames = 0 if workload.kind == "bounce" else 2  # given rays leave the spheres: no frame to move
        assert len(report["embree"]["frame_ms"]) == len(report["durer_double"]["frame_ms"]) == frames
        assert len(report["embree"]["pose_ms"]) == len(report["durer_float"]["pose_ms"]) == frames
        assert ("frame_agreement" in report) == ("pose_agreement" in report) == (frames > 0)
        for precision in ("float", "double"):
            agreement = report["agreement"][precision]
            assert agreement["pixels"] == 160 * 96
            assert agreement["hit_mismatches"] + agreement["depth_mismatches"] <= 0.001 * 160 * 96
            assert report["memory"][f"durer_{precision}"]["retained_bytes"] > 0
        if workload.kind in ("cube", "bounce"):
            assert report["rays"]["embree"] == report["rays"]["durer_double"] == 160 * 96
            if workload.kind == "bounce":  # rays leaving spheres: a fair share meets another
                assert 0.1 * 160 * 96 < report["agreement"]["double"]["both_hit"] < 0.9 * 160 * 96
        else:  # camera rays + one shadow ray per hit facing the sun, counted by each tracer
            shadow = {name: rays - 160 * 96 for name, rays in report["rays"].items()}
            assert shadow["embree"] > 0.3 * 160 * 96
            assert abs(shadow["embree"] - shadow["durer_double"]) <= 0.001 * shadow["embree"]
    # The shadow and reflection rays of bench/secondary_rays.py's colour render at that size, under
    # each of its lights: as many as the render traces in the same scene drawn by numpy's generator
    # (seeds vary them by ~0.5 %).
    import durer

    secondary_rays = import_bench("secondary_rays")
    shadows = {}
    for light, kind in secondary_rays.EMBREE_KINDS.items():
        secondary = bench.run_workload(executable, bench.Workload(kind, kind, 20_000), (160, 96), runs=1)
        assert secondary.agrees, secondary.report["agreement"]
        stats = durer.render(secondary_rays.secondary_scene(20_000, light=light), secondary_rays.CAMERA, 160, 96,
                             passes=("color",)).stats
        render_rays = stats["shadow_rays"] + stats["reflection_rays"]
        assert abs(secondary.report["rays"]["embree"] - render_rays) <= 0.03 * render_rays
        assert secondary.report["rays"]["embree"] == secondary.report["rays"]["durer_double"]
        shadows[light] = secondary.report["agreement"]["double"]["both_hit"]
    assert shadows["sun"] != shadows["point"]  # each lit by its own light
    bad = subprocess.run([str(executable), "--workload", "torus"], capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "unknown workload 'torus'" in bad.stderr
    # A pixel looking past every sphere and the ground: no secondary ray to trace, said so.
    empty = subprocess.run([str(executable), "--workload", "secondary", "--spheres", "1", "--size", "1x1"],
                           capture_output=True, text=True, timeout=60)
    assert empty.returncode == 2 and "meet nothing: no shadow or reflection rays" in empty.stderr
