"""Primary-ray throughput of Dürer, with a numpy ray caster measured in the same run as baseline.

    python bench/primary_rays.py [--quick] [--runs N] [--markdown FILE]

Every figure is the median (and min, max) over N timed renders of res.stats["mrays_per_s"], the
core's own wall-clock timer of the render, after one untimed warm-up render. Timed renders pass
`out=` so that they overwrite the warm-up's arrays, except the one "fresh" row, which shows what
the page faults of new numpy memory cost. The numpy baseline is checked against Dürer's depth and
colour before its speed is reported: a benchmark of a wrong baseline is worthless.
"""

from __future__ import annotations

import os

# Before numpy is imported (durer imports it too): idle OpenBLAS threads spin and would steal a core
# from the render being timed.
os.environ["OPENBLAS_NUM_THREADS"] = "1"

import argparse  # noqa: E402
import datetime  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import durer  # noqa: E402
import numpy as np  # noqa: E402
from durer.render import DEFAULT_PASSES  # noqa: E402
from durer.reports.machine import machine  # noqa: E402
from embree_compare import machine_busy_seconds  # noqa: E402

DEFAULT_RUNS = 7
MIN_RUNS_FOR_MEDIAN = 5
CONTENDED_SHARE = 0.85  # of a core per thread for our own process
BUSY_OTHERS = 0.2  # cores used by other processes
DEPTH_TOLERANCE = 1e-4
COLOR_DEPTH = ("color", "depth")
ALL_PASSES = DEFAULT_PASSES
RANDOM_SPHERES = 1000
RANDOM_SEED = 2024

# Both scenes at full size: scene (b) goes through the sphere hierarchy (a BVH from 16 spheres on).
FULL_SIZES = {"a": (1920, 1080), "b": (1920, 1080)}
QUICK_SIZES = {"a": (960, 540), "b": (320, 180)}
QUICK_RUNS = 5

REFERENCE = (
    "Reference (issue 13's target, not a pass/fail test): scene (a) >= 200 Mrays/s in float64, all passes, 2 cores",
    "  Intel Embree 3 on one sphere's camera rays: bench/embree_compare.py --workloads cube-1 (measured in its own run)",
)

# Dürer's material 0 is diffuse 0.8 grey, shown flat when the scene has no lights; the default
# background is opaque black.
FLAT_GREY = (0.8, 0.8, 0.8, 1.0)
BACKGROUND = (0.0, 0.0, 0.0, 1.0)


# --- scenes ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SceneSpec:
    """A scene's geometry kept as arrays, so that the numpy baseline can intersect the same objects."""

    key: str  # "a" or "b", as the scenes are named in the project's standards
    name: str
    centers: np.ndarray  # (N, 3)
    radii: np.ndarray  # (N,)
    plane_normal: tuple[float, float, float]
    plane_offset: float

    def build(self) -> durer.Scene:
        scene = durer.Scene()
        scene.add_spheres(self.centers, self.radii)
        scene.add_plane(self.plane_normal, self.plane_offset)
        return scene


CAMERA = durer.PerspectiveCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 60)


def sphere_and_plane() -> SceneSpec:
    return SceneSpec("a", "(a) 1 sphere + plane", np.array([[0.0, 0.0, 0.0]]), np.array([1.0]), (0, 1, 0), -1.0)


def random_spheres() -> SceneSpec:
    rng = np.random.default_rng(RANDOM_SEED)
    # A box the camera at z = 5 (looking down -z, 60° horizontal field of view) sees most of.
    centers = rng.uniform((-3.0, -0.7, -6.0), (3.0, 1.7, 1.0), size=(RANDOM_SPHERES, 3))
    radii = rng.uniform(0.05, 0.3, size=RANDOM_SPHERES)
    return SceneSpec("b", f"(b) {RANDOM_SPHERES:,} spheres + plane", centers, radii, (0, 1, 0), -1.0)


# --- measurements ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Measurement:
    """One table row: what was rendered, and the Mrays/s and CPU use of each timed run."""

    key: str
    scene: str
    width: int
    height: int
    passes: tuple[str, ...]
    precision: str
    threads: int
    buffers: str
    samples: tuple[float, ...]
    cpu_use: tuple[float, ...]  # process CPU seconds / wall seconds: the cores the run really had
    others: float | None  # cores other processes used meanwhile (None: no /proc/stat)

    @property
    def median(self) -> float:
        return statistics.median(self.samples)

    @property
    def contended(self) -> bool:
        """Other processes took CPU: the run got clearly less than a core per thread, or shared the
        machine (the two vCPUs may be SMT siblings, so a busy neighbour slows us without taking our CPU)."""
        starved = statistics.median(self.cpu_use) < CONTENDED_SHARE * self.threads
        return starved or (self.others is not None and self.others > BUSY_OTHERS)


@dataclass(frozen=True)
class CpuClock:
    """Wall time, this process's CPU time and the whole machine's busy CPU time, in seconds."""

    wall: float
    own: float
    machine: float | None

    @classmethod
    def now(cls) -> CpuClock:
        return cls(time.perf_counter(), time.process_time(), machine_busy_seconds())

    def others_since(self, start: CpuClock) -> float | None:
        """Cores that other processes used on average between `start` and now."""
        if self.machine is None or start.machine is None:
            return None
        return max(0.0, (self.machine - start.machine) - (self.own - start.own)) / (self.wall - start.wall)


def measure_durer(
    spec: SceneSpec,
    scene: durer.Scene,
    size: tuple[int, int],
    passes: tuple[str, ...],
    precision: str,
    threads: int | None,
    runs: int,
    reuse_buffers: bool = True,
) -> Measurement:
    width, height = size

    def render(out: durer.RenderResult | None) -> durer.RenderResult:
        return durer.render(scene, CAMERA, width, height, passes=passes, precision=precision, threads=threads, out=out)

    # The warm-up pays for the first touch of code, scene data and (with out=) the output arrays.
    first = render(None)
    samples, cpu_use = [], []
    start = CpuClock.now()
    for _ in range(runs):
        # process_time counts every thread of the process, so on an idle machine it is ~threads x wall.
        cpu_start = time.process_time()
        result = render(first if reuse_buffers else None)
        cpu_use.append((time.process_time() - cpu_start) / (result.stats["milliseconds"] / 1000))
        samples.append(result.stats["mrays_per_s"])
    others = CpuClock.now().others_since(start)
    return Measurement(
        spec.key,
        spec.name,
        width,
        height,
        passes,
        precision,
        first.stats["threads"],
        "out=" if reuse_buffers else "fresh",
        tuple(samples),
        tuple(cpu_use),
        others,
    )


# --- numpy baseline ----------------------------------------------------------------------------------
def numpy_camera_rays(width: int, height: int) -> np.ndarray:
    """Unit pixel-centre directions (H, W, 3) of CAMERA, built like Dürer's camera (fit "auto")."""
    direction, up = (np.asarray(v, dtype=np.float64) for v in (CAMERA.direction, CAMERA.up))
    forward = direction / np.linalg.norm(direction)
    horizontal = np.cross(forward, up / np.linalg.norm(up))
    horizontal /= np.linalg.norm(horizontal)
    true_up = np.cross(horizontal, forward)
    pixel_size = 2 * math.tan(math.radians(CAMERA.fov_degrees) / 2) / max(width, height)
    x = (np.arange(width) + 0.5) * pixel_size - 0.5 * width * pixel_size
    y = 0.5 * height * pixel_size - (np.arange(height) + 0.5) * pixel_size
    directions: np.ndarray = forward + x[None, :, None] * horizontal + y[:, None, None] * true_up
    return directions / np.sqrt(np.sum(directions * directions, axis=-1, keepdims=True))


def numpy_render(spec: SceneSpec, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """A straightforward vectorised ray caster: colour (H, W, 4) float32 and depth (H, W) float32."""
    origin = np.asarray(CAMERA.center, dtype=np.float64)
    directions = numpy_camera_rays(width, height)
    dx, dy, dz = directions[..., 0], directions[..., 1], directions[..., 2]
    depth = np.full((height, width), np.inf)
    for center, radius in zip(spec.centers, spec.radii, strict=True):
        # |o + t d - c|² = r² with |d| = 1: t² + 2 b t + c = 0.
        f = origin - center
        b = f[0] * dx + f[1] * dy + f[2] * dz
        c = f @ f - radius * radius
        with np.errstate(invalid="ignore"):
            root = np.sqrt(b * b - c)  # NaN on a miss, and NaN never wins np.fmin below
        near, far = -b - root, -b + root
        t = np.where(near >= 0, near, far)
        t[t < 0] = np.nan  # the sphere is behind the camera
        np.fmin(depth, t, out=depth)
    normal = np.asarray(spec.plane_normal, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_plane = (spec.plane_offset - normal @ origin) / (normal[0] * dx + normal[1] * dy + normal[2] * dz)
    t_plane[~(t_plane >= 0)] = np.nan
    np.fmin(depth, t_plane, out=depth)
    color = np.empty((height, width, 4), dtype=np.float32)
    color[...] = BACKGROUND
    color[np.isfinite(depth)] = FLAT_GREY
    return color, depth.astype(np.float32)


def measure_numpy(spec: SceneSpec, size: tuple[int, int], runs: int) -> Measurement:
    width, height = size
    numpy_render(spec, width, height)  # warm-up, as for Dürer
    samples, cpu_use = [], []
    first = CpuClock.now()
    for _ in range(runs):
        start = CpuClock.now()
        numpy_render(spec, width, height)
        end = CpuClock.now()
        samples.append(width * height / (end.wall - start.wall) / 1e6)
        cpu_use.append((end.own - start.own) / (end.wall - start.wall))
    others = CpuClock.now().others_since(first)
    name = "(a) numpy baseline"
    return Measurement(
        spec.key, name, width, height, COLOR_DEPTH, "double", 1, "fresh", tuple(samples), tuple(cpu_use), others
    )


@dataclass(frozen=True)
class BaselineCheck:
    ray_difference: float  # max |numpy direction - camera.rays direction|
    hit_mismatches: int  # pixels that one caster hits and the other misses
    depth_difference: float  # max |Δdepth| where both hit
    depth_excess: float  # max |Δdepth| / its tolerance where both hit: <= 1 passes
    color_mismatches: int  # pixels whose colours differ

    @property
    def passed(self) -> bool:
        return (
            self.ray_difference < 1e-12
            and self.hit_mismatches == 0
            and self.depth_excess <= 1
            and self.color_mismatches == 0
        )


def depth_tolerance(depth: np.ndarray) -> np.ndarray:
    # Dürer's depth pass is float32: the plane near the horizon is hit at t ~ 3300, where one float32
    # step is ~2.4e-4, so the 1e-4 tolerance gets a float32 ulp of the depth on top.
    return DEPTH_TOLERANCE + depth * np.finfo(np.float32).eps


def check_baseline(spec: SceneSpec, scene: durer.Scene, size: tuple[int, int]) -> BaselineCheck:
    width, height = size
    _, reference_directions = CAMERA.rays(width, height)
    ray_difference = float(np.max(np.abs(numpy_camera_rays(width, height) - reference_directions)))
    color, depth = numpy_render(spec, width, height)
    result = durer.render(scene, CAMERA, width, height, passes=COLOR_DEPTH, precision="double")
    assert result.color is not None and result.depth is not None  # both passes were requested
    hit, durer_hit = np.isfinite(depth), np.isfinite(result.depth)
    both = hit & durer_hit
    difference = np.abs(depth[both].astype(np.float64) - result.depth[both])
    return BaselineCheck(
        ray_difference,
        int(np.count_nonzero(hit != durer_hit)),
        float(difference.max(initial=0.0)),
        float((difference / depth_tolerance(depth[both])).max(initial=0.0)),
        int(np.count_nonzero(np.any(color != result.color, axis=-1))),
    )


# --- the benchmark -----------------------------------------------------------------------------------
def log(message: str) -> None:
    """Progress goes to stderr so that stdout holds only the report."""
    print(message, file=sys.stderr)


def run_benchmark(sizes: dict[str, tuple[int, int]], runs: int) -> tuple[list[Measurement], Measurement, BaselineCheck]:
    spec_a, spec_b = sphere_and_plane(), random_spheres()
    scene_a, scene_b = spec_a.build(), spec_b.build()
    rows: list[Measurement] = []
    for spec, scene, passes in (
        (spec_a, scene_a, COLOR_DEPTH),
        (spec_a, scene_a, ALL_PASSES),
        (spec_b, scene_b, COLOR_DEPTH),
    ):
        for precision in ("double", "float"):
            for threads in (1, None):
                log(f"  {spec.name}, {'+'.join(passes)}, {precision}, threads={threads or 'all'}")
                rows.append(measure_durer(spec, scene, sizes[spec.key], passes, precision, threads, runs))
        if passes == COLOR_DEPTH and spec is spec_a:
            log("  (a) fresh buffers")
            rows.append(measure_durer(spec, scene, sizes["a"], passes, "double", None, runs, reuse_buffers=False))
    log("  numpy baseline")
    check = check_baseline(spec_a, scene_a, sizes["a"])
    baseline = measure_numpy(spec_a, sizes["a"], runs)
    return rows, baseline, check


def find(rows: Sequence[Measurement], key: str, passes: tuple[str, ...], precision: str, single: bool) -> Measurement:
    """The out= row of Dürer on scene `key` with these settings, on 1 thread or on all."""
    for row in rows:
        if (
            row.key == key
            and row.passes == passes
            and row.precision == precision
            and row.buffers == "out="
            and (row.threads == 1) == single
        ):
            return row
    raise LookupError(f"no row for scene {key} {passes} {precision}")


# --- reporting ---------------------------------------------------------------------------------------
HEADER = (
    "Scene",
    "Image",
    "Passes",
    "Precision",
    "Threads",
    "Buffers",
    "Median Mrays/s",
    "Min",
    "Max",
    "CPU/wall",
    "Others",
)


def table_cells(rows: Sequence[Measurement]) -> list[tuple[str, ...]]:
    return [
        (
            row.scene,
            f"{row.width}x{row.height}",
            "+".join(row.passes),
            row.precision,
            str(row.threads),
            row.buffers,
            mrays(row.median),
            mrays(min(row.samples)),
            mrays(max(row.samples)),
            f"{statistics.median(row.cpu_use):.2f}",
            ("n/a" if row.others is None else f"{row.others:.2f}") + (" !" if row.contended else ""),
        )
        for row in rows
    ]


def mrays(value: float) -> str:
    # Scene (b) runs at ~1 Mrays/s, where one decimal would hide a 10 % change.
    return f"{value:.2f}" if value < 10 else f"{value:.1f}"


# Tables shared by the bench scripts: labels left-aligned, the columns from numeric_from on numbers.
def text_table(header: Sequence[str], cells: Sequence[Sequence[str]], numeric_from: int) -> str:
    widths = [max(len(line[i]) for line in (header, *cells)) for i in range(len(header))]

    def line(values: Sequence[str]) -> str:
        return "  ".join(
            v.rjust(w) if i >= numeric_from else v.ljust(w) for i, (v, w) in enumerate(zip(values, widths, strict=True))
        )

    return "\n".join([line(header), "  ".join("-" * w for w in widths), *(line(c) for c in cells)])


def markdown_table(header: Sequence[str], cells: Sequence[Sequence[str]], numeric_from: int) -> str:
    rule = ["---:" if i >= numeric_from else "---" for i in range(len(header))]
    return "\n".join("| " + " | ".join(values) + " |" for values in (header, rule, *cells))


def machine_lines() -> list[str]:
    load = ", ".join(f"{value:.2f}" for value in os.getloadavg())
    return [
        f"CPU: {cpu_model()}, {os.cpu_count()} cores (os.cpu_count()); load average at the end: {load}",
        f"Python {platform.python_version()}, numpy {np.__version__}, durer {durer.__version__}",
        f"Date: {datetime.datetime.now().astimezone().isoformat(timespec='seconds')}",
    ]


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def summary_lines(rows: Sequence[Measurement], baseline: Measurement, check: BaselineCheck) -> list[str]:
    return [
        *check_lines(check, baseline),
        speedup_line(rows, baseline),
        *reference_lines(rows),
        *contention_lines(rows),
    ]


def check_lines(check: BaselineCheck, baseline: Measurement) -> list[str]:
    verdict = "OK" if check.passed else "FAILED: the speed-ups below are meaningless"
    rays = f"max |numpy - camera.rays| = {check.ray_difference:.1e}"
    mismatches = f"hit/miss mismatches: {check.hit_mismatches} pixels, colour: {check.color_mismatches} pixels"
    depth = f"max |diff| = {check.depth_difference:.2e}, max |diff| / tolerance = {check.depth_excess:.2f}"
    tolerance = f"tolerance {DEPTH_TOLERANCE:g} + depth x float32 eps"
    return [
        f"numpy baseline check vs Dürer (double, {baseline.width}x{baseline.height}): {verdict}",
        f"  rays: {rays}; {mismatches}",
        f"  depth where both hit: {depth} ({tolerance})",
    ]


def speedup_line(rows: Sequence[Measurement], baseline: Measurement) -> str:
    all_threads = find(rows, "a", COLOR_DEPTH, "double", single=False)
    one_thread = find(rows, "a", COLOR_DEPTH, "double", single=True)
    ratios = (
        f"{all_threads.median / baseline.median:.1f}x on {all_threads.threads} threads, "
        f"{one_thread.median / baseline.median:.1f}x on 1 thread"
    )
    return f"durer / numpy, (a) double color+depth: {ratios} (numpy: {baseline.median:.1f} Mrays/s, 1 thread)"


def reference_lines(rows: Sequence[Measurement]) -> list[str]:
    target = find(rows, "a", ALL_PASSES, "double", single=False)
    where = f"(a) double all passes, {target.threads} threads, {target.width}x{target.height}"
    return [*REFERENCE, f"  measured here: {target.median:.1f} Mrays/s ({where})"]


def contention_lines(rows: Sequence[Measurement]) -> list[str]:
    contended = sum(row.contended for row in rows)
    if not contended:
        return []
    rows_text = f"{contended} row{'s' if contended > 1 else ''} (marked !)"
    why = f"CPU/wall < {CONTENDED_SHARE} x threads or Others > {BUSY_OTHERS} cores"
    return [f"WARNING: {rows_text} shared the machine ({why}), so their figures are low; rerun on an idle machine"]


def report(
    rows: Sequence[Measurement], baseline: Measurement, check: BaselineCheck, runs: int, quick: bool
) -> tuple[str, str]:
    """The report as plain text and as Markdown."""
    intro = [
        f"Dürer primary-ray throughput ({'quick' if quick else 'full'} run), spp=1, sphere_method robust",
        *machine_lines(),
        (
            f"Each figure: median/min/max over {runs} timed renders of res.stats['mrays_per_s'] (the core's own "
            "timer), after one untimed warm-up; 'out=' reuses the warm-up's buffers, 'fresh' allocates new ones."
        ),
        (
            f"Scene (b): seeded random spheres (seed {RANDOM_SEED}, radii 0.05-0.3), traced through the sphere "
            "hierarchy (BVH). numpy baseline timed with perf_counter."
        ),
        (
            "CPU/wall: median process CPU time / render time (~= threads when alone); Others: cores that other "
            "processes used meanwhile (from /proc/stat; ~0 on an idle machine)."
        ),
    ]
    cells = table_cells([*rows, baseline])
    summary = summary_lines([*rows, baseline], baseline, check)
    numeric_from = HEADER.index("Median Mrays/s")
    text = "\n".join([*intro, "", text_table(HEADER, cells, numeric_from), "", *summary])
    markdown = "\n".join(
        ["## Primary rays", "", *map(bullet, intro), "", markdown_table(HEADER, cells, numeric_from), "",
         *map(bullet, summary), ""]
    )
    return text, markdown


def bullet(line: str) -> str:
    """A Markdown list item; the text report's indented lines become nested items."""
    return f"  - {line[2:]}" if line.startswith("  ") else f"- {line}"


def machine_line(others: float | None) -> str:
    """The machine, the time, and the cores other processes used while measuring (None: unknown)."""
    used = "n/a" if others is None else f"{others:.2f} cores"
    return f"{machine()}; {time.strftime('%Y-%m-%d %H:%M %Z')}; other processes used {used} meanwhile"


def print_report(intro: Sequence[str], header: Sequence[str], cells: Sequence[Sequence[str]], numeric_from: int,
                 notes: Sequence[str], path: Path | None) -> None:
    """Prints the intro lines, the table of `cells` under `header` and the notes; with a path, writes
    them there as Markdown too (the lines as bullets around the Markdown table). Shared by the other
    bench scripts."""
    print("\n".join([*intro, "", text_table(header, cells, numeric_from), "", *notes]))
    if path:
        bullets = [f"- {line}" for line in intro], [f"- {line}" for line in notes]
        markdown = markdown_table(header, cells, numeric_from)
        path.write_text("\n".join([*bullets[0], "", markdown, "", *bullets[1], ""]), encoding="utf-8")


def positive_int(value: str) -> int:
    number = int(value)
    if number < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {number}")
    return number


def parse_arguments(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--quick", action="store_true", help=f"smaller images and {QUICK_RUNS} runs (unless --runs)")
    parser.add_argument(
        "--runs", type=positive_int, metavar="N", help=f"timed renders per row (default {DEFAULT_RUNS})"
    )
    parser.add_argument("--markdown", type=Path, metavar="FILE", help="also write the report as Markdown to FILE")
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_arguments(argv)
    runs = args.runs or (QUICK_RUNS if args.quick else DEFAULT_RUNS)
    if runs < MIN_RUNS_FOR_MEDIAN:
        log(f"warning: a median of {runs} runs is noisy; the project's standard is >= {MIN_RUNS_FOR_MEDIAN}")
    sizes = QUICK_SIZES if args.quick else FULL_SIZES
    log("measuring...")
    rows, baseline, check = run_benchmark(sizes, runs)
    text, markdown = report(rows, baseline, check, runs, args.quick)
    print(text)
    if args.markdown:
        args.markdown.write_text(markdown, encoding="utf-8")
        print(f"\nMarkdown written to {args.markdown}")
    return 0 if check.passed else 1


if __name__ == "__main__":
    sys.exit(main())
