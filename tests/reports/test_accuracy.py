"""The `python -m durer accuracy` report (durer.reports): its error measures, slope fit, page and plots, and the quick run."""

from __future__ import annotations

import math

import numpy as np
import pytest

import durer
from durer.render import PRECISIONS, SAMPLERS, SPHERE_METHODS
from durer.reports import numerics
from durer.reports.accuracy.cli import main, write_report
from durer.reports.accuracy.measure import (
    AAPoint,
    AntiAliasing,
    Config,
    EffectRow,
    PresetRow,
    Report,
    Timing,
    measure_antialiasing,
    measure_effects,
    measure_timings,
    oracle_counts,
    oracle_samples,
)
from durer.reports.accuracy.targets import targets
from durer.reports.errors import depth_differences, fit_slope, pixel_errors, rmse, worst_pixel
from durer.reports.scenes import EFFECT_ROWS, FLAT_ROW, edge_scene


# --- error measures -------------------------------------------------------------------------------

def test_rmse_and_worst_pixel_by_hand():
    reference = np.zeros((2, 2, 4), np.float32)
    image = np.zeros((2, 2, 4), np.float32)
    image[0, 0, :3] = 1.0                   # pixel error 1
    image[1, 1, :3] = (2.0, -2.0, 2.0)      # pixel error 2 (sign does not matter)
    image[0, 1, 3] = 5.0                    # alpha is not colour: ignored
    assert pixel_errors(image, reference) == pytest.approx(np.array([[1.0, 0.0], [0.0, 2.0]]))
    assert rmse(image, reference) == pytest.approx(math.sqrt((1 + 4) / 4))
    assert worst_pixel(image, reference) == pytest.approx(2.0)
    # One channel off by 3 in one of 3 pixels: per-pixel RMS sqrt(9/3), image RMSE sqrt(3/3).
    rgb = np.zeros((1, 3, 3))
    rgb[0, 2, 1] = 3.0
    assert worst_pixel(rgb, np.zeros_like(rgb)) == pytest.approx(math.sqrt(3))
    assert rmse(rgb, np.zeros_like(rgb)) == pytest.approx(1.0)
    # Single-channel images (a depth pass) are compared value by value.
    assert rmse(np.array([[3.0, 4.0]]), np.zeros((1, 2))) == pytest.approx(math.sqrt(12.5))
    assert rmse(image, image) == 0.0
    with pytest.raises(ValueError, match="shapes differ"):
        rmse(image, reference[:1])


def test_depth_differences_by_hand():
    reference = np.array([[1.0, 2.0, np.inf, 4.0]])
    depth = np.array([[1.5, 2.0, 3.0, np.inf]])
    absolute, relative, disagree = depth_differences(depth, reference)
    assert absolute == pytest.approx(0.5) and relative == pytest.approx(0.5) and disagree == 2


def test_fit_slope_recovers_known_slopes():
    spp = np.array([1, 4, 16, 64, 256])
    for slope in (-0.5, -0.75, -1.0, 0.0):
        assert fit_slope(spp, 0.3 * spp**slope) == pytest.approx(slope, abs=1e-12)
    noisy = 0.3 * spp**-0.75 * np.exp(np.random.default_rng(5).normal(0, 0.02, spp.size))
    assert fit_slope(spp, noisy) == pytest.approx(-0.75, abs=0.03)
    # Zeros and non-finite points are left out; too few points or no spread give nan.
    assert fit_slope([1, 4, 16, 64], [1.0, 0.5, 0.0, np.nan]) == pytest.approx(-0.5)
    assert math.isnan(fit_slope([4], [0.5]))
    assert math.isnan(fit_slope([4, 4], [0.5, 0.4]))


def test_oracle_counts_are_powers_of_two_or_quarter_steps_between_them():
    assert oracle_counts(64, fine=False) == [1, 2, 4, 8, 16, 32, 64]
    assert oracle_counts(64, fine=True) == [1, 2, 3, 4, 5, 6, 7, 8, 10, 12, 14, 16, 20, 24, 28, 32, 40, 48, 56, 64]
    assert oracle_counts(3, fine=True) == [1, 2, 3] and oracle_counts(0, fine=True) == []


def test_oracle_samples_by_hand():
    # Two pixels: A's error falls 1 -> 0.5 -> 0.1 at 1, 2, 4 samples; B is exact from 1 sample.
    errors = {1: np.array([[1.0, 0.0]]), 2: np.array([[0.5, 0.0]]), 4: np.array([[0.1, 0.0]])}
    # RMSE 0.5 / sqrt(2) and worst 0.5 need A at 2 samples, B at 1: 1.5 per pixel.
    assert oracle_samples(errors, 0.5 / math.sqrt(2), 0.5) == pytest.approx(1.5)
    # A worst pixel of 0.2 forces A to 4 samples; no target forces B above 1.
    assert oracle_samples(errors, 1.0, 0.2) == pytest.approx(2.5)
    assert math.isinf(oracle_samples(errors, 0.05, 1.0))  # the RMSE needs A below 0.07: never
    assert math.isinf(oracle_samples(errors, 1.0, 0.05))  # and so does this worst pixel


def test_configs():
    quick, full = Config.quick_config(), Config.full()
    assert quick.quick and quick.aa_size == (80, 45) and quick.spps == (1, 4, 16) and quick.reference_spp == 256
    assert quick.runs == 1 and quick.baselines == ((16, 1 / 3),) and quick.adaptive_max_spps == (16,)
    assert full.spps == (1, 4, 16, 64, 256) and full.reference_spp == 4096 and full.runs == 5
    assert full.baselines == ((64, 1 / 3), (256, 1 / 4)) and full.adaptive_max_spps == (64, 256)
    assert full.min_spps == (1, 2, 4, 8) and 0.005 in full.target_errors
    assert full.samplers == SAMPLERS


def test_edge_scene_is_many_small_spheres():
    scene, camera = edge_scene(spheres=300)
    assert scene.sphere_count == 300 and scene.plane_count == 1 and scene.light_count == 1
    assert all(component != 0 for component in camera.direction)


# --- the page, from made-up measurements (no rendering) -------------------------------------------

def synthetic_aa(scene: str, slopes: dict[str, float], spps=(1, 4, 16, 64, 256)) -> AntiAliasing:
    points = []
    for sampler, slope in slopes.items():
        for spp in spps:
            taken = spp / 2 if sampler == "adaptive" else spp
            points.append(AAPoint(sampler, spp, taken, 0.1 * taken**slope, 0.5 * taken**slope, 0.1 * taken))
    return AntiAliasing(scene, f"the {scene} scene", 32, 18, 1024, 50.0, points)


def synthetic_report(config: Config) -> Report:
    slopes = {"center": 0.0, "random": -0.5, "stratified": -0.75, "sobol": -1.0, "adaptive": -0.75}
    showcase = synthetic_aa("showcase", slopes)
    # Adaptive reaches stratified-64's RMSE (0.1 * 64^-0.75) and worst pixel (0.5 * 64^-0.75) in a
    # quarter of its 6.4 ms, and estimates its error within 1.2x.
    counts = np.full((18, 32), 4, np.int32)
    counts[5:9, 10:20] = 256
    showcase.sweep = [AAPoint("adaptive", 256, 20.0, 0.1 * 64**-0.75 * 0.9, 0.5 * 64**-0.75, 1.6, 0.01, 4,
                              0.1 * 64**-0.75 * 1.1, np.zeros((18, 32, 4), np.float32), counts),
                      AAPoint("adaptive", 256, 5.0, 0.05, 0.3, 0.5, 0.04, 8, 0.06)]
    edges = synthetic_aa("edges", slopes)
    edges.edge_share = 0.57
    edges.oracle = {64: 26.2, 256: float("inf")}
    edges.oracle_fine = {64: 19.2, 256: 200.0}
    timings = [Timing(scene, p, m, 10.0 if p == "double" else 7.0, 1_000_000, 0.0 if p == "double" else 1e-6, 0.0,
                      0.0, 0.0, 0) for scene in ("showcase", "edges") for p in PRECISIONS
               for m in SPHERE_METHODS]
    sweep = numerics.sweep(ratios=numerics.RATIOS[:2])
    effects = [EffectRow(name, 1.0 + i, ("flat",), 0) for i, (name, _, _) in enumerate(EFFECT_ROWS)]
    presets = [PresetRow("draft", {"spp": 1, "sampler": "center"}, 0.5, 1.0, 0.04, 0.3),
               PresetRow("final", {"spp": 64, "sampler": "adaptive"}, 5.0, 20.0, 0.004, 0.03)]
    return Report(config, "test machine", "2026-01-01 00:00 UTC", "python -m durer accuracy --test", 2,
                  [showcase, edges], timings, sweep, effects, presets, seconds=1.0)


def test_targets_from_measurements():
    report = synthetic_report(Config.full())
    showcase64, showcase256, edges64, edges256, estimate, slope = targets(report)
    assert showcase64.met is True and "0.25 x the time" in showcase64.figure and "1/3" in showcase64.name
    assert showcase256.met is False and "1/4" in showcase256.name  # 0.1 * 256^-0.75 is out of its reach
    # On the edge scene only adaptive at max 256 spp (128 taken, 12.8 ms) reaches it: twice its time,
    # and the figure says how many of the scene's pixels hold an edge.
    assert edges64.met is False and "= 2.00 x the time" in edges64.figure
    assert "would need 26.2 samples/pixel = 0.41 of stratified's" in edges64.figure
    assert "(with counts in quarter steps between powers of two: 19.2 = 0.30)" in edges64.figure
    assert "no choice of power-of-two Sobol counts per pixel reaches both" in edges256.figure
    assert "(with counts in quarter steps between powers of two: 200.0 = 0.78)" in edges256.figure
    assert estimate.met is True and "from 1.20 to 1.22 over 2 renders" in estimate.figure
    assert slope.met is True and "sobol -1.00, random -0.50" in slope.figure
    report.antialiasing[0].sweep[1].estimated_rmse = 0.05 * 1.6
    assert targets(report)[4].met is False
    # Adaptive never as good as the baseline, sobol no steeper than random: not met.
    for aa in report.antialiasing:
        aa.sweep = []
        aa.points = [p for p in aa.points if p.sampler != "adaptive"] + [
            AAPoint("adaptive", 64, 10.0, 1.0, 1.0, 1.0)]
        for p in aa.points:
            if p.sampler == "sobol":
                p.rmse = 0.1 * p.spp**-0.4
    showcase64, *_, estimate, slope = targets(report)
    assert showcase64.met is False and "no adaptive setting" in showcase64.figure
    assert estimate.met is None and slope.met is False


def test_report_writes_sections_tables_and_plots(tmp_path):
    report = synthetic_report(Config.full())
    output = tmp_path / "docs" / "accuracy.md"
    written = write_report(report, output)
    names = {p.name for p in written}
    assert names == {"accuracy.md", "accuracy-aa-showcase.png", "accuracy-aa-edges.png", "accuracy-adaptive-showcase.png",
                     "accuracy-sphere-methods.png", "accuracy-presets.png"}
    for path in written[1:]:
        assert path.parent == output.parent and path.stat().st_size > 10_000
    text = output.read_text()
    for heading in ("# Accuracy and what it costs", "## Targets", "## Anti-aliasing", "### Showcase", "### Edges",
                    "## Precision: float vs double", "## Sphere method: algebraic vs geometric vs robust",
                    "## Effects: what each adds in time", "## Presets"):
        assert f"\n{heading}\n" in f"\n{text}"
    for line in ("- **Machine:** test machine", "- **Date:** 2026-01-01 00:00 UTC",
                 "- **Command:** `python -m durer accuracy --test`"):
        assert line in text
    for image in names - {"accuracy.md"}:
        assert f"]({image})" in text
    # Tables: the slopes (fitted, not made up), the points, the adaptive sweep, precision, methods, effects, presets.
    assert "| sobol | -1.00 |" in text and "| random | -0.50 |" in text and "| center | +0.00 |" in text
    assert "| sampler | spp | samples/pixel | RMSE | worst pixel | ms | ms / stratified same spp |" in text
    assert "| adaptive | 64 | 32.0 |" in text
    assert "| 256 | 4 | 0.01 | 20.0 | 3.98e-03 | 4.86e-03 | 1.22 | 2.21e-02 | 1.6 | 0.25 | 0.06 |" in text
    assert "57% of this scene's pixels hold an edge" in text
    assert "64-spp stratified's RMSE and worst pixel: 26.2 samples/pixel (0.41 of its samples)" in text
    assert "the same oracle would need 64-spp stratified's: 19.2 (0.30); 256-spp stratified's: 200.0 (0.78)." in text
    assert "| showcase | 10.0 | 7.0 | 0.700 |" in text
    assert "| edges | double | algebraic | 10.0 | 1.000 |" in text
    assert "| double | robust |" in text and "Worst relative error of t" in text
    assert "| + refraction | 7.0 | +1.0 | 3.50 |" in text
    assert "| draft | `spp=1, sampler='center'` | 1.0 |" in text
    assert "**yes**" in text


def test_report_without_presets(tmp_path):
    report = synthetic_report(Config.quick_config())
    report.presets = []
    written = write_report(report, tmp_path / "accuracy.md")
    assert "accuracy-presets.png" not in {p.name for p in written}
    text = (tmp_path / "accuracy.md").read_text()
    assert "quick mode" in text and "](accuracy-presets.png)" not in text
    presets = text.split("## Presets", 1)[1]
    assert "| preset | settings |" in presets and "| draft |" not in presets


# --- measurements on tiny images ------------------------------------------------------------------

def test_antialiasing_measurement_on_a_tiny_image():
    scene, camera = durer.showcase_scene()
    aa = measure_antialiasing("showcase", "the showcase", scene, camera, 32, 18, (1, 16), 64, runs=1,
                              target_errors=(0.02,), adaptive_max_spps=(16,), min_spps=(2, 4))
    assert [(p.sampler, p.spp) for p in aa.points] == [(s, n) for s in SAMPLERS for n in (1, 16)]
    assert [(p.spp, p.min_spp, p.target_error) for p in aa.sweep] == [(16, 2, 0.02), (16, 4, 0.02)]
    for p in aa.sweep:
        assert p.samples.shape == (18, 32) and p.samples.min() >= p.min_spp and p.color.shape == (18, 32, 4)
        # Camera rays a pixel: its samples, and at most one probe of its stratum's outside.
        assert p.samples.mean() <= p.samples_per_pixel <= p.samples.mean() + 1
        assert 0 < p.estimated_rmse and 0 < p.rmse
    assert 0 < aa.edge_share < 1
    assert aa.reference.shape == (18, 32, 4)
    by = {(p.sampler, p.spp): p for p in aa.points}
    # Every centre sample is the same: more of them change nothing.
    assert by["center", 16].rmse == by["center", 1].rmse
    for sampler in ("random", "stratified", "sobol"):
        assert by[sampler, 16].samples_per_pixel == 16
        assert by[sampler, 16].rmse < by[sampler, 1].rmse
        assert 0 < by[sampler, 16].rmse <= by[sampler, 16].worst
    assert 1 <= by["adaptive", 16].samples_per_pixel <= 16
    assert all(p.ms > 0 for p in aa.points)


def test_timings_and_effects_on_tiny_images():
    scene, camera = durer.showcase_scene()
    edges, edges_camera = edge_scene(spheres=200)
    rows = measure_timings([("showcase", scene, camera), ("edges", edges, edges_camera)], 24, 16, 1, runs=1)
    assert len(rows) == 2 * 2 * 3
    for row in rows:
        assert row.rays == 24 * 16 and row.ns_per_ray > 0
        if row.precision == "double" and row.method == "robust":
            assert row.rmse_vs_double_robust == 0 and row.max_depth_difference == 0 and row.hit_disagreements == 0
    float_robust = next(r for r in rows if r.scene == "showcase" and r.precision == "float" and r.method == "robust")
    assert float_robust.rmse_vs_double_robust < 1e-4 and float_robust.max_relative_depth_difference < 1e-5
    effects = measure_effects(camera, 24, 16, runs=1)
    assert [r.name for r in effects] == [name for name, _, _ in EFFECT_ROWS]
    assert effects[FLAT_ROW].effects == ("flat",) and effects[FLAT_ROW].secondary_rays == 0
    assert "refraction" in effects[-1].effects and effects[-1].secondary_rays > 0


def test_quick_command(tmp_path, capsys):
    output = tmp_path / "accuracy.md"
    assert main(["--quick", "--output", str(output)]) == 0
    text = output.read_text()
    assert "quick mode" in text and "| stratified | 16 | 16.0 |" in text
    assert "\n## Ambient occlusion\n" in text and "| 16 |" in text.split("## Ambient occlusion", 1)[1]
    for name in ("aa-showcase", "aa-edges", "sphere-methods"):
        assert (tmp_path / f"accuracy-{name}.png").stat().st_size > 10_000
    out = capsys.readouterr().out
    assert "target: adaptive reaches" in out and f"wrote {output}" in out


def test_a_page_that_could_not_be_written_is_refused_before_measuring(tmp_path, capsys, monkeypatch):
    import durer.reports.accuracy.cli as cli

    monkeypatch.setattr(cli, "measure", lambda *args: pytest.fail("measured before the --output check"))
    (tmp_path / "a_file").write_text("")
    with pytest.raises(SystemExit) as info:
        main(["--quick", "--output", str(tmp_path / "a_file" / "accuracy.md")])
    assert info.value.code == 2
    assert capsys.readouterr().err.endswith(f"error: --output {tmp_path / 'a_file' / 'accuracy.md'}: "
                                            f"'{tmp_path / 'a_file'}' is a file, not a folder\n")


def test_command_is_registered():
    from durer.__main__ import COMMANDS

    assert "accuracy" in COMMANDS
