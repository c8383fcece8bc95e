"""The accuracy report: what accuracy costs in time, measured in one run on this machine.

`python -m durer accuracy [--quick] [--output docs/accuracy.md]` renders and times

- anti-aliasing: every sampler at 1…256 samples per pixel against a 4096-spp stratified reference,
  on the showcase scene and an edge-heavy scene (2,000 small spheres), with each sampler's fitted
  convergence slope; plus adaptive sampling's target_error knob;
- precision: float vs double, time per ray and error (renders, and the numerics hard-case sweep);
- sphere method: algebraic vs geometric vs robust, time per ray and error as distance/radius grows
  (the sweep of `durer.numerics`);
- effects: what diffuse light, shadows, specular, reflection and refraction each add in time;
- presets: each of `durer.PRESETS`' time and error,

and writes the Markdown page with its tables and the PNG plots next to it (accuracy-*.png). Every
comparison is measured in the same run: timings are medians over rounds that each render every
configuration once (so the machine's drift hits all alike), from the core's own timer.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import numerics
from .camera import OrthographicCamera
from .render import PRECISIONS, SPHERE_METHODS, RenderResult, render
from .scene import Scene
from .showcase import showcase_scene

SAMPLERS = ("center", "random", "stratified", "sobol", "adaptive")
REFERENCE_SAMPLER = "stratified"
REFERENCE_SEED = 90210          # not the measured renders' seed: the reference's noise is independent of theirs
SEED = 0
PRESET_NAMES = ("draft", "preview", "final", "reference")


@dataclass(frozen=True)
class Config:
    """How much to measure. `full()` is the page in docs/, `quick()` a smoke run in seconds."""

    quick: bool
    aa_size: tuple[int, int]                 # anti-aliasing and presets image (width, height)
    spps: tuple[int, ...]                    # samples per pixel swept (adaptive: the maximum)
    reference_spp: int
    runs: int                                # timed rounds per point (median); one warm-up before
    target_errors: tuple[float, ...]         # adaptive's knob, swept on the showcase
    timing_size: tuple[int, int]             # precision and sphere-method timings
    timing_spp: int
    timing_runs: int
    effects_size: tuple[int, int]
    edge_spheres: int = 2000
    samplers: tuple[str, ...] = SAMPLERS

    @classmethod
    def full(cls) -> Config:
        return cls(quick=False, aa_size=(160, 90), spps=(1, 4, 16, 64, 256), reference_spp=4096, runs=3,
                   target_errors=(0.08, 0.04, 0.02, 0.01, 0.005, 0.0025), timing_size=(480, 270), timing_spp=4,
                   timing_runs=5, effects_size=(640, 360))

    @classmethod
    def quick_config(cls) -> Config:
        return cls(quick=True, aa_size=(80, 45), spps=(1, 4, 16), reference_spp=256, runs=1,
                   target_errors=(0.04, 0.01), timing_size=(160, 90), timing_spp=4, timing_runs=3,
                   effects_size=(480, 270))

    @property
    def baseline_spp(self) -> int:
        """The stratified spp the adaptive target compares with: 64, or the largest measured below it."""
        return max([s for s in self.spps if s <= 64] or [min(self.spps)])

    @property
    def adaptive_max_spp(self) -> int:
        """The maximum spp of the target_error sweep: 4 x the baseline, so adaptive is not capped by it."""
        return 4 * self.baseline_spp


# --- error measures -------------------------------------------------------------------------------

def pixel_errors(image: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(H, W): each pixel's RMS difference over the colour channels (RGB; alpha is ignored)."""
    image, reference = np.asarray(image, np.float64), np.asarray(reference, np.float64)
    if image.shape != reference.shape:
        raise ValueError(f"shapes differ: {image.shape} vs {reference.shape}")
    if image.ndim == 3 and image.shape[-1] >= 3:
        image, reference = image[..., :3], reference[..., :3]
    elif image.ndim == 2:
        image, reference = image[..., None], reference[..., None]
    return np.sqrt(np.mean((image - reference) ** 2, axis=-1))


def rmse(image: np.ndarray, reference: np.ndarray) -> float:
    """Root mean square colour error over every pixel and RGB channel."""
    return float(np.sqrt(np.mean(pixel_errors(image, reference) ** 2)))


def worst_pixel(image: np.ndarray, reference: np.ndarray) -> float:
    """The largest per-pixel RMS colour error (same units as `rmse`)."""
    return float(np.max(pixel_errors(image, reference)))


def fit_slope(x: Sequence[float], y: Sequence[float]) -> float:
    """Least-squares slope of log y against log x (the convergence order: -0.5 for plain Monte
    Carlo). Points with non-positive or non-finite values are left out; nan if fewer than 2 remain
    or x does not vary."""
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    keep = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    lx, ly = np.log(x[keep]), np.log(y[keep])
    if lx.size < 2 or np.ptp(lx) == 0:
        return float("nan")
    return float(np.polyfit(lx, ly, 1)[0])


# --- scenes ---------------------------------------------------------------------------------------

def edge_scene(spheres: int = 2000, seed: int = 3) -> tuple[Scene, OrthographicCamera]:
    """Many small spheres (radius 0.02-0.08, under one to three pixels at 160 wide) on a plane, one
    sun without shadows, seen from above: nearly every pixel has an edge in it."""
    scene = Scene()
    scene.background = (0.55, 0.7, 0.9, 1.0)
    scene.ambient = (0.18, 0.2, 0.24)
    ground = scene.add_material(diffuse=(0.7, 0.68, 0.62))
    palette = np.array([scene.add_material(diffuse=c) for c in
                        ((0.85, 0.2, 0.15), (0.2, 0.45, 0.85), (0.95, 0.75, 0.2), (0.25, 0.7, 0.35),
                         (0.6, 0.3, 0.75), (0.05, 0.05, 0.05), (0.95, 0.95, 0.95))], dtype=np.int32)
    scene.add_plane((0, 1, 0), 0.0, material=ground)
    rng = np.random.default_rng(seed)
    r = rng.uniform(0.02, 0.08, spheres)
    centers = np.stack([rng.uniform(-4.4, 4.4, spheres), r, rng.uniform(-2.6, 2.6, spheres)], axis=1)
    scene.add_spheres(centers, r, material=palette[rng.integers(0, palette.size, spheres)])
    scene.add_directional_light((-0.5, -1.0, -0.4), (0.95, 0.92, 0.85))
    # Slightly off straight down, so that no ray direction component is exactly 0 (kept for comparable figures).
    camera = OrthographicCamera(center=(0.0, 5.0, 0.0), direction=(0.02, -1.0, -0.05), up=(0.0, 0.0, -1.0), size=8.0)
    return scene, camera


def effect_scene(lights: bool, shadows: bool, specular: bool, reflective: bool, transparent: bool) -> Scene:
    """The showcase's geometry with the asked-for effects switched on (also bench/effects.py's scene)."""
    base, _ = showcase_scene()
    scene = Scene()
    scene.background = base.background
    scene.ambient = base.ambient
    palette = [scene.add_material(
        diffuse=c,
        specular=(0.5, 0.5, 0.5) if specular else (0, 0, 0), exponent=40.0,
        reflective=(0.4, 0.4, 0.4) if reflective and i == 0 else (0, 0, 0),
        transparent=(0.9, 0.9, 0.9) if transparent and i == 1 else (0, 0, 0), ior=1.5,
    ) for i, c in enumerate(((0.85, 0.2, 0.15), (0.2, 0.45, 0.85), (0.95, 0.75, 0.2), (0.25, 0.7, 0.35)))]
    scene.add_plane((0, 1, 0), 0.0, material=scene.add_material((0.7, 0.68, 0.62)))
    centers = np.array([[0.0, 1.5, 0.0], [-2.6, 0.9, 0.8], [2.4, 1.1, -0.6], [-0.9, 0.5, 2.3]])
    scene.add_spheres(centers, [1.5, 0.9, 1.1, 0.5], material=np.array(palette, dtype=np.int32))
    rng = np.random.default_rng(7)
    angle = rng.uniform(0, 2 * np.pi, 60)
    distance = rng.uniform(3.0, 5.5, 60)
    r = rng.uniform(0.08, 0.25, 60)
    scene.add_spheres(np.stack([distance * np.cos(angle), r, distance * np.sin(angle) * 0.6], 1), r,
                      material=np.array(palette, dtype=np.int32)[rng.integers(0, 4, 60)])
    if lights:
        scene.add_directional_light((-0.5, -1.0, -0.4), (0.95, 0.92, 0.85), shadows=shadows)
    return scene


EFFECT_ROWS: tuple[tuple[str, dict[str, bool], tuple[str, ...]], ...] = (
    ("depth only", dict(lights=False, shadows=False, specular=False, reflective=False, transparent=False), ("depth",)),
    ("flat colour (no lights)", dict(lights=False, shadows=False, specular=False, reflective=False, transparent=False),
     ("color",)),
    ("+ diffuse light", dict(lights=True, shadows=False, specular=False, reflective=False, transparent=False), ("color",)),
    ("+ shadows", dict(lights=True, shadows=True, specular=False, reflective=False, transparent=False), ("color",)),
    ("+ Phong specular", dict(lights=True, shadows=True, specular=True, reflective=False, transparent=False), ("color",)),
    ("+ reflection", dict(lights=True, shadows=True, specular=True, reflective=True, transparent=False), ("color",)),
    ("+ refraction", dict(lights=True, shadows=True, specular=True, reflective=True, transparent=True), ("color",)),
)
FLAT_ROW = 1


# --- timing ---------------------------------------------------------------------------------------

def timed(renders: Sequence[Callable[..., RenderResult]], runs: int, reuse: bool = False
          ) -> tuple[list[float], list[RenderResult]]:
    """Median milliseconds (the core's timer) of each render over `runs` rounds that each render
    every one once, after one warm-up round whose results are returned (renders are deterministic).
    With `reuse`, timed renders write into the warm-up's buffers (`out=`): no page faults timed."""
    results = [r(out=None) for r in renders]
    times: list[list[float]] = [[] for _ in renders]
    for _ in range(runs):
        for i, r in enumerate(renders):
            times[i].append(r(out=results[i] if reuse else None).stats["milliseconds"])
    return [statistics.median(t) if t else results[i].stats["milliseconds"] for i, t in enumerate(times)], results


def samples_per_pixel(result: RenderResult) -> float:
    """Mean camera samples per pixel actually taken (adaptive: fewer than its spp maximum)."""
    samples = getattr(result, "samples", None)
    if samples is not None:
        return float(np.mean(samples))
    stats = result.stats
    if "samples" in stats:
        return stats["samples"] / (stats["width"] * stats["height"])
    return float(stats["spp"])


# --- measurements ---------------------------------------------------------------------------------

@dataclass
class AAPoint:
    sampler: str
    spp: int                   # the spp argument (adaptive: the maximum)
    samples_per_pixel: float   # taken, on average
    rmse: float
    worst: float
    ms: float
    target_error: float | None = None  # adaptive only


@dataclass
class AntiAliasing:
    scene: str
    description: str
    width: int
    height: int
    reference_spp: int
    reference_ms: float
    points: list[AAPoint]
    sweep: list[AAPoint] = field(default_factory=list)  # adaptive's target_error sweep (showcase)
    reference: np.ndarray | None = field(default=None, repr=False)  # the reference's colour

    def slope(self, sampler: str) -> float:
        """Fitted log RMSE / log spp of a sampler's points (adaptive: against the samples it took)."""
        sel = [p for p in self.points if p.sampler == sampler]
        return fit_slope([p.samples_per_pixel if sampler == "adaptive" else p.spp for p in sel], [p.rmse for p in sel])

    def point(self, sampler: str, spp: int) -> AAPoint | None:
        return next((p for p in self.points if p.sampler == sampler and p.spp == spp), None)


def measure_antialiasing(name: str, description: str, scene: Scene, camera: Any, width: int, height: int,
                         spps: Sequence[int], reference_spp: int, runs: int, samplers: Sequence[str] = SAMPLERS,
                         target_errors: Sequence[float] = (), adaptive_max_spp: int = 256) -> AntiAliasing:
    """Every sampler at every spp against a `reference_spp` stratified double render."""
    start = time.perf_counter()
    reference = render(scene, camera, width, height, spp=reference_spp, seed=REFERENCE_SEED,
                       sampler=REFERENCE_SAMPLER, precision="double", passes=("color",))
    reference_ms = (time.perf_counter() - start) * 1000
    configs = [(s, n, None) for s in samplers for n in spps]
    configs += [("adaptive", adaptive_max_spp, e) for e in target_errors]

    def renderer(sampler: str, spp: int, target_error: float | None) -> Callable[..., RenderResult]:
        extra = {} if target_error is None else {"target_error": target_error}
        return lambda out: render(scene, camera, width, height, spp=spp, seed=SEED, sampler=sampler,
                                  passes=("color",), **extra)

    medians, results = timed([renderer(*c) for c in configs], runs)
    points = [AAPoint(s, n, samples_per_pixel(r), rmse(r.color, reference.color), worst_pixel(r.color, reference.color),
                      ms, e) for (s, n, e), ms, r in zip(configs, medians, results)]
    main_points = [p for p in points if p.target_error is None]
    sweep = [p for p in points if p.target_error is not None]
    return AntiAliasing(name, description, width, height, reference_spp, reference_ms, main_points, sweep,
                        reference.color)


@dataclass
class Timing:
    """One (scene, precision, method) render: its time and its difference from the double-robust one."""

    scene: str
    precision: str
    method: str
    ms: float
    rays: int
    rmse_vs_double_robust: float
    worst_vs_double_robust: float
    max_depth_difference: float        # over pixels both renders hit
    max_relative_depth_difference: float
    hit_disagreements: int             # pixels hit in one render and missed in the other

    @property
    def ns_per_ray(self) -> float:
        return self.ms * 1e6 / self.rays if self.rays else float("nan")


def depth_differences(depth: np.ndarray, reference: np.ndarray) -> tuple[float, float, int]:
    """Max |depth - reference| and max of it / |reference| over pixels both hit, and the number of
    pixels where one hit and the other missed (inf depth)."""
    a, b = np.asarray(depth, np.float64), np.asarray(reference, np.float64)
    both = np.isfinite(a) & np.isfinite(b)
    disagree = int(np.count_nonzero(np.isfinite(a) != np.isfinite(b)))
    if not both.any():
        return 0.0, 0.0, disagree
    diff = np.abs(a[both] - b[both])
    scale = np.maximum(np.abs(b[both]), np.finfo(np.float64).tiny)
    return float(diff.max()), float((diff / scale).max()), disagree


def measure_timings(scenes: Sequence[tuple[str, Scene, Any]], width: int, height: int, spp: int, runs: int
                    ) -> list[Timing]:
    """Each scene in both precisions with each sphere method, all in the same rounds."""
    configs = [(name, scene, camera, p, m) for name, scene, camera in scenes for p in PRECISIONS for m in SPHERE_METHODS]
    renders = [lambda out, s=s, c=c, p=p, m=m: render(s, c, width, height, spp=spp, seed=SEED, precision=p,
                                                      sphere_method=m, passes=("color", "depth"), out=out)
               for _, s, c, p, m in configs]
    medians, results = timed(renders, runs, reuse=True)
    exact = {name: results[i] for i, (name, _, _, p, m) in enumerate(configs) if p == "double" and m == "robust"}
    rows = []
    for (name, _, _, p, m), ms, r in zip(configs, medians, results):
        ref = exact[name]
        depth, relative, disagree = depth_differences(r.depth, ref.depth)
        rows.append(Timing(name, p, m, ms, int(r.stats["rays"]), rmse(r.color, ref.color),
                           worst_pixel(r.color, ref.color), depth, relative, disagree))
    return rows


@dataclass
class EffectRow:
    name: str
    ms: float
    effects: tuple[str, ...]
    secondary_rays: int   # shadow + reflection + refraction rays


def measure_effects(camera: Any, width: int, height: int, runs: int) -> list[EffectRow]:
    """Each row of EFFECT_ROWS adds one effect to the one above, 1 spp, in the same rounds."""
    renders = []
    for _, flags, passes in EFFECT_ROWS:
        scene = effect_scene(**flags)
        renders.append(lambda out, scene=scene, passes=passes: render(
            scene, camera, width, height, passes=passes, seed=SEED, out=out, shade_back=True))
    medians, results = timed(renders, runs, reuse=True)
    rows = []
    for (name, _, _), ms, r in zip(EFFECT_ROWS, medians, results):
        s = r.stats
        secondary = sum(int(s.get(k, 0)) for k in ("shadow_rays", "reflection_rays", "refraction_rays"))
        rows.append(EffectRow(name, ms, tuple(s.get("effects", ())), secondary))
    return rows


@dataclass
class PresetRow:
    name: str
    settings: dict[str, Any]
    ms: float
    samples_per_pixel: float
    rmse: float
    worst: float


def available_presets() -> dict[str, dict[str, Any]]:
    """durer.PRESETS if the core has them (else empty)."""
    import durer

    presets = getattr(durer, "PRESETS", None)
    return {name: dict(kwargs) for name, kwargs in presets.items()} if presets else {}


def measure_presets(scene: Scene, camera: Any, width: int, height: int, reference: np.ndarray, runs: int,
                    presets: dict[str, dict[str, Any]]) -> list[PresetRow]:
    names = list(presets)
    settings = [{"passes": ("color",), **presets[n]} for n in names]  # colour only, as the anti-aliasing renders
    renders = [lambda out, kw=kw: render(scene, camera, width, height, **kw) for kw in settings]
    medians, results = timed(renders, runs)
    return [PresetRow(n, presets[n], ms, samples_per_pixel(r), rmse(r.color, reference), worst_pixel(r.color, reference))
            for n, ms, r in zip(names, medians, results)]


# --- the whole report -----------------------------------------------------------------------------

@dataclass
class Report:
    config: Config
    machine: str
    date: str
    command: str
    threads: int
    antialiasing: list[AntiAliasing]
    timings: list[Timing]
    sweep: list[numerics.SweepRow]
    effects: list[EffectRow]
    presets: list[PresetRow]
    seconds: float = 0.0


def machine() -> str:
    """CPU model, cores, Python, numpy and durer versions."""
    import durer

    cpu = platform.processor() or "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}, Python "
            f"{platform.python_version()}, numpy {np.__version__}, durer {durer.__version__}")


def measure(config: Config, command: str = "python -m durer accuracy", log: Callable[[str], Any] = print) -> Report:
    """Everything the page shows, measured now."""
    start = time.perf_counter()
    width, height = config.aa_size
    showcase, showcase_camera = showcase_scene()
    edges, edges_camera = edge_scene(config.edge_spheres)
    threads = int(render(showcase, showcase_camera, 8, 8).stats.get("threads", 0))

    log(f"anti-aliasing: showcase, {width}x{height}, reference {config.reference_spp} spp ...")
    aa_showcase = measure_antialiasing(
        "showcase", f"the showcase scene ({showcase.sphere_count} spheres, a ground plane, a sun)", showcase,
        showcase_camera, width, height, config.spps, config.reference_spp, config.runs, config.samplers,
        config.target_errors if "adaptive" in config.samplers else (), config.adaptive_max_spp)
    log(f"anti-aliasing: edges ({config.edge_spheres} small spheres) ...")
    aa_edges = measure_antialiasing(
        "edges", f"the edge-heavy scene ({config.edge_spheres} spheres of radius 0.02-0.08 on a plane, seen from "
        "above, one sun without shadows)", edges, edges_camera, width, height, config.spps, config.reference_spp,
        config.runs, config.samplers)

    tw, th = config.timing_size
    log(f"precision and sphere method: {tw}x{th}, {config.timing_spp} spp ...")
    timings = measure_timings([("showcase", showcase, showcase_camera), ("edges", edges, edges_camera)],
                              tw, th, config.timing_spp, config.timing_runs)
    log("hard-case sweep (durer.numerics) ...")
    sweep = numerics.sweep()
    ew, eh = config.effects_size
    log(f"effects: {ew}x{eh}, 1 spp ...")
    effects = measure_effects(showcase_camera, ew, eh, config.timing_runs)

    presets = available_presets()
    log(f"presets: {', '.join(presets) or 'none (durer.PRESETS missing)'} ...")
    preset_rows = measure_presets(showcase, showcase_camera, width, height, aa_showcase.reference, config.runs, presets)
    report = Report(config, machine(), time.strftime("%Y-%m-%d %H:%M %Z"), command, threads,
                    [aa_showcase, aa_edges], timings, sweep, effects, preset_rows)
    report.seconds = time.perf_counter() - start
    return report


# --- targets --------------------------------------------------------------------------------------

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


# --- the page -------------------------------------------------------------------------------------

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
        lines.append(f"| {s} | {slope:+.2f}{note} | {_fmt(last.rmse)} | {_fmt(last.worst)} |" if not math.isnan(slope)
                     else f"| {s} | — | {_fmt(last.rmse)} | {_fmt(last.worst)} |")
    lines += ["", "| sampler | spp | samples/pixel | RMSE | worst pixel | ms | ms / stratified same spp |",
              "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for p in aa.points:
        base = stratified.get(p.spp)
        ratio = f"{p.ms / base.ms:.2f}" if base and base.ms > 0 else "—"
        lines.append(f"| {p.sampler} | {p.spp} | {p.samples_per_pixel:.1f} | {_fmt(p.rmse)} | {_fmt(p.worst)} | "
                     f"{p.ms:.1f} | {ratio} |")
    return "\n".join(lines)


def sweep_table(aa: AntiAliasing, baseline: AAPoint | None) -> str:
    lines = ["| target_error | max spp | samples/pixel | RMSE | worst pixel | ms | time / stratified baseline |",
             "| ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for p in aa.sweep:
        ratio = f"{p.ms / baseline.ms:.2f}" if baseline and baseline.ms > 0 else "—"
        lines.append(f"| {p.target_error:g} | {p.spp} | {p.samples_per_pixel:.1f} | {_fmt(p.rmse)} | {_fmt(p.worst)} | "
                     f"{p.ms:.1f} | {ratio} |")
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
    lines += ["", "On the hard-case sweep (`durer.numerics.sweep()`: a unit sphere at distance/radius 10…10⁹, "
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


def presets_table(rows: list[PresetRow], aa: AntiAliasing | None) -> str:
    if not rows:
        return "_durer.PRESETS is not available in this build: no presets measured._"
    lines = ["| preset | settings | samples/pixel | RMSE | worst pixel | ms |", "| --- | --- | ---: | ---: | ---: | ---: |"]
    for r in rows:
        settings = ", ".join(f"{k}={v!r}" for k, v in r.settings.items())
        lines.append(f"| {r.name} | `{settings}` | {r.samples_per_pixel:.1f} | {_fmt(r.rmse)} | {_fmt(r.worst)} | "
                     f"{r.ms:.1f} |")
    return "\n".join(lines)


def markdown(report: Report, plots: dict[str, str]) -> str:
    c = report.config
    aa = {a.scene: a for a in report.antialiasing}
    width, height = c.aa_size
    mode = "quick mode: small images, fewer samples, single timings; a smoke run, not the page's figures" \
        if c.quick else "full run"
    parts = [
        "# Accuracy and what it costs",
        "",
        "Generated by `python -m durer accuracy` (`addon/durer/accuracy.py`); rerun it to regenerate this page and "
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
        "points; *adaptive* treats spp as the maximum: it starts with min(4, spp) Sobol' samples and adds rounds "
        "of 4 while a pixel's samples hit different objects or the standard error of its mean luminance exceeds "
        "`target_error` (default 0.01), so its samples/pixel column is what it actually took. The slopes are "
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
            baseline = a.point("stratified", c.baseline_spp)
            parts += ["", f"Adaptive sampling's knob: `target_error` swept with spp (the maximum) = "
                      f"{c.adaptive_max_spp}; the time is compared with {c.baseline_spp}-spp stratified.", "",
                      sweep_table(a, baseline)]
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
        "Error as distance/radius grows (`durer.numerics.sweep()`, the same sweep as [numerics.md](numerics.md)):",
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
        "",
        "## Presets",
        "",
        f"`durer.PRESETS` (also `durer.preset(name)`) on the showcase at {width}×{height}, against the same reference:",
        "",
        presets_table(report.presets, aa.get("showcase")),
    ]
    if "presets" in plots:
        parts += ["", f"![presets: time vs RMSE]({plots['presets']})"]
    return "\n".join(parts) + "\n"


# --- plots ----------------------------------------------------------------------------------------

COLORS = {"center": "tab:gray", "random": "tab:red", "stratified": "tab:blue", "sobol": "tab:green",
          "adaptive": "tab:purple"}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _plain_log_ticks(ax: Any) -> None:
    """Decade labels only (minor labels of a short log axis overlap)."""
    from matplotlib.ticker import NullFormatter

    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.yaxis.set_minor_formatter(NullFormatter())


def plot_antialiasing(aa: AntiAliasing, path: Path) -> None:
    """Log-log RMSE vs samples per pixel (left) and vs time (right), a line per sampler with its slope."""
    plt = _pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4.2))
    for sampler in dict.fromkeys(p.sampler for p in aa.points):
        sel = sorted((p for p in aa.points if p.sampler == sampler), key=lambda p: p.samples_per_pixel)
        slope = aa.slope(sampler)
        label = f"{sampler} (slope {slope:+.2f})" if not math.isnan(slope) else sampler
        color = COLORS.get(sampler)
        left.loglog([p.samples_per_pixel for p in sel], [p.rmse for p in sel], "-o", ms=4, color=color, label=label)
        right.loglog([p.ms for p in sel], [p.rmse for p in sel], "-o", ms=4, color=color, label=sampler)
    if aa.sweep:
        for ax, x in ((left, lambda p: p.samples_per_pixel), (right, lambda p: p.ms)):
            sweep = sorted(aa.sweep, key=x)
            ax.loglog([x(p) for p in sweep], [p.rmse for p in sweep], ":^", ms=5, color=COLORS["adaptive"],
                      label=f"adaptive, target_error sweep (max {sweep[0].spp} spp)")
    stratified = [p for p in aa.points if p.sampler == "stratified"]
    if stratified:  # a spp^-1/2 guide through stratified's first point
        x0 = min(stratified, key=lambda p: p.spp)
        xs = np.array([min(p.samples_per_pixel for p in aa.points), max(p.samples_per_pixel for p in aa.points)])
        left.loglog(xs, x0.rmse * (xs / x0.samples_per_pixel) ** -0.5, color="black", lw=0.7, ls="--",
                    label="spp^-0.5 guide")
    left.set_xlabel("samples per pixel (adaptive: mean taken)")
    right.set_xlabel("render time (ms, median)")
    for ax in (left, right):
        _plain_log_ticks(ax)
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
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    if aa is not None:
        for sampler in ("stratified", "adaptive"):
            sel = sorted((p for p in aa.points if p.sampler == sampler), key=lambda p: p.ms)
            if sel:
                ax.loglog([p.ms for p in sel], [p.rmse for p in sel], "-", color=COLORS[sampler], alpha=0.5, label=sampler)
    for r in rows:
        ax.loglog([r.ms], [r.rmse], "ko", ms=6)
        ax.annotate(r.name, (r.ms, r.rmse), textcoords="offset points", xytext=(6, 4), fontsize=9)
    _plain_log_ticks(ax)
    ax.set_xlabel("render time (ms, median)")
    ax.set_ylabel("RMSE vs reference")
    ax.set_title("Presets on the showcase")
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def write_report(report: Report, output: Path) -> list[Path]:
    """The page and its plots (accuracy-*.png next to it); returns the files written."""
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    stem = output.stem
    written, plots = [], {}
    for aa in report.antialiasing:
        path = output.parent / f"{stem}-aa-{aa.scene}.png"
        plot_antialiasing(aa, path)
        plots[aa.scene] = path.name
        written.append(path)
    if report.sweep:
        path = output.parent / f"{stem}-sphere-methods.png"
        numerics.plot(report.sweep, path)
        plots["sphere-methods"] = path.name
        written.append(path)
    if report.presets:
        path = output.parent / f"{stem}-presets.png"
        plot_presets(report.presets, next((a for a in report.antialiasing if a.scene == "showcase"), None), path)
        plots["presets"] = path.name
        written.append(path)
    output.write_text(markdown(report, plots))
    return [output, *written]


def summary(report: Report) -> str:
    """A few lines for the terminal."""
    lines = []
    for aa in report.antialiasing:
        slopes = ", ".join(f"{s} {aa.slope(s):+.2f}" for s in dict.fromkeys(p.sampler for p in aa.points)
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


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(prog="python -m durer accuracy", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="80x45 images, spp 1, 4, 16 against a 256-spp reference, single timings (seconds)")
    parser.add_argument("--output", default="docs/accuracy.md",
                        help="Markdown page to write; plots go next to it (default %(default)s)")
    args = parser.parse_args(argv)
    config = Config.quick_config() if args.quick else Config.full()
    command = " ".join(["python -m durer accuracy", *argv])
    report = measure(config, command)
    print(summary(report))
    written = write_report(report, Path(args.output))
    print(f"\nwrote {', '.join(str(p) for p in written)} in {report.seconds:.1f} s")
    return 0
