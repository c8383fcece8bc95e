"""`render`: an image of a scene through a camera, with colour, depth, normal and id passes."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from . import _checks, _core
from .camera import Camera, OrthographicCamera
from .scene import Scene

# The option names, owned by the core (cpp/include/durer/Options.h), in its order.
PASSES: tuple[str, ...] = _core.PASSES
#: The passes `render` computes unless told: colour, depth, normal (the id passes are asked for by name).
DEFAULT_PASSES: tuple[str, ...] = _core.DEFAULT_PASSES
SAMPLERS: tuple[str, ...] = _core.SAMPLERS
PRECISIONS: tuple[str, ...] = _core.PRECISIONS
SPHERE_METHODS: tuple[str, ...] = _core.SPHERE_METHODS
DEPTHS: tuple[str, ...] = _core.DEPTHS


class _Flag(Protocol):
    def is_set(self) -> bool: ...


@dataclass
class RenderResult:
    """Float32 arrays, top row first (numpy convention); a pass not requested is None.

    color  (H, W, 4): linear RGBA; the box-filtered mean of the pixel's samples (with
                      sampler="adaptive" through a camera without a lens, where spheres'
                      silhouettes cross the pixel: the means of its samples inside and outside
                      them weighed by their exact shares of the pixel; orthographic: the union
                      of up to three discs, perspective: one sphere's ellipse).
    depth  (H, W):    the pixel's nearest sample hit: with depth="ray" its t along the unit camera
                      ray (the distance from the ray origin), with depth="planar" its distance
                      along the camera's view axis (Blender's Depth); +inf where every sample missed.
    normal (H, W, 3): unit world-space normal, the normalised mean over the pixel's hit samples;
                      where that mean is shorter than 1/1024 of their count (the samples' normals
                      cancel: a thin wall seen from both sides), the nearest hit sample's normal
                      (the first taken among equally near ones); 0 where every sample missed.
    object_id, material_id (H, W) int32: the object id (as `cast` and the scene's adds give them)
                      and material id of the pixel's nearest hit sample (the first taken among
                      equally near ones: one sample's ids, never a blend at an edge); -1 where
                      every sample missed. Not computed unless asked for in `passes`.
    stats:            effects (the effect set simulated: "flat" or "diffuse", "specular", "shadows",
                      "reflection", "refraction", "ambient_occlusion", "colors" (per-primitive
                      colours)); rays (camera), shadow_rays, reflection_rays, refraction_rays, ao_rays,
                      shading_evaluations, bounces_cut_by_depth,
                      bounces_cut_by_weight, total_internal_reflections, intersection_tests
                      (ray-primitive tests made); milliseconds, mrays_per_s (camera rays), threads,
                      width, height, spp, samples (camera samples of the returned pixels), precision,
                      sphere_method, passes, cancelled; with sampler="adaptive" also
                      estimated_rmse, estimated_worst, rounds, time_limit_reached.
    samples (H, W):   int32 samples each pixel took, with sampler="adaptive" (else None).
    error   (H, W):   float32, with sampler="adaptive": the estimated RMS error over RGB of the
                      pixel's colour, from the difference of the means of the two halves of its
                      samples (each made as the colour is; 0 where they agree); a pixel of two
                      samples: from how far its colour lies from its four neighbours' mean; inf
                      where a float render's sums overflowed (else None).
    """

    color: np.ndarray | None
    depth: np.ndarray | None
    normal: np.ndarray | None
    stats: dict[str, Any] = field(default_factory=dict)
    samples: np.ndarray | None = None
    error: np.ndarray | None = None
    object_id: np.ndarray | None = None
    material_id: np.ndarray | None = None

    #: The per-pixel arrays a result may hold (a pass not requested, or not adaptive: None).
    ARRAYS = ("color", "depth", "normal", "samples", "error", "object_id", "material_id")


class RenderCancelled(Exception):
    """The render was cancelled; `result` holds the tiles finished before it stopped. The pixels not
    reached (also in buffers reused through `out`) hold depth and error NaN, which no rendered pixel
    has, colour (0, 0, 0, 0), normal 0, ids -1 and samples 0."""

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
    camera: Camera,
    width: int,
    height: int,
    *,
    spp: int = 1,
    seed: int = 0,
    sampler: str = "stratified",
    target_error: float = 0.01,
    min_spp: int = 4,
    time_limit: float | None = None,
    precision: str = "double",
    sphere_method: str = "robust",
    passes: Iterable[str] = DEFAULT_PASSES,
    threads: int | None = None,
    progress: Callable[[float], Any] | None = None,
    cancel: Callable[[], bool] | _Flag | None = None,
    out: RenderResult | None = None,
    shade_back: bool = False,
    max_bounces: int = 4,
    min_weight: float = 0.01,
    depth: str = "ray",
    region: tuple[int, int, int, int] | None = None,
    ambient_occlusion: tuple[int, float] | None = None,
) -> RenderResult:
    """Render `scene` through `camera` at width x height pixels.

    spp samples per pixel, placed by `sampler` and deterministic for a `seed`, averaged with a box
    filter: "stratified" (jittered in an nx·ny grid; 1 sample is the pixel centre), "center" (all at
    the centre: no anti-aliasing), "random" (uniform), "sobol" (Owen-scrambled Sobol points) or
    "adaptive" (spp is the maximum: every pixel takes min(min_spp, spp) Sobol samples, then rounds
    double the samples of the pixels whose estimated colour error (each round's estimate averaged with
    the rounds' before), or their 3x3 neighbourhood's, exceeds `target_error`, or that sit on an edge
    their own or their neighbours' samples show; `target_error` is the estimated RMS error over RGB
    a pixel stops at, `result.error` each pixel's estimate, stats "estimated_rmse" /
    "estimated_worst" the image's, "rounds" the rounds run, "probes" the camera rays that found the
    colour outside a silhouette where the samples had not (in "rays", not samples), `result.samples`
    the counts;
    `time_limit` seconds (None: none) stops refining when spent, the worst tiles refined first, and
    sets stats "time_limit_reached"; see AdaptiveSampler.h).
    `durer.preset(name)` gives ready settings. `precision` "float" or "double" is used for every ray and
    intersection; `sphere_method` "robust" (default), "algebraic" or "geometric". Only the
    requested `passes` (any of PASSES; by default DEFAULT_PASSES) are computed. The GIL is released while rendering on `threads` threads
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

    `ambient_occlusion=(samples, distance)` scales the ambient term (ambient · kd, lit scenes) of
    every shaded hit by the fraction of `samples` cosine-weighted rays over its hemisphere that meet
    nothing within `distance` (inf: nothing at all): Owen-scrambled Sobol directions, deterministic
    for the seed, any-hit rays counted in stats["ao_rays"]. None (default): no AO rays at all.
    Samples in [1, 65536], distance > 0; see docs/accuracy.md for its noise and cost per sample.

    `region=(x, y, w, h)` renders only pixels [x, x + w) x [y, y + h) of the width x height image
    (x right, y down from the top row), into (h, w) arrays equal bit for bit to that part of the
    whole render: positions and seeds are the whole image's. With sampler="adaptive" it is sampled
    with a margin of one pixel per round (a pixel's neighbours steer its sampling), counted in
    stats "rays" but not "samples".

    Types and shapes are checked here, values (ranges, option names) by the core: either way the
    ValueError or TypeError names the argument.
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a durer.Scene, got {type(scene).__name__}")
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be an OrthographicCamera or PerspectiveCamera, got {type(camera).__name__}")
    width = _checks.image_side(width, "width")  # before the region, which must lie inside the image
    height = _checks.image_side(height, "height")
    spp = _checks.c_int(spp, "spp")
    seed = _checks.integer(seed, "seed", 0, 2**64 - 1)
    for value, name in ((sampler, "sampler"), (precision, "precision"), (sphere_method, "sphere_method"), (depth, "depth")):
        _checks.string(value, name)
    target_error = _checks.real(target_error, "target_error")
    min_spp = _checks.c_int(min_spp, "min_spp")
    time_limit = 0.0 if time_limit is None else _checks.real(time_limit, "time_limit")
    wanted = _pass_names(passes)
    shade_back = _checks.boolean(shade_back, "shade_back")
    max_bounces = _checks.c_int(max_bounces, "max_bounces")
    min_weight = _checks.real(min_weight, "min_weight")
    box = region_argument(region, width, height)
    occlusion = ambient_occlusion_argument(ambient_occlusion)
    poll = poll_function(progress, cancel)
    if out is not None and not isinstance(out, RenderResult):
        raise TypeError(f"out must be a RenderResult or None, got {type(out).__name__}")
    buffers = {} if out is None else {name: getattr(out, name) for name in PASSES}
    out = _core.render(
        scene._core, camera._spec, width, height, spp, seed, sampler, target_error, min_spp, time_limit, precision,
        sphere_method, wanted, depth, threads_argument(threads), shade_back, max_bounces, min_weight, occlusion, poll,
        buffers, box,
    )
    stats = dict(out["stats"])
    seconds = stats["milliseconds"] / 1000
    stats.update(
        width=width, height=height, spp=spp, sampler=sampler, precision=precision,
        samples=int(out["samples"].sum(dtype=np.int64)) if "samples" in out else stats["rays"],
        sphere_method=sphere_method, depth=depth, ambient_occlusion=occlusion,
        passes=tuple(p for p in PASSES if p in wanted), region=box if box[2] else None,
        requested_rays=(box[2] * box[3] if box[2] else width * height) * spp,
        mrays_per_s=stats["rays"] / seconds / 1e6 if seconds > 0 else float("inf"),
    )
    result = RenderResult(out.get("color"), out.get("depth"), out.get("normal"), stats, out.get("samples"),
                          out.get("error"), out.get("object_id"), out.get("material_id"))
    if stats["cancelled"]:
        raise RenderCancelled(result)
    if progress is not None:
        progress(1.0)
    return result


def check_options(width: int, height: int, camera: Camera | None = None, **options: Any) -> None:
    """Raise now the TypeError or ValueError ``render(scene, camera, width, height, **options)`` would
    raise for these arguments, by render's own checks (the core's ranges and option names among them,
    which have no copy in Python): it renders one pixel of the image of an empty scene, well under a
    millisecond (30 ms at the largest spp). Batches (durer.distributed) and the 6.837 command check
    their options so before any work, which may run on a cluster."""
    probe = OrthographicCamera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0)) if camera is None else camera
    render(Scene(), probe, width, height, region=(0, 0, 1, 1), **options)


def region_argument(region: tuple[int, int, int, int] | None, width: int, height: int) -> tuple[int, int, int, int]:
    """The core's region: (x, y, w, h) inside the image, or (0, 0, 0, 0) for the whole image."""
    if region is None:
        return (0, 0, 0, 0)
    x, y, w, h = _checks.items(region, 4, "region", "(x, y, width, height)")
    x, y = _checks.integer(x, "region x", 0, width - 1), _checks.integer(y, "region y", 0, height - 1)
    w, h = _checks.integer(w, "region width", 1, width - x), _checks.integer(h, "region height", 1, height - y)
    return (x, y, w, h)


def ambient_occlusion_argument(value: tuple[int, float] | None) -> tuple[int, float] | None:
    """(samples, distance) as (int, float), or None (off); their ranges are the core's to check."""
    if value is None:
        return None
    samples, distance = _checks.items(value, 2, "ambient_occlusion", "(samples, distance)")
    return _checks.c_int(samples, "ambient_occlusion samples"), _checks.real(distance, "ambient_occlusion distance")


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
