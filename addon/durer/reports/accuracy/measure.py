"""The accuracy report's measurements: what it renders and times, and the figures it keeps."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ... import _core
from ...presets import PRESETS
from ...render import PRECISIONS, SAMPLERS, SPHERE_METHODS, RenderResult, render
from ...scene import Scene
from ...showcase import showcase_scene
from .. import numerics
from ..errors import depth_differences, fit_slope, pixel_errors, rmse, worst_pixel
from ..machine import machine
from ..scenes import EFFECT_ROWS, edge_scene, effect_scene

if TYPE_CHECKING:
    from .occlusion import Occlusion

REFERENCE_SAMPLER = "stratified"
REFERENCE_SEED = 90210          # not the measured renders' seed: the reference's noise is independent of theirs
SEED = 0


@dataclass(frozen=True)
class Config:
    """How much to measure. `full()` is the page in docs/, `quick_config()` a smoke run in seconds."""

    quick: bool
    aa_size: tuple[int, int]                 # anti-aliasing and presets image (width, height)
    spps: tuple[int, ...]                    # samples per pixel swept (adaptive: the maximum)
    reference_spp: int
    runs: int                                # timed rounds per point (median); one warm-up before
    target_errors: tuple[float, ...]         # adaptive's knob, swept on both scenes
    min_spps: tuple[int, ...]                # adaptive's first pass, swept with it
    oracle_seeds: int                        # seeds each pixel's expected Sobol error is measured over
    timing_size: tuple[int, int]             # precision and sphere-method timings
    timing_spp: int
    timing_runs: int
    effects_size: tuple[int, int]
    edge_spheres: int = 2000
    samplers: tuple[str, ...] = SAMPLERS

    @classmethod
    def full(cls) -> Config:
        return cls(quick=False, aa_size=(160, 90), spps=(1, 4, 16, 64, 256), reference_spp=4096, runs=5,
                   target_errors=(0.04, 0.028, 0.02, 0.014, 0.01, 0.007, 0.005, 0.0035, 0.0025), min_spps=(1, 2, 4, 8),
                   oracle_seeds=6,
                   timing_size=(480, 270), timing_spp=4, timing_runs=5, effects_size=(640, 360))

    @classmethod
    def quick_config(cls) -> Config:
        return cls(quick=True, aa_size=(80, 45), spps=(1, 4, 16), reference_spp=256, runs=1,
                   target_errors=(0.04, 0.01), min_spps=(4,), oracle_seeds=2, timing_size=(160, 90), timing_spp=4,
                   timing_runs=3, effects_size=(480, 270))

    @property
    def baselines(self) -> tuple[tuple[int, float], ...]:
        """(stratified spp, the share of its time adaptive must reach its error in): 64 in 1/3 and 256
        in 1/4 (quick: the largest measured spp below each)."""
        out = []
        for spp, share in ((64, 1 / 3), (256, 1 / 4)):
            measured = max([s for s in self.spps if s <= spp] or [min(self.spps)])
            if all(measured != b for b, _ in out):
                out.append((measured, share))
        return tuple(out)

    @property
    def adaptive_max_spps(self) -> tuple[int, ...]:
        """The maxima of the target_error sweep: each baseline's spp."""
        return tuple(spp for spp, _ in self.baselines)


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
    """Mean camera rays per pixel actually traced: the samples (adaptive: fewer than its spp maximum),
    and adaptive sampling's probes of strata's outsides, which are not samples (docs/accuracy.md)."""
    stats = result.stats
    return stats["rays"] / (stats["width"] * stats["height"])


# --- measurements ---------------------------------------------------------------------------------

@dataclass
class AAPoint:
    sampler: str
    spp: int                   # the spp argument (adaptive: the maximum)
    samples_per_pixel: float   # taken, on average
    rmse: float
    worst: float
    ms: float
    target_error: float | None = None     # adaptive's sweep only
    min_spp: int | None = None            # adaptive's sweep only
    estimated_rmse: float | None = None   # adaptive: the render's own estimate of `rmse`
    color: np.ndarray | None = field(default=None, repr=False)    # adaptive's sweep: the image
    samples: np.ndarray | None = field(default=None, repr=False)  # and its per-pixel sample counts


@dataclass
class BudgetPoint:
    """An adaptive render stopped by `time_limit`: what it reached against what it estimated."""

    time_limit: float | None   # seconds; None: no limit
    ms: float
    samples_per_pixel: float
    rmse: float
    estimated_rmse: float
    worst: float
    reached: bool              # stopped by the limit


@dataclass
class AntiAliasing:
    scene: str
    description: str
    width: int
    height: int
    reference_spp: int
    reference_ms: float
    points: list[AAPoint]
    sweep: list[AAPoint] = field(default_factory=list)  # adaptive's target_error x min_spp x max spp sweep
    reference: np.ndarray | None = field(default=None, repr=False)  # the reference's colour
    edge_share: float = float("nan")   # pixels whose reference differs from their centre sample by > 1e-3
    budget: list[BudgetPoint] = field(default_factory=list)  # adaptive under time limits
    oracle: dict[int, float] = field(default_factory=dict)   # stratified spp -> oracle_samples(...) for it
    oracle_fine: dict[int, float] = field(default_factory=dict)  # the same over oracle_counts(spp, fine=True)

    def slope(self, sampler: str) -> float:
        """Fitted log RMSE / log spp of a sampler's points (adaptive: against the samples it took)."""
        sel = [p for p in self.points if p.sampler == sampler]
        return fit_slope([p.samples_per_pixel if sampler == "adaptive" else p.spp for p in sel], [p.rmse for p in sel])

    def point(self, sampler: str, spp: int) -> AAPoint | None:
        return next((p for p in self.points if p.sampler == sampler and p.spp == spp), None)

    def cheapest_reaching(self, base: AAPoint) -> AAPoint | None:
        """The fastest adaptive render with `base`'s RMSE and worst pixel or better."""
        reached = [p for p in self.points + self.sweep
                   if p.sampler == "adaptive" and p.rmse <= base.rmse and p.worst <= base.worst]
        return min(reached, key=lambda p: p.ms, default=None)

    def heatmap_point(self, baselines: tuple[tuple[int, float], ...]) -> AAPoint | None:
        """The sweep's render the report's heat map shows: the cheapest reaching the first baseline's
        RMSE and worst pixel, else the one with the smallest RMSE."""
        base = self.point("stratified", baselines[0][0]) if baselines else None
        reaching = self.cheapest_reaching(base) if base is not None else None
        if reaching is not None and reaching.samples is not None:
            return reaching
        return min((p for p in self.sweep if p.samples is not None), key=lambda p: p.rmse, default=None)


def measure_antialiasing(name: str, description: str, scene: Scene, camera: Any, width: int, height: int,
                         spps: Sequence[int], reference_spp: int, runs: int, samplers: Sequence[str] = SAMPLERS,
                         target_errors: Sequence[float] = (), adaptive_max_spps: Sequence[int] = (),
                         min_spps: Sequence[int] = (4,)) -> AntiAliasing:
    """Every sampler at every spp, and adaptive's sweep of target_error x min_spp x max spp, against
    a `reference_spp` stratified double render."""
    start = time.perf_counter()
    reference = render(scene, camera, width, height, spp=reference_spp, seed=REFERENCE_SEED,
                       sampler=REFERENCE_SAMPLER, precision="double", passes=("color",))
    reference_ms = (time.perf_counter() - start) * 1000
    configs: list[tuple[str, int, float | None, int | None]] = [(s, n, None, None) for s in samplers for n in spps]
    configs += [("adaptive", n, e, m) for n in adaptive_max_spps for m in min_spps for e in target_errors]

    def renderer(sampler: str, spp: int, target_error: float | None, min_spp: int | None) -> Callable[..., RenderResult]:
        extra = {} if target_error is None else {"target_error": target_error, "min_spp": min_spp}
        return lambda out: render(scene, camera, width, height, spp=spp, seed=SEED, sampler=sampler,
                                  passes=("color",), **extra)

    medians, results = timed([renderer(*c) for c in configs], runs)
    points = []
    for (s, n, e, m), ms, r in zip(configs, medians, results):
        swept = e is not None
        points.append(AAPoint(s, n, samples_per_pixel(r), rmse(r.color, reference.color),
                              worst_pixel(r.color, reference.color), ms, e, m, r.stats.get("estimated_rmse"),
                              r.color if swept else None, r.samples if swept else None))
    centre = next((r for (s, n, _, _), r in zip(configs, results) if s == "center" and n == 1), None)
    edge_share = float("nan") if centre is None else \
        float(np.mean(pixel_errors(centre.color, reference.color) > 1e-3))
    aa = AntiAliasing(name, description, width, height, reference_spp, reference_ms,
                      [p for p in points if p.target_error is None], [p for p in points if p.target_error is not None],
                      reference.color, edge_share)
    return aa


def oracle_counts(limit: int, fine: bool) -> list[int]:
    """The Sobol counts up to `limit` an oracle chooses among: the powers of two (adaptive's), or
    also those in quarter steps between them (1 to 8, 10, 12, 14, 16, 20, 24, 28, 32, 40, ...)."""
    steps = (1.0, 1.25, 1.5, 1.75) if fine else (1.0,)
    counts = {int(2**k * s) for k in range(21) for s in steps if (2**k * s).is_integer()}
    return sorted(n for n in counts if n <= limit)


def measure_oracle(aa: AntiAliasing, scene: Scene, camera: Any, baselines: Sequence[int], seeds: int) -> None:
    """aa.oracle and aa.oracle_fine: for each stratified baseline, oracle_samples over
    oracle_counts(baseline) without and with the quarter steps, each pixel's error the RMS over
    `seeds` seeds (its expected error, not one draw's luck)."""
    errors = {}
    for n in oracle_counts(max(baselines, default=0), fine=True):
        squares = [pixel_errors(render(scene, camera, aa.width, aa.height, spp=n, seed=SEED + k, sampler="sobol",
                                       passes=("color",)).color, aa.reference) ** 2 for k in range(seeds)]
        errors[n] = np.sqrt(np.mean(squares, axis=0))
    for spp in baselines:
        base = aa.point("stratified", spp)
        if base is None:
            continue
        for bounds, fine in ((aa.oracle, False), (aa.oracle_fine, True)):
            bounds[spp] = oracle_samples({n: errors[n] for n in oracle_counts(spp, fine)}, base.rmse, base.worst)


def oracle_samples(errors: dict[int, np.ndarray], rmse_target: float, worst_target: float) -> float:
    """The fewest samples per pixel, on average, of an oracle that knows every pixel's error after
    each of the given Sobol counts (errors: spp -> (H, W) per-pixel errors) and gives each pixel
    one of those counts so that the image's RMSE and worst pixel meet the targets; inf if no choice
    does. A bound for any sampler that chooses among these counts per pixel, as adaptive does
    without the oracle's knowledge.
    Lagrangian relaxation: each pixel takes the count minimising n + lambda * error^2 among those
    within worst_target; lambda is found by bisection."""
    counts = np.array(sorted(errors), np.float64)
    squared = np.stack([errors[int(n)].ravel().astype(np.float64) ** 2 for n in counts])  # (counts, pixels)
    allowed = np.sqrt(squared) <= worst_target * (1 + 1e-9)
    if not allowed.any(axis=0).all():
        return float("inf")
    budget = rmse_target**2 * squared.shape[1] * (1 + 1e-9)  # a target met exactly is met

    def choose(lam: float) -> tuple[float, float]:
        cost = np.where(allowed, counts[:, None] + lam * squared, np.inf)
        pick = np.argmin(cost, axis=0)
        columns = np.arange(squared.shape[1])
        return float(counts[pick].mean()), float(squared[pick, columns].sum())

    low, high = 0.0, 1.0
    while choose(high)[1] > budget:
        high *= 4
        if high > 1e30:
            return float("inf")
    for _ in range(60):
        middle = (low + high) / 2
        low, high = (middle, high) if choose(middle)[1] > budget else (low, middle)
    return choose(high)[0]


def measure_budget(aa: AntiAliasing, scene: Scene, camera: Any, max_spp: int, target_error: float,
                   shares: Sequence[float] = (1 / 8, 1 / 4, 1 / 2)) -> list[BudgetPoint]:
    """Adaptive (max_spp, target_error) without a limit, then with time limits of `shares` of its
    time: the error each reached, measured and estimated. One render each, after a warm-up."""
    def run(limit: float | None) -> BudgetPoint:
        r = render(scene, camera, aa.width, aa.height, spp=max_spp, seed=SEED, sampler="adaptive",
                   target_error=target_error, time_limit=limit, passes=("color",))
        return BudgetPoint(limit, r.stats["milliseconds"], samples_per_pixel(r), rmse(r.color, aa.reference),
                           r.stats["estimated_rmse"], worst_pixel(r.color, aa.reference), r.stats["time_limit_reached"])

    run(None)
    free = run(None)
    return [*(run(free.ms / 1000 * share) for share in shares), free]


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
        secondary = sum(int(s[k]) for k in ("shadow_rays", "reflection_rays", "refraction_rays"))
        rows.append(EffectRow(name, ms, tuple(s["effects"]), secondary))
    return rows


@dataclass
class PresetRow:
    name: str
    settings: dict[str, Any]
    ms: float
    samples_per_pixel: float
    rmse: float
    worst: float


def measure_presets(scene: Scene, camera: Any, width: int, height: int, reference: np.ndarray, runs: int,
                    presets: dict[str, dict[str, Any]]) -> list[PresetRow]:
    names = list(presets)
    settings = [{"passes": ("color",), **presets[n]} for n in names]  # colour only, as the anti-aliasing renders
    renders = [lambda out, kw=kw: render(scene, camera, width, height, **kw) for kw in settings]
    medians, results = timed(renders, runs)
    return [PresetRow(n, dict(presets[n]), ms, samples_per_pixel(r), rmse(r.color, reference), worst_pixel(r.color, reference))
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
    occlusion: Occlusion | None = None


def measure(config: Config, command: str = "python -m durer accuracy", log: Callable[[str], Any] = print) -> Report:
    """Everything the page shows, measured now."""
    start = time.perf_counter()
    width, height = config.aa_size
    showcase, showcase_camera = showcase_scene()
    edges, edges_camera = edge_scene(config.edge_spheres)
    threads = _core.default_thread_count()  # what the renders below run on (threads=None)

    adaptive = "adaptive" in config.samplers
    sweep = dict(target_errors=config.target_errors if adaptive else (), adaptive_max_spps=config.adaptive_max_spps,
                 min_spps=config.min_spps)
    log(f"anti-aliasing: showcase, {width}x{height}, reference {config.reference_spp} spp ...")
    aa_showcase = measure_antialiasing(
        "showcase", f"the showcase scene ({showcase.sphere_count} spheres, a ground plane, a sun)", showcase,
        showcase_camera, width, height, config.spps, config.reference_spp, config.runs, config.samplers, **sweep)
    log(f"anti-aliasing: edges ({config.edge_spheres} small spheres) ...")
    aa_edges = measure_antialiasing(
        "edges", f"the edge-heavy scene ({config.edge_spheres} spheres of radius 0.02-0.08 on a plane, seen from "
        "above, one sun without shadows)", edges, edges_camera, width, height, config.spps, config.reference_spp,
        config.runs, config.samplers, **sweep)
    if adaptive:
        log("adaptive under time limits, and the oracle's bound ...")
        for aa, (scene, camera) in ((aa_showcase, (showcase, showcase_camera)), (aa_edges, (edges, edges_camera))):
            aa.budget = measure_budget(aa, scene, camera, max(config.adaptive_max_spps), min(config.target_errors))
            measure_oracle(aa, scene, camera, config.adaptive_max_spps, config.oracle_seeds)

    tw, th = config.timing_size
    log(f"precision and sphere method: {tw}x{th}, {config.timing_spp} spp ...")
    timings = measure_timings([("showcase", showcase, showcase_camera), ("edges", edges, edges_camera)],
                              tw, th, config.timing_spp, config.timing_runs)
    log("hard-case sweep (durer.reports.numerics) ...")
    sweep = numerics.sweep()
    ew, eh = config.effects_size
    log(f"effects: {ew}x{eh}, 1 spp ...")
    effects = measure_effects(showcase_camera, ew, eh, config.timing_runs)

    log(f"presets: {', '.join(PRESETS)} ...")
    preset_rows = measure_presets(showcase, showcase_camera, width, height, aa_showcase.reference, config.runs, PRESETS)
    report = Report(config, machine(), time.strftime("%Y-%m-%d %H:%M %Z"), command, threads,
                    [aa_showcase, aa_edges], timings, sweep, effects, preset_rows)
    from .occlusion import measure_occlusion  # it times with this module's timed()

    log("ambient occlusion ...")
    report.occlusion = measure_occlusion(config)
    report.seconds = time.perf_counter() - start
    return report
