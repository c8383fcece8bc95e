"""bench/secondary_rays.py counts every ray the render traces: its rows are the core's own
counters, summed, for the scene it describes."""

from __future__ import annotations

import numpy as np
import pytest

import durer


@pytest.fixture
def bench(import_bench):
    return import_bench("secondary_rays")


def test_scene_is_the_issues(bench):
    scene = bench.secondary_scene(spheres=500, seed=1)
    assert scene.object_count == 501  # the spheres and the ground plane
    result = durer.render(scene, bench.CAMERA, 32, 18, passes=("color",))
    assert set(result.stats["effects"]) == {"diffuse", "shadows", "reflection"}


def test_rows_sum_the_core_counters(bench):
    scene = bench.secondary_scene(spheres=2000, seed=1)
    rows, _ = bench.measure(scene, (48, 27), runs=1, threads=2)
    assert [(r.mode, r.precision) for r in rows] == [
        ("depth only", "double"), ("colour", "double"), ("depth only", "float"), ("colour", "float")]
    for row in rows:
        stats = durer.render(scene, bench.CAMERA, 48, 27, passes=bench.MODES[row.mode], precision=row.precision,
                             threads=2).stats
        assert row.counts == {k: stats[k] for k in (*bench.RAY_KINDS, "intersection_tests")}
        assert row.rays == stats["rays"] + stats["shadow_rays"] + stats["reflection_rays"] + stats["refraction_rays"]
        assert row.counts["rays"] == 48 * 27
        secondary = row.rays - row.counts["rays"]
        assert (secondary > 0) == (row.mode == "colour")
        assert row.mrays_per_s(row.median_ms) == pytest.approx(row.rays / (row.median_ms / 1000) / 1e6)
        cpu_seconds = row.milliseconds[0] / 1000 * row.cpu_use[0]
        assert row.mrays_per_cpu_second == pytest.approx(row.rays / cpu_seconds / 1e6)
        assert np.isclose(row.tests_per_ray, stats["intersection_tests"] / row.rays)
