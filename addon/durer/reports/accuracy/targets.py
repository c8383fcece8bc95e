"""The accuracy report's two benchmark targets, as figures measured in the report."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .measure import AAPoint, Report


@dataclass
class Target:
    name: str
    figure: str
    met: bool | None   # None: could not be measured


def targets(report: Report) -> list[Target]:
    """The issue's two benchmark targets, as figures."""
    out = []
    aa = {a.scene: a for a in report.antialiasing}
    base_spp = report.config.baseline_spp
    name = f"adaptive reaches the RMSE of {base_spp}-spp stratified on the showcase in <= 1/3 of its time"
    showcase = aa.get("showcase")
    base = showcase.point("stratified", base_spp) if showcase else None
    if base is None:
        out.append(Target(name, "not measured", None))
    else:
        adaptive = [p for p in showcase.points + showcase.sweep if p.sampler == "adaptive"]
        reached = [p for p in adaptive if p.rmse <= base.rmse]
        if reached:
            best = min(reached, key=lambda p: p.ms)
            ratio = best.ms / base.ms
            out.append(Target(name, f"stratified {base_spp} spp: RMSE {base.rmse:.2e} in {base.ms:.1f} ms; cheapest "
                              f"adaptive at or below it ({_adaptive_label(best)}): RMSE {best.rmse:.2e} in "
                              f"{best.ms:.1f} ms = {ratio:.2f} x the time", ratio <= 1 / 3))
        elif adaptive:
            best = min(adaptive, key=lambda p: p.rmse)
            out.append(Target(name, f"stratified {base_spp} spp: RMSE {base.rmse:.2e} in {base.ms:.1f} ms; no adaptive "
                              f"setting measured reaches it (best: {_adaptive_label(best)}, RMSE {best.rmse:.2e} in "
                              f"{best.ms:.1f} ms)", False))
        else:
            out.append(Target(name, "adaptive not measured", None))
    name = "the low-discrepancy (sobol) fitted slope is steeper than random's (about -0.5) on the edge-heavy scene"
    edges = aa.get("edges")
    if edges is None:
        out.append(Target(name, "not measured", None))
    else:
        sobol, random = edges.slope("sobol"), edges.slope("random")
        if math.isnan(sobol) or math.isnan(random):
            out.append(Target(name, "not measured", None))
        else:
            out.append(Target(name, f"sobol {sobol:+.2f}, random {random:+.2f}, stratified "
                              f"{edges.slope('stratified'):+.2f}", sobol < random))
    return out


def _adaptive_label(p: AAPoint) -> str:
    knob = f", target_error {p.target_error:g}" if p.target_error is not None else ", target_error default"
    return f"max {p.spp} spp{knob}, {p.samples_per_pixel:.1f} samples/pixel"
