"""What each effect adds to a render's time, measured in one run (the effects issue's benchmark).

    python bench/effects.py [--size 1280x720] [--runs 7] [--precision double]

The scene is the showcase (65 spheres and a ground plane) with the effects switched on row by row
(`durer.reports.scenes.effect_scene`, which the accuracy report measures the same way). Each row adds one effect to the one
above, so its "added" column is that effect's own cost; "vs depth" compares with rendering depth
only. Figures are medians of --runs rounds, each rendering every row once (so drift of this noisy
machine hits all rows alike), into the same buffers, after one warm-up, from the core's own timer.
The issue's target: the scene without lights (flat colour) takes <= 1.05 x the depth-only time.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable, Sequence

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # numpy's BLAS threads must not spin during timing

import durer  # noqa: E402
from durer.render import PRECISIONS  # noqa: E402
from durer.reports.machine import machine  # noqa: E402
from durer.reports.scenes import EFFECT_ROWS as ROWS  # noqa: E402
from durer.reports.scenes import effect_scene as showcase  # noqa: E402


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


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="1280x720")
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--precision", choices=PRECISIONS, default="double")
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
