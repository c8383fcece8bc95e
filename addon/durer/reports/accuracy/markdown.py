"""The accuracy report as a Markdown page, and as a few lines for the terminal."""

from __future__ import annotations

import math

from ...render import PRECISIONS, SPHERE_METHODS
from .. import numerics
from ..scenes import FLAT_ROW
from .measure import REFERENCE_SAMPLER, SEED, AntiAliasing, BudgetPoint, EffectRow, PresetRow, Report
from .occlusion import markdown_section
from .targets import targets


def _slope(value: float) -> str:
    """A fitted slope, signed, two decimals; one that rounds to zero (a flat curve, fitted as ±1e-17
    by one machine's arithmetic or another's) as +0.00."""
    return f"{round(value, 2) + 0.0:+.2f}"


def _fmt(value: float, digits: int = 2) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "—"
    if value == 0:
        return "0"
    return f"{value:.{digits}e}"


def _yes(met: bool | None) -> str:
    return {True: "**yes**", False: "no", None: "—"}[met]


def aa_tables(aa: AntiAliasing) -> str:
    """The scene's slope table and its long table of points."""
    samplers = list(dict.fromkeys(p.sampler for p in aa.points))
    stratified = {p.spp: p for p in aa.points if p.sampler == "stratified"}
    lines = ["| sampler | fitted slope of log RMSE vs log spp | RMSE at the most samples | worst pixel there |",
             "| --- | --- | --- | --- |"]
    for s in samplers:
        last = max((p for p in aa.points if p.sampler == s), key=lambda p: p.spp)
        slope = aa.slope(s)
        note = " (vs samples taken)" if s == "adaptive" else ""
        lines.append(f"| {s} | {_slope(slope)}{note} | {_fmt(last.rmse)} | {_fmt(last.worst)} |" if not math.isnan(slope)
                     else f"| {s} | — | {_fmt(last.rmse)} | {_fmt(last.worst)} |")
    lines += ["", "| sampler | spp | samples/pixel | RMSE | worst pixel | ms | ms / stratified same spp |",
              "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for p in aa.points:
        base = stratified.get(p.spp)
        ratio = f"{p.ms / base.ms:.2f}" if base and base.ms > 0 else "—"
        lines.append(f"| {p.sampler} | {p.spp} | {p.samples_per_pixel:.1f} | {_fmt(p.rmse)} | {_fmt(p.worst)} | "
                     f"{p.ms:.1f} | {ratio} |")
    return "\n".join(lines)


def sweep_table(aa: AntiAliasing, baselines: tuple[tuple[int, float], ...]) -> str:
    """Adaptive's sweep: what each setting took and reached, its own error estimate, and its time
    against each stratified baseline."""
    bases = [(spp, aa.point("stratified", spp)) for spp, _ in baselines]
    head = " | ".join(f"time / stratified {spp}" for spp, _ in bases)
    lines = [f"| max spp | min_spp | target_error | samples/pixel | RMSE | estimated RMSE | estimated / measured | "
             f"worst pixel | ms | {head} |", "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | "
             + " | ".join("---:" for _ in bases) + " |"]
    for p in aa.sweep:
        ratios = " | ".join(f"{p.ms / b.ms:.2f}" if b and b.ms > 0 else "—" for _, b in bases)
        estimate = p.estimated_rmse if p.estimated_rmse is not None else float("nan")
        factor = f"{estimate / p.rmse:.2f}" if p.rmse > 0 and not math.isnan(estimate) else "—"
        lines.append(f"| {p.spp} | {p.min_spp} | {p.target_error:g} | {p.samples_per_pixel:.1f} | {_fmt(p.rmse)} | "
                     f"{_fmt(estimate)} | {factor} | {_fmt(p.worst)} | {p.ms:.1f} | {ratios} |")
    return "\n".join(lines)


def _samples(n: float) -> str:
    return "no choice reaches it" if math.isinf(n) else f"{n:.1f}"


def budget_table(rows: list[BudgetPoint]) -> str:
    lines = ["| time_limit | ms | stopped by the limit | samples/pixel | RMSE | estimated RMSE | worst pixel |",
             "| ---: | ---: | --- | ---: | ---: | ---: | ---: |"]
    for r in rows:
        limit = "none" if r.time_limit is None else f"{r.time_limit * 1000:.1f} ms"
        lines.append(f"| {limit} | {r.ms:.1f} | {'yes' if r.reached else 'no'} | {r.samples_per_pixel:.1f} | "
                     f"{_fmt(r.rmse)} | {_fmt(r.estimated_rmse)} | {_fmt(r.worst)} |")
    return "\n".join(lines)


def precision_tables(report: Report) -> str:
    rows = [t for t in report.timings if t.method == "robust"]
    by = {(t.scene, t.precision): t for t in rows}
    lines = ["| scene | double ns/ray | float ns/ray | float / double time | colour RMSE float vs double | "
             "worst pixel | max abs depth difference | max relative depth difference | pixels hit in one only |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for scene in dict.fromkeys(t.scene for t in rows):
        d, f = by[scene, "double"], by[scene, "float"]
        lines.append(f"| {scene} | {d.ns_per_ray:.1f} | {f.ns_per_ray:.1f} | {f.ms / d.ms:.3f} | "
                     f"{_fmt(f.rmse_vs_double_robust)} | {_fmt(f.worst_vs_double_robust)} | "
                     f"{_fmt(f.max_depth_difference)} | {_fmt(f.max_relative_depth_difference)} | "
                     f"{f.hit_disagreements} |")
    lines += ["", "On the hard-case sweep (`durer.reports.numerics.sweep()`: a unit sphere at distance/radius 10…10⁹, "
              f"{numerics.RAYS_PER_RATIO} rays per distance, exact t from mpmath), over every distance:", "",
              "| precision | method | worst relative error of t | worst error along the ray (radii) | false hits | "
              "false misses |", "| --- | --- | ---: | ---: | ---: | ---: |"]
    for precision in PRECISIONS:
        for method in SPHERE_METHODS:
            sel = [r for r in report.sweep if r.precision == precision and r.method == method]
            if not sel:
                continue
            worst = max((r.max_error for r in sel if not math.isnan(r.max_error)), default=float("nan"))
            radii = max((r.max_error_radii for r in sel if not math.isnan(r.max_error_radii)), default=float("nan"))
            lines.append(f"| {precision} | {method} | {_fmt(worst, 1)} | {_fmt(radii, 1)} | "
                         f"{sum(r.false_hits for r in sel)} | {sum(r.false_misses for r in sel)} |")
    return "\n".join(lines)


def method_tables(report: Report) -> str:
    by = {(t.scene, t.precision, t.method): t for t in report.timings}
    lines = ["| scene | precision | method | ns/ray | time / robust | colour RMSE vs robust double | "
             "pixels hit in one only |", "| --- | --- | --- | ---: | ---: | ---: | ---: |"]
    for t in report.timings:
        robust = by[t.scene, t.precision, "robust"]
        lines.append(f"| {t.scene} | {t.precision} | {t.method} | {t.ns_per_ray:.1f} | {t.ms / robust.ms:.3f} | "
                     f"{_fmt(t.rmse_vs_double_robust)} | {t.hit_disagreements} |")
    return "\n".join(lines)


def effects_table(rows: list[EffectRow]) -> str:
    flat = rows[FLAT_ROW].ms if len(rows) > FLAT_ROW else rows[0].ms
    lines = ["| render | ms | added ms | time / flat | effects simulated | secondary rays |",
             "| --- | ---: | ---: | ---: | --- | ---: |"]
    for i, r in enumerate(rows):
        added = "" if i == 0 else f"{r.ms - rows[i - 1].ms:+.1f}"
        lines.append(f"| {r.name} | {r.ms:.1f} | {added} | {r.ms / flat:.2f} | {', '.join(r.effects) or '—'} | "
                     f"{r.secondary_rays} |")
    return "\n".join(lines)


def presets_table(rows: list[PresetRow]) -> str:
    lines = ["| preset | settings | samples/pixel | RMSE | worst pixel | ms |", "| --- | --- | ---: | ---: | ---: | ---: |"]
    for r in rows:
        settings = ", ".join(f"{k}={v!r}" for k, v in r.settings.items())
        lines.append(f"| {r.name} | `{settings}` | {r.samples_per_pixel:.1f} | {_fmt(r.rmse)} | {_fmt(r.worst)} | "
                     f"{r.ms:.1f} |")
    return "\n".join(lines)


def _heatmap_label(aa: AntiAliasing, baselines: tuple[tuple[int, float], ...]) -> str:
    point = aa.heatmap_point(baselines)
    return "" if point is None else (f"max {point.spp} spp, min_spp {point.min_spp}, target_error "
                                     f"{point.target_error:g}: {point.samples_per_pixel:.1f} samples/pixel")


def markdown(report: Report, plots: dict[str, str]) -> str:
    c = report.config
    width, height = c.aa_size
    mode = "quick mode: small images, fewer samples, single timings; a smoke run, not the page's figures" \
        if c.quick else "full run"
    parts = [
        "# Accuracy and what it costs",
        "",
        "Generated by `python -m durer accuracy` (`addon/durer/reports/accuracy/`); rerun it to regenerate this page and "
        "its plots from scratch — do not edit by hand.",
        "",
        f"- **Machine:** {report.machine}; the core rendered on {report.threads} threads",
        f"- **Date:** {report.date}",
        f"- **Command:** `{report.command}` ({mode}; {report.seconds:.0f} s)",
        f"- **Method:** every comparison is measured in this one run. Times are the core's own timer, the median of "
        f"{c.runs} (anti-aliasing, presets) or {c.timing_runs} (precision, sphere method, effects) rounds that each "
        "render every configuration of the table once, after a warm-up round. Errors are deterministic "
        f"(seed {SEED}).",
        "",
        "## Targets",
        "",
        "| target | measured | met |",
        "| --- | --- | --- |",
    ]
    parts += [f"| {t.name} | {t.figure} | {_yes(t.met)} |" for t in targets(report)]
    parts += [
        "",
        "## Anti-aliasing",
        "",
        f"RMSE and worst-pixel error of the colour (linear RGB, per-pixel RMS over the channels) against a "
        f"{c.reference_spp}-spp {REFERENCE_SAMPLER} double-precision reference (another seed) at {width}×{height}, "
        f"for spp {', '.join(map(str, c.spps))} and every sampler. *center* puts every sample at the pixel centre, "
        "*random* is uniform, *stratified* jittered stratified (the default), *sobol* Owen-scrambled Sobol' (0,2) "
        "points; *adaptive* treats spp as the maximum: every pixel takes `min_spp` (default 4) Sobol' samples, then "
        "rounds double the samples of the pixels whose estimated colour error (the difference of the two halves of "
        "their samples, averaged with the rounds' before), or their 3x3 neighbourhood's, exceeds `target_error` "
        "(default 0.01), or that sit on an "
        "edge their own or their neighbours' samples show (other geometry, or a colour contrast an unseen edge "
        "could hide in) or that a sphere's silhouette crosses (from the camera's view of the spheres), or that "
        "hold one sample (`min_spp` 1: no error estimate yet) where that view does not prove them smooth nor "
        "their control describe them, so its "
        "samples/pixel column is what it actually took (camera rays: its probes, below, included); where "
        "silhouettes cross a pixel (both scenes are seen "
        "orthographically), its samples inside their union (up to four spheres'; where it fills the pixel, "
        "there for its control alone) and outside are weighed by "
        "their exact shares of the pixel "
        "(post-stratification), each sample inside the union first taken less a control variate (the diffuse "
        "shading by the ambient light and the sun of the sphere seen there, less that shading's exact mean over "
        "the union's part of the pixel, where spheres cut through each other the part of an overlap where each "
        "is seen bounded by the projection of the circle their fronts meet on; where the maximum is under 128 spp, "
        "the mean of the shading of the sphere seen over the union's part found on a lattice, and where the one "
        "seen changes inside an overlap and three discs or more cross the pixel, what each loses to a nearer one "
        "there, within half the target by its own estimate, which the pixel's estimated error adds), and a part "
        "no sample has reached keeps the pixel refining while its share exceeds "
        "`target_error`, a part whose samples all lie in one half of them while its share times 1/2 over the root "
        "of its samples does, and a sphere whose silhouette crosses the pixel and that no sample has met (one of "
        "the union's, or another) while half its share does (less for each sample that landed inside it and met "
        "something else); a pixel "
        "no sphere's disc reaches holds no edge in either scene (only the spheres make edges there: no shadows, one "
        "unbounded plane), and a sphere's edge or contrast in a neighbour does not keep it refining; a pixel with a "
        "control and no sphere behind its discs covering it, its samples less their control one colour on each "
        "part (both scenes' shading is the control's: diffuse, one sun, no shadows), settles once its outside's "
        "colour is known (no edge rule, nor its neighbours' errors, keeps it refining; its inside's colour is the "
        "control's mean there, known without a sample; where a sphere covering the pixel is seen all over its "
        "outside, that sphere's shading is the outside's control, its colour known too; where its first samples "
        "all landed inside and no cover is known, one camera ray at a point of its outside, a probe, tells that "
        "outside's one colour, or from one or two first samples a pixel, none: every ray that meets no sphere "
        "sees the plane's one colour, which a sample of the same tile off every disc met); so does a pixel a "
        "sphere's disc covers and is seen all over, beside its edge (a neighbour's square crosses it), at its "
        "first samples: its stratum is the disc filling it, its colour the control's mean. "
        "The slopes are "
        "least-squares fits of log RMSE against log spp (adaptive: against the samples it took); plain Monte "
        "Carlo converges as spp^-0.5. The reference's own error puts a floor under the curves at the highest spp.",
    ]
    for a in report.antialiasing:
        parts += ["", f"### {a.scene.capitalize()}", "",
                  f"{a.description[0].upper()}{a.description[1:]}; reference rendered in {a.reference_ms:.0f} ms.", "",
                  aa_tables(a)]
        if a.scene in plots:
            parts += ["", f"![RMSE vs samples and time, {a.scene}]({plots[a.scene]})"]
        if a.sweep:
            parts += ["", "Adaptive sampling's knobs: `target_error` swept with `min_spp` and spp (the maximum); "
                      "*estimated RMSE* is the render's own estimate (`stats['estimated_rmse']`, the RMS of "
                      "`result.error`), measured against nothing but its samples.", "", sweep_table(a, c.baselines)]
        if f"adaptive-{a.scene}" in plots:
            parts += ["", f"Where adaptive put its samples ({_heatmap_label(a, c.baselines)}): the render and "
                      "`result.samples` as a heat map.", "",
                      f"![adaptive samples per pixel, {a.scene}]({plots[f'adaptive-{a.scene}']})"]
        if not math.isnan(a.edge_share):
            parts += ["", f"{a.edge_share:.0%} of this scene's pixels hold an edge (their centre sample differs from "
                      "the reference by more than 1e-3)."]
        if a.oracle:
            bounds = "; ".join(f"{spp}-spp stratified's RMSE and worst pixel: {_samples(n)} samples/pixel"
                               + ("" if math.isinf(n) else f" ({n / spp:.2f} of its samples)")
                               for spp, n in a.oracle.items())
            parts += ["", "A bound on any sampler that gives each pixel a power-of-two count of Sobol samples and "
                      "takes their plain mean, as adaptive does where no silhouette is weighed: an oracle that knew "
                      "every pixel's expected error after 1, 2, 4, … samples (the "
                      f"RMS over {c.oracle_seeds} seeds) and chose each pixel's count with the fewest samples in all "
                      f"would need, to reach {bounds}."]
            if a.oracle_fine:
                fine = "; ".join(f"{spp}-spp stratified's: {_samples(n)}"
                                 + ("" if math.isinf(n) else f" ({n / spp:.2f})") for spp, n in a.oracle_fine.items())
                parts[-1] += (" Free to choose counts in quarter steps between powers of two as well (1–8, 10, 12, "
                              f"14, 16, 20, …), the same oracle would need {fine}.")
        if a.budget:
            free = a.budget[-1]
            parts += ["", f"With a time budget: `time_limit=` a share of the unlimited render's time (max "
                      f"{a.sweep[-1].spp if a.sweep else '—'} spp, target_error {min(c.target_errors):g}, "
                      f"{free.ms:.1f} ms); the render refines the tiles with the largest estimated errors first "
                      "and reports the estimate it reached.", "", budget_table(a.budget)]
    tw, th = c.timing_size
    parts += [
        "",
        "## Precision: float vs double",
        "",
        f"Renders at {tw}×{th}, {c.timing_spp} spp, robust sphere method; time per camera ray (the render's time "
        "divided by its camera rays, shading included) and the float render's difference from the double one.",
        "",
        precision_tables(report),
        "",
        "## Sphere method: algebraic vs geometric vs robust",
        "",
        f"Time per camera ray on the same renders (the edge-heavy scene has {c.edge_spheres} spheres), and each "
        "render's difference from the double-precision robust one:",
        "",
        method_tables(report),
        "",
        "Error as distance/radius grows (`durer.reports.numerics.sweep()`, the same sweep as [numerics.md](numerics.md)):",
        "",
        numerics.markdown_table(report.sweep),
    ]
    if "sphere-methods" in plots:
        parts += ["", f"![t error vs distance/radius]({plots['sphere-methods']})"]
    ew, eh = c.effects_size
    parts += [
        "",
        "## Effects: what each adds in time",
        "",
        f"The showcase geometry at {ew}×{eh}, 1 spp, double, each row adding one effect to the row above (as "
        "`bench/effects.py`): *added ms* is that effect's own cost, *time / flat* the ratio to the unlit render.",
        "",
        effects_table(report.effects),
    ]
    if report.occlusion is not None:
        parts += markdown_section(report.occlusion)
    parts += [
        "",
        "## Presets",
        "",
        f"`durer.PRESETS` (also `durer.preset(name)`) on the showcase at {width}×{height}, against the same reference:",
        "",
        presets_table(report.presets),
    ]
    if "presets" in plots:
        parts += ["", f"![presets: time vs RMSE]({plots['presets']})"]
    return "\n".join(parts) + "\n"


def summary(report: Report) -> str:
    """A few lines for the terminal."""
    lines = []
    for aa in report.antialiasing:
        slopes = ", ".join(f"{s} {_slope(aa.slope(s))}" for s in dict.fromkeys(p.sampler for p in aa.points)
                           if not math.isnan(aa.slope(s)))
        lines.append(f"{aa.scene}: fitted slopes {slopes}")
    by = {(t.scene, t.precision, t.method): t for t in report.timings}
    for scene in dict.fromkeys(t.scene for t in report.timings):
        d, f = by[scene, "double", "robust"], by[scene, "float", "robust"]
        methods = ", ".join(f"{m} {by[scene, 'double', m].ns_per_ray:.0f}" for m in SPHERE_METHODS)
        lines.append(f"{scene}: float/double time {f.ms / d.ms:.2f}; ns/ray (double) {methods}")
    if report.effects:
        flat = report.effects[FLAT_ROW].ms
        lines.append("effects vs flat: " + ", ".join(f"{r.name} {r.ms / flat:.2f}" for r in report.effects))
    for r in report.presets:
        lines.append(f"preset {r.name}: {r.ms:.1f} ms, RMSE {r.rmse:.2e}, {r.samples_per_pixel:.1f} samples/pixel")
    for t in targets(report):
        lines.append(f"target: {t.name}: {t.figure} -> {_yes(t.met).strip('*')}")
    return "\n".join(lines)
