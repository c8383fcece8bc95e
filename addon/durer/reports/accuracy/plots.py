"""The accuracy report's plots (PNG, matplotlib)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..plotting import plain_log_ticks, pyplot
from .measure import AAPoint, AntiAliasing, PresetRow


COLORS = {"center": "tab:gray", "random": "tab:red", "stratified": "tab:blue", "sobol": "tab:green",
          "adaptive": "tab:purple"}


def plot_antialiasing(aa: AntiAliasing, path: Path) -> None:
    """Log-log RMSE vs samples per pixel (left) and vs time (right), a line per sampler with its slope."""
    plt = pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4.2))
    for sampler in dict.fromkeys(p.sampler for p in aa.points):
        sel = sorted((p for p in aa.points if p.sampler == sampler), key=lambda p: p.samples_per_pixel)
        slope = aa.slope(sampler)
        label = f"{sampler} (slope {slope:+.2f})" if not math.isnan(slope) else sampler
        color = COLORS.get(sampler)
        left.loglog([p.samples_per_pixel for p in sel], [p.rmse for p in sel], "-o", ms=4, color=color, label=label)
        right.loglog([p.ms for p in sel], [p.rmse for p in sel], "-o", ms=4, color=color, label=sampler)
    groups = dict.fromkeys((p.spp, p.min_spp) for p in aa.sweep)
    for (spp, min_spp), marker in zip(groups, ("^", "v", "s", "D", "P", "X")):
        group = [p for p in aa.sweep if (p.spp, p.min_spp) == (spp, min_spp)]
        for ax, x in ((left, lambda p: p.samples_per_pixel), (right, lambda p: p.ms)):
            sweep = sorted(group, key=x)
            ax.loglog([x(p) for p in sweep], [p.rmse for p in sweep], ":" + marker, ms=5, color=COLORS["adaptive"],
                      alpha=0.8, label=f"adaptive sweep, max {spp}, min_spp {min_spp}")
    stratified = [p for p in aa.points if p.sampler == "stratified"]
    if stratified:  # a spp^-1/2 guide through stratified's first point
        x0 = min(stratified, key=lambda p: p.spp)
        xs = np.array([min(p.samples_per_pixel for p in aa.points), max(p.samples_per_pixel for p in aa.points)])
        left.loglog(xs, x0.rmse * (xs / x0.samples_per_pixel) ** -0.5, color="black", lw=0.7, ls="--",
                    label="spp^-0.5 guide")
    left.set_xlabel("samples per pixel (adaptive: mean taken)")
    right.set_xlabel("render time (ms, median)")
    for ax in (left, right):
        plain_log_ticks(ax)
        ax.set_ylabel("RMSE vs reference")
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"Anti-aliasing, {aa.scene}: {aa.width}x{aa.height}, reference {aa.reference_spp} spp")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_presets(rows: list[PresetRow], aa: AntiAliasing | None, path: Path) -> None:
    """Presets as points on the time/RMSE plane, over the showcase's stratified and adaptive curves."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    if aa is not None:
        for sampler in ("stratified", "adaptive"):
            sel = sorted((p for p in aa.points if p.sampler == sampler), key=lambda p: p.ms)
            if sel:
                ax.loglog([p.ms for p in sel], [p.rmse for p in sel], "-", color=COLORS[sampler], alpha=0.5, label=sampler)
    for r in rows:
        ax.loglog([r.ms], [r.rmse], "ko", ms=6)
        ax.annotate(r.name, (r.ms, r.rmse), textcoords="offset points", xytext=(6, 4), fontsize=9)
    plain_log_ticks(ax)
    ax.set_xlabel("render time (ms, median)")
    ax.set_ylabel("RMSE vs reference")
    ax.set_title("Presets on the showcase")
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_adaptive(point: AAPoint, scene: str, path: Path) -> None:
    """The adaptive render (left, sRGB for display) beside its samples per pixel (right, log scale)."""
    from matplotlib.colors import LogNorm

    plt = pyplot()
    h, w = point.samples.shape
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 10 * h / w / 2 + 0.9))
    rgb = np.clip(point.color[..., :3], 0, 1)
    left.imshow(np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * rgb ** (1 / 2.4) - 0.055), interpolation="nearest")
    shown = right.imshow(point.samples, cmap="magma", norm=LogNorm(vmin=max(1, point.samples.min()), vmax=point.spp),
                         interpolation="nearest")
    bar = fig.colorbar(shown, ax=right, fraction=0.03, label="samples")
    ticks = [2**k for k in range(21) if point.samples.min() <= 2**k <= point.spp]
    bar.set_ticks(ticks, labels=[str(t) for t in ticks])
    bar.minorticks_off()
    for ax, title in ((left, "render"), (right, "samples per pixel")):
        ax.set_title(title)
        ax.set_axis_off()
    fig.suptitle(f"Adaptive, {scene}: max {point.spp} spp, min_spp {point.min_spp}, target_error "
                 f"{point.target_error:g}, {point.samples_per_pixel:.1f} samples/pixel")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
