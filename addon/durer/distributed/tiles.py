"""`render_tiles`: one image rendered in tiles, locally or on a Dask cluster, assembled bit for bit
as a single render (every pixel keeps the whole image's sample positions and seed)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from .. import _checks
from ..camera import Camera
from ..render import RenderResult, check_options
from ..scene import Scene
from .batch import _RENDER_OPTIONS, run_renders

#: Counters of `RenderResult.stats` that add up over tiles.
_COUNTERS = ("rays", "shadow_rays", "reflection_rays", "refraction_rays", "ao_rays", "shading_evaluations",
             "bounces_cut_by_depth", "bounces_cut_by_weight", "total_internal_reflections", "intersection_tests",
             "samples", "requested_rays")


def tile_regions(width: int, height: int, tile: int = 512) -> list[tuple[int, int, int, int]]:
    """The (x, y, w, h) tiles of a width x height image, row by row from the top: `tile` x `tile`
    pixels, smaller at the right and bottom edges."""
    width, height = _checks.image_side(width, "width"), _checks.image_side(height, "height")
    tile = _checks.integer(tile, "tile", 1)
    return [(x, y, min(tile, width - x), min(tile, height - y))
            for y in range(0, height, tile) for x in range(0, width, tile)]


def render_tiles(
    scene: Scene,
    camera: Camera,
    width: int,
    height: int,
    *,
    tile: int = 512,
    client: Any = None,
    progress: bool = False,
    threads: int | None = None,
    **options: Any,
) -> RenderResult:
    """Render a width x height image as `tile` x `tile` tiles (see `tile_regions`): one task each on
    `client` (a `distributed.Client`; the scene is sent once), or one after another here without
    one, and assemble them. The result equals ``durer.render(scene, camera, width, height,
    **options)`` bit for bit, pixels and sample counts; its stats add up the tiles' counters, with
    `milliseconds` the wall time and `tiles` the count (with sampler="adaptive" each tile also traces
    the margin its refinement reads, so `rays` exceeds one render's; `samples` does not). `threads` and `progress` as in
    `render_many`."""
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a durer.Scene, got {type(scene).__name__}")
    unknown = set(options) - _RENDER_OPTIONS
    if unknown:
        raise TypeError(f"render_tiles got unexpected options: {', '.join(sorted(unknown))}")
    progress = _checks.boolean(progress, "progress")
    check_options(width, height, camera, threads=threads, **options)
    regions = tile_regions(width, height, tile)
    jobs = [dict(options, camera=camera, width=width, height=height, region=r) for r in regions]
    start = time.perf_counter()
    image: RenderResult | None = None
    for i, part in run_renders([scene] * len(jobs), jobs, client=client, ordered=False, progress=progress,
                               threads=threads, unit="tile"):
        if image is None:
            image = _empty_like(part, width, height)
        _paste(image, part, regions[i])
    assert image is not None  # there is at least one tile
    if image.error is not None:
        image.stats.update(estimated_rmse=float(np.sqrt(np.mean(np.square(image.error, dtype=np.float64)))),
                           estimated_worst=float(image.error.max()))
    image.stats.update(milliseconds=(time.perf_counter() - start) * 1000, tiles=len(regions))
    seconds = image.stats["milliseconds"] / 1000
    image.stats["mrays_per_s"] = image.stats["rays"] / seconds / 1e6 if seconds > 0 else float("inf")
    return image


def _empty_like(part: RenderResult, width: int, height: int) -> RenderResult:
    def full(array: np.ndarray | None) -> np.ndarray | None:
        return None if array is None else np.empty((height, width, *array.shape[2:]), dtype=array.dtype)

    stats = {k: v for k, v in part.stats.items() if k not in ("worker", "region")}
    stats.update({k: 0 for k in _COUNTERS}, region=None, workers={})
    return RenderResult(stats=stats, **{name: full(getattr(part, name)) for name in RenderResult.ARRAYS})


def _paste(image: RenderResult, part: RenderResult, region: tuple[int, int, int, int]) -> None:
    x, y, w, h = region
    for name in RenderResult.ARRAYS:
        target = getattr(image, name)
        if target is not None:
            target[y : y + h, x : x + w] = getattr(part, name)
    for key in _COUNTERS:
        image.stats[key] += part.stats[key]
    if image.error is not None:  # adaptive: the whole image's summary of its error estimates
        image.stats["rounds"] = max(image.stats["rounds"], part.stats["rounds"])
        image.stats["time_limit_reached"] = image.stats["time_limit_reached"] or part.stats["time_limit_reached"]
    worker = part.stats["worker"]
    image.stats["workers"][worker] = image.stats["workers"].get(worker, 0) + 1
