"""Secondary-ray throughput: many small spheres with a sun casting shadows and a mirror-like
material, counting every ray the render traces (issue 13's benchmark).

    python bench/secondary_rays.py [--full] [--runs N] [--threads 2] [--light point] [--markdown FILE]

The scene: 200,000 spheres of radius 0.05 uniform in the cube [-10, 10]^3 (seeded) over a ground
plane 0.5 below the cube, every surface diffuse grey and 50 % reflective, a sun with shadows, a
perspective camera 15 units in front of the cube looking at it (60° field of view), 1 spp, up to 4
bounces (the render's default); `--light point`: a point light above the cube instead of the sun
(Blender's default light; its shadow rays search six perspective views from it, not the sun's one).
Each precision renders it depth only (camera rays alone) and in colour (camera + shadow + reflection
rays). Mrays/s counts ALL rays: stats' rays + shadow_rays + reflection_rays + refraction_rays over
the core's own render time. Tests per ray: stats["intersection_tests"] over all rays. CPU/wall: the cores the render really had (~threads when
the machine is idle); Mrays/CPU-s: all rays per second of that CPU time, which on a shared machine
(x threads) estimates an idle machine's figure better than the wall-clock one.

Against Intel Embree 3 (when installed: Debian's libembree-dev; `--no-embree` skips it): bench/embree's
harness (built as bench/embree_compare.py builds it) makes the same scene (its spheres drawn by its
own generator, under the same light) and the shadow and reflection rays its colour render traces at
the same size (the scene's ray tree, found with durer::cast: as many rays as the render's, within
about 1 %), then traces them with Embree's calls for incoherent rays (rtcIntersect1 for the
reflection rays, rtcOccluded1 for the shadow rays) and with Dürer's (durer::cast for the reflection
rays, its occlusion query -- durer.occluded's -- for the shadow rays), interleaved, on the same
threads. The report prints both and what Embree's speed on these rays bounds: were the render's
camera rays and shading free, its secondary rays alone at Embree's speed cap the all-rays Mrays/s.

Default: 320x180 (today's colour render takes about a second); `--full`: 1920x1080, the issue's
size (about a minute per colour render before the issue's traversal work). Every figure is the
median of --runs rounds that render every row once (so the machine's drift hits all rows alike),
into the warm-up's buffers, after one warm-up render of each row that also builds the hierarchy.
"""

from __future__ import annotations

import os

# Before numpy is imported (durer imports it too): idle OpenBLAS threads spin and would steal a core.
os.environ["OPENBLAS_NUM_THREADS"] = "1"

import argparse  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import durer  # noqa: E402
import numpy as np  # noqa: E402
import embree_compare  # noqa: E402
from primary_rays import (  # noqa: E402
    BUSY_OTHERS, CONTENDED_SHARE, CpuClock, machine_line, positive_int, print_report)

SPHERES = 200_000
RADIUS = 0.05
SEED = 13
QUICK_SIZE = (320, 180)
FULL_SIZE = (1920, 1080)
QUICK_RUNS, FULL_RUNS = 5, 3
THREADS = 2
PRECISIONS = ("double", "float")
MODES = {"depth only": ("depth",), "colour": ("color",)}
RAY_KINDS = ("rays", "shadow_rays", "reflection_rays", "refraction_rays")  # camera rays first
TARGET_MRAYS = 10.0  # issue 13: all rays, double, 2 threads, 1920x1080

CAMERA = durer.PerspectiveCamera((0, 0, 25), (0, 0, -1), (0, 1, 0), fov_degrees=60)
LIGHTS = ("sun", "point")
# The point light: above a corner of the cube, without falloff (the 6.837 light), so that it lights
# the spheres as brightly as the sun does.
POINT_LIGHT = (15.0, 30.0, 15.0)
# bench/embree's workload of each light's scene (its Workload.cpp lights them the same way).
EMBREE_KINDS = {"sun": "secondary", "point": "secondary-point"}


def secondary_scene(spheres: int = SPHERES, seed: int = SEED, light: str = "sun") -> durer.Scene:
    """The issue's scene: `spheres` small reflective spheres in a 20-unit cube over a reflective
    ground plane, lit by a sun casting shadows (or a point light: `light`)."""
    rng = np.random.default_rng(seed)
    scene = durer.Scene()
    mirror_grey = scene.add_material(diffuse=(0.6, 0.6, 0.6), reflective=(0.5, 0.5, 0.5))
    scene.add_spheres(rng.uniform(-10, 10, (spheres, 3)), RADIUS, material=mirror_grey)
    scene.add_plane((0, 1, 0), -10.5, material=mirror_grey)
    if light == "sun":
        scene.add_directional_light((-1, -2, -1), (1, 1, 1), shadows=True)
    else:
        scene.add_point_light(POINT_LIGHT, (1, 1, 1), shadows=True)
    return scene


@dataclass(frozen=True)
class Row:
    """One configuration's ray counts (the same in every run: the render is deterministic) and times."""

    mode: str
    precision: str
    counts: dict[str, int]  # RAY_KINDS and intersection_tests
    milliseconds: tuple[float, ...]
    cpu_use: tuple[float, ...]  # process CPU seconds / render seconds: the cores the render really had

    @property
    def rays(self) -> int:
        return sum(self.counts[kind] for kind in RAY_KINDS)

    @property
    def median_ms(self) -> float:
        return statistics.median(self.milliseconds)

    def mrays_per_s(self, ms: float) -> float:
        return self.rays / ms / 1e3

    @property
    def mrays_per_cpu_second(self) -> float:
        """Rays per second of CPU time the render really had: on a shared machine, a figure that
        other processes' load lowers less than wall-clock Mrays/s (x threads ~ an idle machine's)."""
        return statistics.median(self.rays / (ms / 1000 * cpu) / 1e6
                                 for ms, cpu in zip(self.milliseconds, self.cpu_use, strict=True))

    @property
    def tests_per_ray(self) -> float:
        return self.counts["intersection_tests"] / self.rays


def measure(scene: durer.Scene, size: tuple[int, int], runs: int, threads: int) -> tuple[list[Row], float | None]:
    """Every (mode, precision) row, timed round-robin; and the cores other processes used meanwhile."""
    width, height = size
    configs = [(mode, precision) for precision in PRECISIONS for mode in MODES]

    def render(mode: str, precision: str, out: durer.RenderResult | None) -> durer.RenderResult:
        return durer.render(scene, CAMERA, width, height, passes=MODES[mode], precision=precision,
                            threads=threads, out=out)

    results = [render(mode, precision, None) for mode, precision in configs]  # warm-up: hierarchy, buffers
    times: list[list[float]] = [[] for _ in configs]
    cpu: list[list[float]] = [[] for _ in configs]
    start = CpuClock.now()
    for _ in range(runs):
        for i, (mode, precision) in enumerate(configs):
            cpu_start = time.process_time()
            results[i] = render(mode, precision, results[i])
            ms = results[i].stats["milliseconds"]
            times[i].append(ms)
            cpu[i].append((time.process_time() - cpu_start) / (ms / 1000))
    others = CpuClock.now().others_since(start)
    rows = [
        Row(mode, precision, {k: int(result.stats[k]) for k in (*RAY_KINDS, "intersection_tests")},
            tuple(times[i]), tuple(cpu[i]))
        for i, ((mode, precision), result) in enumerate(zip(configs, results, strict=True))
    ]
    return rows, others


@dataclass(frozen=True)
class EmbreeRays:
    """bench/embree's secondary workload: the scene's shadow and reflection rays traced by Embree
    (rtcOccluded1, rtcIntersect1) and by durer::cast (times in ms, one per interleaved round)."""

    rays: int
    embree_ms: tuple[float, ...]
    durer_ms: dict[str, tuple[float, ...]]  # by precision
    agrees: bool

    def mrays_per_s(self, times: Sequence[float]) -> float:
        return self.rays / statistics.median(times) / 1e3


def measure_embree(spheres: int, size: tuple[int, int], runs: int, threads: int,
                   light: str = "sun") -> EmbreeRays | str:
    """Embree and durer::cast on the scene's secondary rays, or why they were not measured."""
    embree_dir = embree_compare.find_embree()
    if embree_dir is None:
        return "Intel Embree 3 not found (Debian: libembree-dev): no comparison"
    native = embree_compare.native_flags()
    print(f"building {embree_compare.EXECUTABLE} in {embree_compare.build_dir(native)} (a clean build takes about a "
          "minute)...", file=sys.stderr)
    executable = embree_compare.build_executable(embree_dir, native)
    kind = EMBREE_KINDS[light]
    workload = embree_compare.Workload(kind, kind, spheres)
    result = embree_compare.run_workload(executable, workload, size, runs, threads)
    report = result.report
    return EmbreeRays(report["rays"]["embree"], tuple(report["embree"]["trace_ms"]),
                      {p: tuple(report[f"durer_{p}"]["cached_ms"]) for p in PRECISIONS}, result.agrees)


def embree_lines(embree: EmbreeRays | str, rows: Sequence[Row], threads: int) -> list[str]:
    """What Embree's speed on the secondary rays says next to the render's."""
    if isinstance(embree, str):
        return [embree]
    if not embree.agrees:
        return ["Embree and durer::cast DISAGREE on the secondary rays' hits: not timed"]
    speed = embree.mrays_per_s(embree.embree_ms)
    durer_speeds = {p: embree.mrays_per_s(embree.durer_ms[p]) for p in PRECISIONS}
    colour = next(r for r in rows if r.mode == "colour" and r.precision == "double")
    secondary = colour.rays - colour.counts["rays"]
    ceiling = colour.rays / (secondary / speed)
    return [
        f"Intel Embree 3 on this scene's shadow + reflection rays ({embree.rays:,}, the render's {secondary:,}; "
        f"rtcIntersect1 for the reflection rays, rtcOccluded1 for the shadow rays, {threads} threads): "
        f"{statistics.median(embree.embree_ms):.1f} ms = {speed:.3g} Mrays/s; Dürer's cast of the same rays "
        "(durer.cast, durer.occluded for the shadow rays): "
        + ", ".join(f"{p} {statistics.median(embree.durer_ms[p]):.1f} ms = {durer_speeds[p]:.3g} Mrays/s "
                    f"({durer_speeds[p] / speed:.2f}x Embree's)" for p in PRECISIONS),
        f"At Embree's speed the double colour render's {secondary:,} secondary rays alone take "
        f"{secondary / speed / 1e3:.1f} ms: with its camera rays and shading free it would reach at most "
        f"{ceiling:.3g} Mrays/s counting all rays (the target: {TARGET_MRAYS:g})",
    ]


HEADER = ("Render", "Precision", "Camera", "Shadow", "Reflection", "Refraction", "All rays", "Tests",
          "Tests/ray", "Median ms", "Min ms", "Max ms", "Mrays/s (all)", "CPU/wall",
          "Mrays/CPU-s")


def cells(row: Row) -> tuple[str, ...]:
    c = row.counts
    return (row.mode, row.precision, f"{c['rays']:,}", f"{c['shadow_rays']:,}", f"{c['reflection_rays']:,}",
            f"{c['refraction_rays']:,}", f"{row.rays:,}", f"{c['intersection_tests']:,}",
            f"{row.tests_per_ray:.1f}", f"{row.median_ms:.1f}", f"{min(row.milliseconds):.1f}",
            f"{max(row.milliseconds):.1f}", f"{row.mrays_per_s(row.median_ms):.3g}",
            f"{statistics.median(row.cpu_use):.2f}", f"{row.mrays_per_cpu_second:.3g}")


def summary(rows: Sequence[Row], size: tuple[int, int], others: float | None, threads: int) -> list[str]:
    lines = []
    for precision in PRECISIONS:
        depth, colour = (next(r for r in rows if r.mode == m and r.precision == precision) for m in MODES)
        secondary = colour.rays - colour.counts["rays"]
        # The camera rays make the same tests in both renders and shading makes none itself (it
        # spawns the secondary rays), so the colour render's extra tests are the secondary rays'.
        extra = colour.counts["intersection_tests"] - depth.counts["intersection_tests"]
        lines.append(f"{precision}: colour {colour.mrays_per_s(colour.median_ms):.3g} Mrays/s counting all "
                     f"{colour.rays:,} rays; {extra / secondary:.0f} tests per secondary ray "
                     f"(the colour render's tests beyond depth only's, over its {secondary:,} shadow + "
                     f"reflection + refraction rays)")
    double = next(r for r in rows if r.mode == "colour" and r.precision == "double")
    lines.append(f"Target (issue 13, not a pass/fail test): >= {TARGET_MRAYS:g} Mrays/s all rays, double, colour, "
                 f"2 threads, 1920x1080; measured here {double.mrays_per_s(double.median_ms):.3g} at "
                 f"{size[0]}x{size[1]} on {threads} threads")
    starved = sum(statistics.median(r.cpu_use) < CONTENDED_SHARE * threads for r in rows)
    if starved or (others is not None and others > BUSY_OTHERS):
        lines.append(f"WARNING: the machine was shared ({starved} of {len(rows)} rows had < {CONTENDED_SHARE} x "
                     f"{threads} cores; other processes' load is on the second line): figures are low, "
                     "rerun on an idle machine")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true", help=f"{FULL_SIZE[0]}x{FULL_SIZE[1]} (default "
                        f"{QUICK_SIZE[0]}x{QUICK_SIZE[1]}), {FULL_RUNS} runs unless --runs")
    parser.add_argument("--runs", type=positive_int, help=f"timed rounds (default {QUICK_RUNS}, --full {FULL_RUNS})")
    parser.add_argument("--threads", type=positive_int, default=THREADS)
    parser.add_argument("--spheres", type=positive_int, default=SPHERES)
    parser.add_argument("--markdown", type=Path, metavar="FILE", help="also write the report as Markdown to FILE")
    parser.add_argument("--no-embree", action="store_true", help="skip the comparison with Intel Embree 3")
    parser.add_argument("--light", choices=LIGHTS, default="sun", help="the light casting shadows")
    args = parser.parse_args(argv)
    size = FULL_SIZE if args.full else QUICK_SIZE
    runs = args.runs or (FULL_RUNS if args.full else QUICK_RUNS)
    print(f"measuring {len(PRECISIONS) * len(MODES)} renders x {runs + 1}...", file=sys.stderr)
    rows, others = measure(secondary_scene(args.spheres, light=args.light), size, runs, args.threads)
    if args.no_embree:
        embree = "Intel Embree 3: not compared (--no-embree)"
    else:
        embree = measure_embree(args.spheres, size, runs, args.threads, args.light)
    lit = "sun" if args.light == "sun" else f"point light at {POINT_LIGHT}"
    intro = [
        f"Secondary rays: {args.spheres:,} spheres (r {RADIUS}, seed {SEED}) + plane, {lit} with shadows, 50 % "
        f"reflective, perspective, {size[0]}x{size[1]}, 1 spp, {args.threads} threads; median of {runs} rounds",
        machine_line(others),
    ]
    print_report(intro, HEADER, [cells(row) for row in rows], 2,
                 summary(rows, size, others, args.threads) + embree_lines(embree, rows, args.threads), args.markdown)
    return 0


if __name__ == "__main__":
    sys.exit(main())
