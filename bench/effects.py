"""What each effect adds to a render's time, measured in one run (the effects issue's benchmark).

    python bench/effects.py [--size 1280x720] [--runs 7] [--precision double]

The scene is the showcase (65 spheres and a ground plane). Each row adds one effect to the one
above, so its "added" column is that effect's own cost; "vs depth" compares with rendering depth
only. Figures are medians of --runs rounds, each rendering every row once (so drift of this noisy
machine hits all rows alike), into the same buffers, after one warm-up, from the core's own timer.
The issue's target: the scene without lights (flat colour) takes <= 1.05 x the depth-only time.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from collections.abc import Callable, Sequence
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # numpy's BLAS threads must not spin during timing

import numpy as np  # noqa: E402

import durer  # noqa: E402


def showcase(lights: bool, shadows: bool, specular: bool, reflective: bool, transparent: bool) -> durer.Scene:
    """The showcase geometry with the asked-for effects switched on."""
    base, _ = durer.showcase_scene()
    scene = durer.Scene()
    scene.background = base.background
    scene.ambient = base.ambient
    rng = np.random.default_rng(7)
    palette = [scene.add_material(
        diffuse=c,
        specular=(0.5, 0.5, 0.5) if specular else (0, 0, 0), exponent=40.0,
        reflective=(0.4, 0.4, 0.4) if reflective and i == 0 else (0, 0, 0),
        transparent=(0.9, 0.9, 0.9) if transparent and i == 1 else (0, 0, 0), ior=1.5,
    ) for i, c in enumerate(((0.85, 0.2, 0.15), (0.2, 0.45, 0.85), (0.95, 0.75, 0.2), (0.25, 0.7, 0.35)))]
    scene.add_plane((0, 1, 0), 0.0, material=scene.add_material((0.7, 0.68, 0.62)))
    centers = np.array([[0.0, 1.5, 0.0], [-2.6, 0.9, 0.8], [2.4, 1.1, -0.6], [-0.9, 0.5, 2.3]])
    scene.add_spheres(centers, [1.5, 0.9, 1.1, 0.5], material=np.array(palette, dtype=np.int32))
    angle = rng.uniform(0, 2 * np.pi, 60)
    distance = rng.uniform(3.0, 5.5, 60)
    r = rng.uniform(0.08, 0.25, 60)
    scene.add_spheres(np.stack([distance * np.cos(angle), r, distance * np.sin(angle) * 0.6], 1), r,
                      material=np.array(palette, dtype=np.int32)[rng.integers(0, 4, 60)])
    if lights:
        scene.add_directional_light((-0.5, -1.0, -0.4), (0.95, 0.92, 0.85), shadows=shadows)
    return scene


ROWS: list[tuple[str, dict, tuple[str, ...]]] = [
    ("depth only", dict(lights=False, shadows=False, specular=False, reflective=False, transparent=False), ("depth",)),
    ("flat colour (no lights)", dict(lights=False, shadows=False, specular=False, reflective=False, transparent=False),
     ("color",)),
    ("+ diffuse light", dict(lights=True, shadows=False, specular=False, reflective=False, transparent=False), ("color",)),
    ("+ shadows", dict(lights=True, shadows=True, specular=False, reflective=False, transparent=False), ("color",)),
    ("+ Phong specular", dict(lights=True, shadows=True, specular=True, reflective=False, transparent=False), ("color",)),
    ("+ reflection", dict(lights=True, shadows=True, specular=True, reflective=True, transparent=False), ("color",)),
    ("+ refraction", dict(lights=True, shadows=True, specular=True, reflective=True, transparent=True), ("color",)),
]


def round_robin(renders: list[Callable[..., durer.RenderResult]], runs: int) -> tuple[list[float], list]:
    """Median ms of each render over `runs` rounds that each render every one once (so that the
    machine's drift hits all rows alike), into the same buffers (fresh ones would time page faults)."""
    results = [render(out=None) for render in renders]  # warm-up: the hierarchy and the buffers
    times: list[list[float]] = [[] for _ in renders]
    for _ in range(runs):
        for i, render in enumerate(renders):
            results[i] = render(out=results[i])
            times[i].append(results[i].stats["milliseconds"])
    return [statistics.median(t) for t in times], results


def machine() -> str:
    cpu = "unknown CPU"
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            cpu = line.split(":", 1)[1].strip()
            break
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, durer {durer.__version__}"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="1280x720")
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--precision", choices=("float", "double"), default="double")
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.split("x"))
    _, camera = durer.showcase_scene()
    print(f"Effects benchmark, {width}x{height}, 1 spp, {args.precision}; median of {args.runs} runs")
    print(f"{machine()}; {time.strftime('%Y-%m-%d %H:%M')}\n")
    print(f"{'render':26} {'ms':>8} {'added ms':>9} {'vs depth':>9}  effects / rays")
    renders = []
    for _, flags, passes in ROWS:
        scene = showcase(**flags)
        renders.append(lambda out, scene=scene, passes=passes: durer.render(
            scene, camera, width, height, passes=passes, out=out, precision=args.precision, shade_back=True))
    medians, results = round_robin(renders, args.runs)
    for i, ((name, _, _), ms, result) in enumerate(zip(ROWS, medians, results)):
        s = result.stats
        added = "" if i == 0 else f"{ms - medians[i - 1]:+9.1f}"
        rays = (f"camera {s['rays']}, shadow {s['shadow_rays']}, reflection {s['reflection_rays']}, "
                f"refraction {s['refraction_rays']}")
        print(f"{name:26} {ms:8.1f} {added:>9} {ms / medians[0]:9.3f}  {', '.join(s['effects']) or '-'}; {rays}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
