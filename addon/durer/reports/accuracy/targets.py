"""The accuracy report's benchmark targets, as figures measured in the report."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .measure import AAPoint, AntiAliasing, Report

#: How far the adaptive renders' own error estimate may be from the measured RMSE (either way).
ESTIMATE_FACTOR = 1.5


@dataclass
class Target:
    name: str
    figure: str
    met: bool | None   # None: could not be measured


def targets(report: Report) -> list[Target]:
    """Adaptive against stratified on each scene and baseline, the error estimate against the
    measured error, and the low-discrepancy slope."""
    out = []
    for aa in report.antialiasing:
        for spp, share in report.config.baselines:
            name = (f"adaptive reaches the RMSE and the worst pixel of {spp}-spp stratified on the {aa.scene} in "
                    f"<= 1/{round(1 / share)} of its time")
            base = aa.point("stratified", spp)
            adaptive = [p for p in aa.points + aa.sweep if p.sampler == "adaptive"]
            if base is None or not adaptive:
                out.append(Target(name, "not measured", None))
                continue
            best = aa.cheapest_reaching(base)
            stratified = f"stratified {spp} spp: RMSE {base.rmse:.2e}, worst {base.worst:.2e} in {base.ms:.1f} ms"
            if best is None:
                closest = min(adaptive, key=lambda p: max(p.rmse / base.rmse, p.worst / base.worst))
                out.append(Target(name, f"{stratified}; no adaptive setting measured reaches both (closest: "
                                  f"{_adaptive_label(closest)}: RMSE {closest.rmse:.2e}, worst {closest.worst:.2e} in "
                                  f"{closest.ms:.1f} ms){_oracle_note(aa, spp)}", False))
                continue
            ratio = best.ms / base.ms
            out.append(Target(name, f"{stratified}; cheapest adaptive reaching both ({_adaptive_label(best)}): RMSE "
                              f"{best.rmse:.2e}, worst {best.worst:.2e} in {best.ms:.1f} ms = {ratio:.2f} x the time"
                              f"{'' if ratio <= share else _oracle_note(aa, spp)}", ratio <= share))
    out.append(_estimate_target(report))
    out.append(_slope_target(report))
    return out


def _estimate_target(report: Report) -> Target:
    name = (f"adaptive's estimated RMSE is within {ESTIMATE_FACTOR:g}x of the measured RMSE across the target_error "
            "sweep, on both scenes")
    sweep = [(aa.scene, p) for aa in report.antialiasing for p in aa.sweep
             if p.estimated_rmse is not None and p.rmse > 0 and p.estimated_rmse > 0]
    if not sweep:
        return Target(name, "not measured", None)
    scene, worst = max(sweep, key=lambda sp: _factor(sp[1]))
    ratios = [p.estimated_rmse / p.rmse for _, p in sweep]
    return Target(name, f"estimated / measured from {min(ratios):.2f} to {max(ratios):.2f} over {len(sweep)} renders "
                  f"(furthest: {scene}, {_adaptive_label(worst)})", _factor(worst) <= ESTIMATE_FACTOR)


def _slope_target(report: Report) -> Target:
    name = "the low-discrepancy (sobol) fitted slope is steeper than random's (about -0.5) on the edge-heavy scene"
    edges = next((a for a in report.antialiasing if a.scene == "edges"), None)
    if edges is None:
        return Target(name, "not measured", None)
    sobol, random = edges.slope("sobol"), edges.slope("random")
    if math.isnan(sobol) or math.isnan(random):
        return Target(name, "not measured", None)
    return Target(name, f"sobol {sobol:+.2f}, random {random:+.2f}, stratified {edges.slope('stratified'):+.2f}",
                  sobol < random)


def _factor(p: AAPoint) -> float:
    ratio = p.estimated_rmse / p.rmse
    return max(ratio, 1 / ratio)


def _oracle_note(aa: AntiAliasing, spp: int) -> str:
    samples, fine = aa.oracle.get(spp), aa.oracle_fine.get(spp)
    if samples is None:
        return ""
    note = ("; no choice of power-of-two Sobol counts per pixel reaches both" if math.isinf(samples) else
            f"; an oracle choosing each pixel's power-of-two Sobol count from its expected error (plain means) "
            f"would need {samples:.1f} samples/pixel = {samples / spp:.2f} of stratified's")
    if fine is None:
        return note
    return note + (" (with counts in quarter steps between powers of two: "
                   + ("none reaches both)" if math.isinf(fine) else f"{fine:.1f} = {fine / spp:.2f})"))


def _adaptive_label(p: AAPoint) -> str:
    knobs = f", target_error {p.target_error:g}, min_spp {p.min_spp}" if p.target_error is not None \
        else ", default target_error"
    return f"max {p.spp} spp{knobs}, {p.samples_per_pixel:.1f} samples/pixel"
