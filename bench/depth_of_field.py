"""What depth of field costs: many spheres seen through a pinhole and through lenses of growing
aperture, the camera's view of the spheres (its footprints widened by each sphere's blur) against a
walk of the hierarchy, on the same spheres and rays.

    python bench/depth_of_field.py [--spheres N] [--runs N] [--threads 2] [--markdown FILE]

The scene: N spheres (default 1,000,000; radius 0.02, or 0.2 below 100,000 spheres)
uniform in the cube [-10, 10]^3 (seeded), a perspective camera 30 units in front of it focused on
its centre (45° field of view), 1920x1080, depth only, 1 spp. Each lens row renders the spheres as
given (`view`: the camera's view of them, made while the spheres' mean blur is at most
TileRenderer::kMostLensBlurPixels, 3 pixels) and the same spheres halved in a group scaled by 2
(`walk`: exact in binary, the same hits bit for bit, which no view serves: the hierarchy's walk).
"Mean blur" is the spheres' mean blur radius in pixels (aperture · |1/z − 1/focus| over a pixel's
width at unit distance). Every figure is the median of --runs rounds that render every row once, after
a warm-up render of each row (which builds the hierarchies and views).
"""

from __future__ import annotations

import os

os.environ["OPENBLAS_NUM_THREADS"] = "1"  # before numpy: idle OpenBLAS threads would steal a core

import argparse  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
from pathlib import Path  # noqa: E402

import durer  # noqa: E402
import numpy as np  # noqa: E402
from primary_rays import CpuClock, machine_line, positive_int, print_report  # noqa: E402

WIDTH, HEIGHT = 1920, 1080
DISTANCE, FOV = 30.0, 45.0
APERTURES = (0.0, 0.02, 0.1, 0.2, 0.3, 0.5)


def scenes(n: int) -> tuple[durer.Scene, durer.Scene, np.ndarray]:
    rng = np.random.default_rng(1)
    centers = rng.uniform(-10, 10, (n, 3))
    radius = 0.02 if n >= 100_000 else 0.2
    viewed = durer.Scene()
    viewed.add_spheres(centers, radius)
    walked = durer.Scene()
    walked.add_spheres(centers / 2, radius / 2, transform=np.hstack([2 * np.eye(3), np.zeros((3, 1))]))
    return viewed, walked, centers


def camera(aperture: float) -> durer.PerspectiveCamera:
    lens = {"aperture_radius": aperture, "focus_distance": DISTANCE} if aperture > 0 else {}
    return durer.PerspectiveCamera((0, 0, DISTANCE), (0, 0, -1), (0, 1, 0), fov_degrees=FOV, **lens)


def mean_blur(centers: np.ndarray, aperture: float) -> float:
    pixel = 2 * math.tan(math.radians(FOV / 2)) / WIDTH
    depth = DISTANCE - centers[:, 2]
    return float(np.mean(aperture * np.abs(1 / depth - 1 / DISTANCE)) / pixel)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--spheres", type=positive_int, default=1_000_000)
    parser.add_argument("--runs", type=positive_int, default=3)
    parser.add_argument("--threads", type=positive_int, default=2)
    parser.add_argument("--markdown", type=Path)
    args = parser.parse_args(argv)
    viewed, walked, centers = scenes(args.spheres)
    rows = [(a, name, scene) for a in APERTURES for name, scene in (("view", viewed), ("walk", walked))]

    def render(aperture, scene, out=None):
        return durer.render(scene, camera(aperture), WIDTH, HEIGHT, passes=("depth",), threads=args.threads, out=out)

    results = [render(a, scene) for a, _, scene in rows]
    times: list[list[float]] = [[] for _ in rows]
    start = CpuClock.now()
    for _ in range(args.runs):
        for i, (a, _, scene) in enumerate(rows):
            times[i].append(render(a, scene, results[i]).stats["milliseconds"])
    others = CpuClock.now().others_since(start)
    pinhole = statistics.median(times[0])
    cells = []
    for (a, name, _), t, res in zip(rows, times, results):
        median = statistics.median(t)
        cells.append([f"{a:g}" if a else "pinhole", name, f"{mean_blur(centers, a):.2f}", f"{median:.1f}",
                      f"{median / pinhole:.2f}", f"{res.stats['intersection_tests'] / res.stats['rays']:.1f}"])
    print_report(
        [f"Depth of field: {args.spheres:,} spheres in a cube, perspective, focused on its centre, {WIDTH}x{HEIGHT}, "
         f"depth only, 1 spp, {args.threads} threads; median of {args.runs} rounds",
         machine_line(others)],
        ["Aperture", "Search", "Mean blur px", "Median ms", "x pinhole view", "Tests/ray"], cells, 2,
        ["view: the camera's view of the spheres where it is made (mean blur <= 3 px), else the same walk as "
         "'walk'; walk: the same spheres in a group scaled by 2, which no view serves."],
        args.markdown)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
