"""`render`: an image of a scene through a camera, with colour, depth and normal passes."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from . import _checks, _core
from .camera import OrthographicCamera, PerspectiveCamera
from .scene import Scene

# The option names, owned by the core (cpp/include/durer/Options.h), in its order.
PASSES: tuple[str, ...] = _core.PASSES
SAMPLERS: tuple[str, ...] = _core.SAMPLERS
PRECISIONS: tuple[str, ...] = _core.PRECISIONS
SPHERE_METHODS: tuple[str, ...] = _core.SPHERE_METHODS
DEPTHS: tuple[str, ...] = _core.DEPTHS


class _Flag(Protocol):
    def is_set(self) -> bool: ...


@dataclass
class RenderResult:
    """Float32 arrays, top row first (numpy convention); a pass not requested is None.

    color  (H, W, 4): linear RGBA; the box-filtered mean of the pixel's samples.
    depth  (H, W):    the pixel's nearest sample hit: with depth="ray" its t along the unit camera
                      ray (the distance from the ray origin), with depth="planar" its distance
                      along the camera's view axis (Blender's Depth); +inf where every sample missed.
    normal (H, W, 3): unit world-space normal, the normalised mean over the pixel's hit samples;
                      where that mean is shorter than 1/1024 of their count (the samples' normals
                      cancel: a thin wall seen from both sides), the nearest hit sample's normal
                      (the first taken among equally near ones); 0 where every sample missed.
    stats:            effects (the effect set simulated: "flat" or "diffuse", "specular", "shadows",
                      "reflection", "refraction", "colors" (per-primitive colours)); rays (camera), shadow_rays, reflection_rays,
                      refraction_rays, shading_evaluations, bounces_cut_by_depth,
                      bounces_cut_by_weight, total_internal_reflections, intersection_tests
                      (ray-primitive tests made); milliseconds, mrays_per_s (camera rays), threads,
                      width, height, spp, precision, sphere_method, passes, cancelled.
    """

    color: np.ndarray | None
    depth: np.ndarray | None
    normal: np.ndarray | None
    stats: dict[str, Any] = field(default_factory=dict)
    samples: np.ndarray | None = None  # (H, W) int32 samples per pixel, with sampler="adaptive"


class RenderCancelled(Exception):
    """The render was cancelled; `result` holds the tiles finished before it stopped."""

    def __init__(self, result: RenderResult) -> None:
        super().__init__(f"render cancelled after {result.stats['rays']} of {result.stats['requested_rays']} rays")
        self.result = result


def poll_function(
    progress: Callable[[float], Any] | None, cancel: Callable[[], bool] | _Flag | None
) -> Callable[[float], bool]:
    """The core's poll(fraction) -> cancel? from the user's progress and cancel arguments."""
    if progress is not None and not callable(progress):
        raise TypeError("progress must be callable (it receives the finished fraction) or None")
    if cancel is None:
        should_stop: Callable[[], bool] = lambda: False  # noqa: E731
    elif hasattr(cancel, "is_set"):
        should_stop = cancel.is_set
    elif callable(cancel):
        should_stop = cancel
    else:
        raise TypeError("cancel must be a callable returning bool, an object with is_set() (threading.Event), or None")

    def poll(fraction: float) -> bool:
        if progress is not None:
            progress(fraction)
        return bool(should_stop())

    return poll


def threads_argument(threads: int | None) -> int:
    return 0 if threads is None else _checks.integer(threads, "threads", 1, 2**31 - 1)


def render(
    scene: Scene,
    camera: OrthographicCamera | PerspectiveCamera,
    width: int,
    height: int,
    *,
    spp: int = 1,
    seed: int = 0,
    sampler: str = "stratified",
    target_error: float = 0.01,
    precision: str = "double",
    sphere_method: str = "robust",
    passes: Iterable[str] = PASSES,
    threads: int | None = None,
    progress: Callable[[float], Any] | None = None,
    cancel: Callable[[], bool] | _Flag | None = None,
    out: RenderResult | None = None,
    shade_back: bool = False,
    max_bounces: int = 4,
    min_weight: float = 0.01,
    depth: str = "ray",
    region: tuple[int, int, int, int] | None = None,
) -> RenderResult:
    """Render `scene` through `camera` at width x height pixels.

    spp samples per pixel, placed by `sampler` and deterministic for a `seed`, averaged with a box
    filter: "stratified" (jittered in an nx·ny grid; 1 sample is the pixel centre), "center" (all at
    the centre: no anti-aliasing), "random" (uniform), "sobol" (Owen-scrambled Sobol points) or
    "adaptive" (spp is the maximum: min(4, spp) Sobol samples, then rounds of 4 more while the
    pixel's samples meet different objects or the standard error of its mean luminance exceeds
    `target_error`; `result.samples` holds the counts). `durer.preset(name)` gives ready settings. `precision` "float" or "double" is used for every ray and
    intersection; `sphere_method` "robust" (default), "algebraic" or "geometric". Only the
    requested `passes` are computed. The GIL is released while rendering on `threads` threads
    (None: all cores); `progress(fraction)` is called from this thread as tiles finish, and the
    render stops within 0.1 s once `cancel()` returns true (or the `cancel` Event is set), raising
    RenderCancelled with the partial result. `out`, an earlier RenderResult of the same size and
    passes, has its arrays overwritten instead of new ones being allocated (saves the page faults of
    fresh memory when rendering frame after frame).

    Effects are simulated only where the scene calls for them (stats["effects"]): lights, Phong
    highlights, shadows, and mirror and refracted rays up to `max_bounces` deep (0: none), a ray
    not spawned when its weight in the pixel would fall below `min_weight`. With `shade_back`, back
    faces are shaded (and reported in the Normal pass) with the flipped normal, as 6.837's -shade_back.
    `depth` says what the depth pass measures: "ray" (t along the unit camera ray) or "planar" (the
    distance along the camera's view axis, as Blender's and Cycles' Depth pass).

    `region=(x, y, w, h)` renders only pixels [x, x + w) x [y, y + h) of the width x height image
    (x right, y down from the top row), into (h, w) arrays equal bit for bit to that part of the
    whole render: positions and seeds are the whole image's. With sampler="adaptive" its edges must
    lie on the core's 8-pixel tile grid or the image's edges (a pixel's neighbours in its tile steer
    its sampling).

    Types and shapes are checked here, values (ranges, option names) by the core: either way the
    ValueError or TypeError names the argument.
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a durer.Scene, got {type(scene).__name__}")
    if not isinstance(camera, (OrthographicCamera, PerspectiveCamera)):
        raise TypeError(f"camera must be an OrthographicCamera or PerspectiveCamera, got {type(camera).__name__}")
    width = _checks.c_int(width, "width")
    height = _checks.c_int(height, "height")
    spp = _checks.c_int(spp, "spp")
    seed = _checks.integer(seed, "seed", 0, 2**64 - 1)
    for value, name in ((sampler, "sampler"), (precision, "precision"), (sphere_method, "sphere_method"), (depth, "depth")):
        _checks.string(value, name)
    target_error = _checks.real(target_error, "target_error")
    wanted = _pass_names(passes)
    shade_back = _checks.boolean(shade_back, "shade_back")
    max_bounces = _checks.c_int(max_bounces, "max_bounces")
    min_weight = _checks.real(min_weight, "min_weight")
    box = region_argument(region, width, height, sampler)
    poll = poll_function(progress, cancel)
    if out is not None and not isinstance(out, RenderResult):
        raise TypeError(f"out must be a RenderResult or None, got {type(out).__name__}")
    buffers = {} if out is None else {"color": out.color, "depth": out.depth, "normal": out.normal}
    out = _core.render(
        scene._core, camera._spec, width, height, spp, seed, sampler, target_error, precision, sphere_method,
        wanted, depth, threads_argument(threads), shade_back, max_bounces, min_weight, poll, buffers, box,
    )
    stats = dict(out["stats"])
    seconds = stats["milliseconds"] / 1000
    stats.update(
        width=width, height=height, spp=spp, sampler=sampler, samples=stats["rays"], precision=precision,
        sphere_method=sphere_method, depth=depth,
        passes=tuple(p for p in PASSES if p in wanted), region=box if box[2] else None,
        requested_rays=(box[2] * box[3] if box[2] else width * height) * spp,
        mrays_per_s=stats["rays"] / seconds / 1e6 if seconds > 0 else float("inf"),
    )
    result = RenderResult(out.get("color"), out.get("depth"), out.get("normal"), stats, out.get("samples"))
    if stats["cancelled"]:
        raise RenderCancelled(result)
    if progress is not None:
        progress(1.0)
    return result


#: The core's tile edge in pixels: adaptive sampling looks at a pixel's neighbours within its tile.
TILE_GRID = 8


def region_argument(
    region: tuple[int, int, int, int] | None, width: int, height: int, sampler: str
) -> tuple[int, int, int, int]:
    """The core's region: (x, y, w, h) inside the image, or (0, 0, 0, 0) for the whole image."""
    if region is None:
        return (0, 0, 0, 0)
    try:
        x, y, w, h = region
    except (TypeError, ValueError):
        raise ValueError(f"region must be (x, y, width, height), got {region!r}") from None
    x, y = _checks.integer(x, "region x", 0, width - 1), _checks.integer(y, "region y", 0, height - 1)
    w, h = _checks.integer(w, "region width", 1, width - x), _checks.integer(h, "region height", 1, height - y)
    if sampler == "adaptive":
        for name, start, end, size in (("x", x, x + w, width), ("y", y, y + h, height)):
            if start % TILE_GRID or (end % TILE_GRID and end != size):
                raise ValueError(f"region {name} edges must be multiples of {TILE_GRID} (or the image edge) with "
                                 f"sampler='adaptive', got {start}..{end}")
    return (x, y, w, h)


def _pass_names(passes: Iterable[str]) -> tuple[str, ...]:
    if isinstance(passes, str):
        passes = (passes,)
    try:
        names = tuple(passes)
    except TypeError:
        raise TypeError("passes must be a collection of pass names") from None
    for name in names:
        _checks.string(name, "passes")
    return names
