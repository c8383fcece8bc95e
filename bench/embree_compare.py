"""Dürer against Intel Embree 3 on the same spheres and the same camera rays (or given rays), in one run.

    python bench/embree_compare.py [--quick] [--workloads cube-1k,slab-1m] [--runs N] [--markdown FILE]

Builds bench/embree's C++ executable (durer_embree_bench, linking Dürer's core and Embree) in its own
build folder, then runs each workload in its own process, which checks that both images agree
before it times anything and reports JSON. Embree traces Dürer's own float camera rays
(RTC_GEOMETRY_TYPE_SPHERE_POINT, rtcIntersect8 packets, rtcOccluded8 shadow rays) on 2 threads;
Dürer renders through its public C++ API `durer::render` (depth only; colour with the sun), float
and double, 2 threads. The bounce workload gives both a ray per pixel instead, leaving a random
sphere's surface in a random direction (incoherent, as reflection and shadow rays are): Embree
traces each with rtcIntersect1, Dürer casts them all with `durer::cast`; the secondary workload
gives both the shadow and reflection rays of bench/secondary_rays.py's colour render (its scene's
ray tree, found with durer::cast), traced the same way but for the shadow rays, which both trace
as occlusion queries (any hit: Embree's rtcOccluded1, durer::cast's anyHit); secondary-point gives
those of the same scene under its point light (shadow rays that end at the light). Every time is a
median over interleaved rounds (Embree, Dürer float, Dürer double) after an untimed first pass.
Dürer's core is compiled as the package's own build was (its compiler and DURER_NATIVE, so that
ccache reuses its objects; set DURER_NATIVE=0/1 to choose), in build/bench-embree or
build/bench-embree-native. Needs Embree 3 (Debian: `apt-get install libembree-dev`); exit status 2
without it, 1 when a workload's images disagree.
"""

from __future__ import annotations

import argparse
import datetime
import glob
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import sysconfig
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXECUTABLE = "durer_embree_bench"
THREADS = 2
FULL_SIZE = (1920, 1080)
QUICK_SIZE = (480, 270)
DEFAULT_RUNS = 5
QUICK_RUNS = 3
QUICK_SPHERES_DIVISOR = 100  # --quick traces 1/100 of each workload's spheres (at least 1)
MEMORY_MIN_SPHERES = 100_000  # below, pages and fixed buffers dominate the bytes per sphere
BUSY_OTHERS = 0.2  # cores other processes used while a workload ran, above which its times are suspect
INSTALL_HINT = (
    "Intel Embree 3 was not found: install it (Debian/Ubuntu: `sudo apt-get install libembree-dev`) "
    "or point embree_DIR at the folder holding embree-config.cmake."
)


@dataclass(frozen=True)
class Workload:
    """A named run of the executable: its kind (bench/embree/Workload.cpp) and sphere count."""

    name: str
    kind: str
    spheres: int

    def scaled(self, quick: bool) -> Workload:
        spheres = max(1, self.spheres // QUICK_SPHERES_DIVISOR) if quick else self.spheres
        return Workload(self.name, self.kind, spheres)


# The workloads, in its order.
WORKLOADS = (
    Workload("cube-1", "cube", 1),
    Workload("cube-1k", "cube", 1_000),
    Workload("cube-100k", "cube", 100_000),
    Workload("cube-1m", "cube", 1_000_000),
    Workload("cube-10m", "cube", 10_000_000),
    Workload("slab-1m", "slab", 1_000_000),
    Workload("slab-sun-1m", "slab-sun", 1_000_000),
    Workload("inside-1m", "inside", 1_000_000),
    Workload("bounce-200k", "bounce", 200_000),
    Workload("secondary-200k", "secondary", 200_000),
    Workload("secondary-point-200k", "secondary-point", 200_000),
)


def workloads_named(text: str) -> list[Workload]:
    """The workloads of a comma-separated list of names, in the list's order."""
    by_name = {w.name: w for w in WORKLOADS}
    names = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in names if name not in by_name]
    if unknown or not names:
        given = ", ".join(unknown) or "(none given)"
        raise argparse.ArgumentTypeError(f"unknown workload(s) {given}; choose from {', '.join(by_name)}")
    return [by_name[name] for name in names]


# --- finding Embree and building ---------------------------------------------------------------------
EMBREE_CONFIG_GLOBS = (
    "/usr/lib/*/cmake/embree-3*/embree-config.cmake",
    "/usr/lib/cmake/embree-3*/embree-config.cmake",
    "/usr/local/lib/cmake/embree-3*/embree-config.cmake",
    "/usr/local/lib/*/cmake/embree-3*/embree-config.cmake",
    "/opt/*/lib/cmake/embree-3*/embree-config.cmake",
)


def find_embree(environ: dict[str, str] | None = None, patterns: Sequence[str] = EMBREE_CONFIG_GLOBS) -> Path | None:
    """The folder of Embree 3's embree-config.cmake: $embree_DIR if set and holding one, else the first
    in the usual install places; None when there is none."""
    environ = os.environ if environ is None else environ
    if environ.get("embree_DIR"):
        folder = Path(environ["embree_DIR"])
        return folder if (folder / "embree-config.cmake").is_file() else None
    for pattern in patterns:
        found = sorted(glob.glob(pattern))
        if found:
            return Path(found[-1]).parent
    return None


def embree_version(config_dir: Path) -> str:
    """The version in Embree's config folder name (embree-3.13.5), or 'unknown'."""
    name = config_dir.name
    return name.split("-", 1)[1] if name.startswith("embree-") else "unknown"


def tool(name: str) -> str:
    """The venv's CMake/Ninja (installed by .ci/setup), else the system's."""
    local = Path(sys.executable).parent / name
    found = str(local) if local.exists() else shutil.which(name)
    if not found:
        raise SystemExit(f"{name} not found: run `bash .ci/setup` or install {name}")
    return found


def build_dir(native: bool) -> Path:
    # One folder per flag set, so that switching does not rebuild the other; both sit two levels
    # below the root like the package's build, so ccache (CCACHE_BASEDIR) can share objects.
    return ROOT / "build" / ("bench-embree-native" if native else "bench-embree")


def configure_command(build: Path, embree_dir: Path, native: bool) -> list[str]:
    command = [
        tool("cmake"), "-S", str(ROOT), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
        "-DDURER_BENCH_EMBREE=ON", f"-DDURER_NATIVE={'ON' if native else 'OFF'}", f"-Dembree_DIR={embree_dir}",
    ]
    ninja = Path(sys.executable).parent / "ninja"
    if ninja.exists() or shutil.which("ninja"):
        command += ["-G", "Ninja", f"-DCMAKE_MAKE_PROGRAM={ninja if ninja.exists() else shutil.which('ninja')}"]
    if shutil.which("ccache"):
        command.append("-DCMAKE_CXX_COMPILER_LAUNCHER=ccache")
    compiler = package_compiler()
    return command + ([f"-DCMAKE_CXX_COMPILER={compiler}"] if compiler else [])


def wheel_tag() -> str:
    """scikit-build-core's {wheel_tag} for this interpreter (cp311-cp311-linux_x86_64, say)."""
    version = f"cp{sys.version_info.major}{sys.version_info.minor}"
    return f"{version}-{version}-{sysconfig.get_platform().replace('-', '_').replace('.', '_')}"


def package_cache(root: Path = ROOT) -> Path | None:
    """The CMake cache of the package's own build (pyproject's build-dir, build/{wheel_tag}), if any:
    not another folder's under build/, which a developer may have configured with other flags."""
    cache = root / "build" / wheel_tag() / "CMakeCache.txt"
    return cache if cache.is_file() else None


def package_compiler() -> str | None:
    """The package build's C++ compiler: ccache keys on the compiler's path, so with it (and the same
    flags) the core's objects come from the cache instead of being compiled again."""
    cache = package_cache()
    return cache_value(cache, "CMAKE_CXX_COMPILER") if cache else None


def native_flags(environ: dict[str, str] | None = None) -> bool:
    """Whether to compile with -march=native: $DURER_NATIVE if set (as for the package), else as the
    package was built, so that the benchmark measures the core as installed."""
    environ = os.environ if environ is None else environ
    cache = package_cache()
    value = environ.get("DURER_NATIVE") or (cache and cache_value(cache, "DURER_NATIVE")) or "OFF"
    return value.upper() in ("1", "ON", "TRUE", "YES")


def cache_value(cache: Path, name: str) -> str | None:
    """A variable's value in a CMakeCache.txt (lines NAME:TYPE=VALUE)."""
    for line in cache.read_text().splitlines():
        if line.split(":", 1)[0] == name and "=" in line:
            return line.split("=", 1)[1]
    return None


def build_executable(embree_dir: Path, native: bool) -> Path:
    """Configures and builds durer_embree_bench; returns its path. A clean build compiles Dürer's
    core again (two to three minutes on 2 cores); ccache makes a rebuild take seconds."""
    build = build_dir(native)
    cache, compiler = build / "CMakeCache.txt", package_compiler()
    if compiler and cache.exists() and cache_value(cache, "CMAKE_CXX_COMPILER") != compiler:
        shutil.rmtree(build)  # CMake cannot switch a configured folder to another compiler
    env = {**os.environ, "CCACHE_BASEDIR": os.environ.get("CCACHE_BASEDIR", str(ROOT.parent))}
    steps = (
        configure_command(build, embree_dir, native),
        [tool("cmake"), "--build", str(build), "--target", EXECUTABLE],
    )
    for step in steps:
        run = subprocess.run(step, cwd=ROOT, env=env, capture_output=True, text=True)
        if run.returncode != 0:
            raise SystemExit(f"{' '.join(step)} failed:\n{run.stdout[-4000:]}\n{run.stderr[-4000:]}")
    return build / "bench" / "embree" / EXECUTABLE


def compiler_description(build: Path) -> str:
    """The first line of the build's C++ compiler's --version."""
    compiler = cache_value(build / "CMakeCache.txt", "CMAKE_CXX_COMPILER")
    if not compiler:
        return "unknown compiler"
    return subprocess.run([compiler, "--version"], capture_output=True, text=True).stdout.splitlines()[0]


# --- running -----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Result:
    """One workload's report from the executable, and how busy the machine was meanwhile."""

    workload: Workload
    report: dict  # the executable's JSON
    others: float | None  # cores that other processes used while it ran (None: no /proc/stat)
    exit_code: int

    def median(self, tracer: str, key: str) -> float:
        return statistics.median(self.report[tracer][key])

    @property
    def agrees(self) -> bool:
        checks = [self.report[key] for key in ("agreement", "pose_agreement", "frame_agreement") if key in self.report]
        return self.exit_code == 0 and all(c[p]["passed"] for c in checks for p in ("float", "double"))


def machine_busy_seconds() -> float | None:
    """Non-idle CPU time of all cores since boot, from /proc/stat (Linux only)."""
    try:
        with open("/proc/stat") as stat:
            fields = [int(value) for value in stat.readline().split()[1:9]]
    except (OSError, ValueError):
        return None
    user, nice, system, _idle, _iowait, irq, softirq, steal = fields
    return (user + nice + system + irq + softirq + steal) / os.sysconf("SC_CLK_TCK")


def run_workload(executable: Path, workload: Workload, size: tuple[int, int], runs: int,
                 threads: int = THREADS) -> Result:
    command = [
        str(executable), "--workload", workload.kind, "--spheres", str(workload.spheres),
        "--size", f"{size[0]}x{size[1]}", "--runs", str(runs), "--threads", str(threads),
    ]
    start_wall, start_busy, start_children = time.perf_counter(), machine_busy_seconds(), children_cpu_seconds()
    run = subprocess.run(command, stdout=subprocess.PIPE, text=True)  # progress (stderr) shows as it runs
    wall, busy = time.perf_counter() - start_wall, machine_busy_seconds()
    if run.returncode not in (0, 3):
        raise SystemExit(f"{' '.join(command)} failed with exit status {run.returncode}")
    others = None
    if busy is not None and start_busy is not None:
        others = max(0.0, (busy - start_busy) - (children_cpu_seconds() - start_children)) / wall
    return Result(workload, json.loads(run.stdout), others, run.returncode)


def children_cpu_seconds() -> float:
    times = os.times()
    return times.children_user + times.children_system


# --- reporting ---------------------------------------------------------------------------------------
HEADER = (
    "Workload", "Spheres", "Embree build + trace ms", "Embree Mrays/s", "Dürer float ms: cached (first)",
    "Dürer double ms: cached (first)", "Dürer Mrays/s f / d", "Dürer / Embree f / d", "First render f / d",
    "New pose ms: Embree, Dürer f / d", "New pose f / d", "Moved frame ms: Embree, Dürer f / d", "Moved frame f / d",
    "Hits agree f / d", "B/sphere: Dürer f / d + scene (Embree)", "Peak RSS MB", "Others",
)
NUMERIC_FROM = 1


def row_cells(result: Result) -> tuple[str, ...]:
    r = result.report
    n = r["spheres"]
    if not result.agrees:
        return (result.workload.name, f"{n:,}", *["-"] * 11, agreement_cell(r), "-", "-", others_cell(result.others))
    build, trace = result.median("embree", "build_ms"), result.median("embree", "trace_ms")
    cached = {p: result.median(f"durer_{p}", "cached_ms") for p in ("float", "double")}
    first = {p: result.median(f"durer_{p}", "first_ms") for p in ("float", "double")}
    mrays = {p: r["rays"][f"durer_{p}"] / cached[p] / 1e3 for p in ("float", "double")}
    memory = r["memory"]
    return (
        result.workload.name,
        f"{n:,}",
        f"{build:.0f} + {trace:.0f}",
        f"{r['rays']['embree'] / trace / 1e3:.1f}",
        f"{cached['float']:.0f} ({first['float']:.0f})",
        f"{cached['double']:.0f} ({first['double']:.0f})",
        f"{mrays['float']:.1f} / {mrays['double']:.1f}",
        f"{trace / cached['float']:.2f}x / {trace / cached['double']:.2f}x",
        f"{(build + trace) / first['float']:.2f}x / {(build + trace) / first['double']:.2f}x",
        *later_cells(result, "pose_ms"),
        *later_cells(result, "frame_ms"),
        agreement_cell(r),
        memory_cell(memory, n),
        f"{memory['process_peak_rss_bytes'] / 2**20:.0f}",
        others_cell(result.others),
    )


def later_cells(result: Result, key: str) -> tuple[str, str]:
    """The camera's other pose ("pose_ms": Embree's trace, Dürer's render with the pose's new view) or
    an animation's next frame ("frame_ms": Embree's refit + trace, Dürer's move + render), in ms, and
    Embree's time over Dürer's; "-" for given rays, which have neither."""
    if not result.report["embree"].get(key):
        return "-", "-"
    embree = result.median("embree", key)
    durer = {p: result.median(f"durer_{p}", key) for p in ("float", "double")}
    return (f"{embree:.0f}, {durer['float']:.0f} / {durer['double']:.0f}",
            f"{embree / durer['float']:.2f}x / {embree / durer['double']:.2f}x")


def memory_cell(memory: dict, spheres: int) -> str:
    """Bytes per sphere: what Dürer's first render adds in float / double (the precision's geometry and
    hierarchy) + what its Scene holds (the spheres in double), and Embree's scene + build."""
    if spheres < MEMORY_MIN_SPHERES:
        return "-"
    durer = {p: memory[f"durer_{p}"] for p in ("float", "double")}
    prepared = " / ".join(f"{(d['retained_bytes'] - d['scene_bytes']) / spheres:.0f}" for d in durer.values())
    scene = durer["float"]["scene_bytes"] / spheres
    return f"{prepared} + {scene:.0f} ({memory['embree']['retained_bytes'] / spheres:.0f})"


def agreement_cell(report: dict) -> str:
    """The share of pixels where Dürer (float / double) and Embree agree on hit/miss and depth (1e-4), and
    with a sun, on which hits are lit."""
    agreements = [report["agreement"][p] for p in ("float", "double")]

    def shares(key: str) -> str:
        return " / ".join(
            f"{100 * (1 - sum(a[k] for k in key.split('+')) / a['pixels']):.3f}%" + ("" if a["passed"] else " FAIL")
            for a in agreements
        )

    light = any(a["lit_mismatches"] for a in agreements)
    return shares("hit_mismatches+depth_mismatches") + (f"; light {shares('lit_mismatches')}" if light else "")


def others_cell(others: float | None) -> str:
    if others is None:
        return "n/a"
    return f"{others:.2f}" + (" !" if others > BUSY_OTHERS else "")


def text_table(cells: Sequence[tuple[str, ...]]) -> str:
    widths = [max(len(line[i]) for line in (HEADER, *cells)) for i in range(len(HEADER))]

    def line(values: Sequence[str]) -> str:
        return "  ".join(
            v.rjust(w) if i >= NUMERIC_FROM else v.ljust(w) for i, (v, w) in enumerate(zip(values, widths, strict=True))
        )

    return "\n".join([line(HEADER), "  ".join("-" * w for w in widths), *(line(c) for c in cells)])


def markdown_table(cells: Sequence[tuple[str, ...]]) -> str:
    rule = ["---:" if i >= NUMERIC_FROM else "---" for i in range(len(HEADER))]
    return "\n".join("| " + " | ".join(values) + " |" for values in (HEADER, rule, *cells))


def native_flags_text(root: Path = ROOT) -> str:
    """DURER_NATIVE's compiler flags, as CMakeLists.txt (their one home) sets DURER_NATIVE_FLAGS."""
    return re.search(r"^set\(DURER_NATIVE_FLAGS (.+)\)$", (root / "CMakeLists.txt").read_text(), re.M).group(1)


def machine_lines(build: Path, embree_dir: Path, native: bool) -> list[str]:
    from durer.reports.machine import machine

    flags = f"{native_flags_text()} (DURER_NATIVE=1)" if native else "the default (portable) flags"
    return [
        f"Machine: {machine()}",
        f"Compiler: {compiler_description(build)}, {flags}; Embree {embree_version(embree_dir)} (its own ISA dispatch)",
        f"Date: {datetime.datetime.now().astimezone().isoformat(timespec='seconds')}; "
        f"load average at the end: {', '.join(f'{v:.2f}' for v in os.getloadavg())}",
    ]


def legend_lines(size: tuple[int, int], runs: int) -> list[str]:
    return [
        f"{size[0]}x{size[1]}, 1 ray per pixel, {THREADS} threads; every time is the median of {runs} interleaved "
        "rounds after an untimed first pass that checks agreement and measures memory.",
        "Embree build + trace: rtcCommitScene, then rtcIntersect8 (+ rtcOccluded8 with the sun) over Dürer's 8x8 "
        "tiles in strips of 8, on 2 std::threads; Mrays/s counts camera + shadow rays. bounce: a given ray per pixel "
        "(leaving a random sphere in a random direction), rtcIntersect1 each against Dürer's durer::cast; secondary: "
        "the shadow and reflection rays of bench/secondary_rays.py's colour render at this size (up to 4 bounces; "
        "as many rays as that render's), the shadow rays as occlusion queries (Embree's rtcOccluded1, Dürer's "
        "durer::cast with anyHit: durer.occluded's); secondary-point: the same under its point light (the shadow "
        "rays end at the light).",
        "Dürer cached: the same Scene rendered again (hierarchy reused); first: a fresh Scene's first render, "
        "hierarchy build included. Depth pass only; colour + depth with the sun.",
        "Dürer / Embree: Embree trace time / Dürer cached time (above 1: Dürer faster); First render: "
        "Embree build + trace / Dürer first render.",
        "New pose: the camera turned 2 degrees about its up vector (a synthetic data set's next view), the scenes "
        "as built for the first pose: Embree's trace of its rays; Dürer's render, which makes the pose's view of the "
        "spheres. Ratio: Embree's time / Dürer's.",
        "Moved frame: an animation's next frame, every sphere moved a quarter radius (seeded directions). Embree: "
        "its animated scene (RTC_SCENE_FLAG_DYNAMIC, spheres at RTC_BUILD_QUALITY_REFIT) gets the new centres, "
        "rtcCommitScene (a refit) and the trace; Dürer: Scene::moveSpheres and the render (hierarchy refitted, "
        "views made again). Ratio: Embree's time / Dürer's.",
        "Hits agree: pixels where both hit or both miss and the depths agree to 1e-4 relative (below 99.9 %: FAIL, "
        "not timed); light: pixels both light or both leave dark (sun; below 99.5 %: FAIL).",
        "B/sphere (from 100k spheres): resident memory (VmRSS) added, per sphere: by Dürer's first render in float / "
        "double (that precision's geometry + hierarchy), + by its Scene (the spheres as given, in double); Embree: "
        "its scene, build and trace. Measured one tracer at a time, heap trimmed before each; Peak RSS: the process's.",
        f"Others: cores other processes used meanwhile (from /proc/stat); ! above {BUSY_OTHERS}: times suspect.",
    ]


def report(results: Sequence[Result], machine: list[str], legend: list[str]) -> tuple[str, str]:
    cells = [row_cells(result) for result in results]
    failed = [r.workload.name for r in results if not r.agrees]
    verdict = [f"DISAGREEMENT in {', '.join(failed)}: those rows are not timed"] if failed else []
    text = "\n".join(["Dürer vs Embree 3", *machine, "", text_table(cells), "", *legend, *verdict])
    markdown = "\n".join([*(f"- {line}" for line in machine), "", markdown_table(cells), "",
                          *(f"- {line}" for line in legend + verdict), ""])
    return text, markdown


# --- command line ------------------------------------------------------------------------------------
def positive_int(value: str) -> int:
    number = int(value)
    if number < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {number}")
    return number


def parse_arguments(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"1/{QUICK_SPHERES_DIVISOR} of the spheres, {QUICK_SIZE[0]}x{QUICK_SIZE[1]}, "
                             f"{QUICK_RUNS} runs (unless --runs)")
    parser.add_argument("--workloads", type=workloads_named, default=list(WORKLOADS), metavar="A,B",
                        help=f"which workloads, comma-separated (default all: {','.join(w.name for w in WORKLOADS)})")
    parser.add_argument("--runs", type=positive_int, metavar="N",
                        help=f"timed rounds per workload (default {DEFAULT_RUNS})")
    parser.add_argument("--markdown", type=Path, metavar="FILE", help="also write the report as Markdown to FILE")
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_arguments(argv)
    embree_dir = find_embree()
    if embree_dir is None:
        print(INSTALL_HINT, file=sys.stderr)
        return 2
    native = native_flags()
    print(f"building {EXECUTABLE} in {build_dir(native)} (a clean build takes two to three minutes)...", file=sys.stderr)
    executable = build_executable(embree_dir, native)
    size = QUICK_SIZE if args.quick else FULL_SIZE
    runs = args.runs or (QUICK_RUNS if args.quick else DEFAULT_RUNS)
    results = [run_workload(executable, w.scaled(args.quick), size, runs) for w in args.workloads]
    text, markdown = report(results, machine_lines(build_dir(native), embree_dir, native), legend_lines(size, runs))
    print(text)
    if args.markdown:
        args.markdown.write_text(markdown, encoding="utf-8")
        print(f"\nMarkdown written to {args.markdown}")
    return 0 if all(r.agrees for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
