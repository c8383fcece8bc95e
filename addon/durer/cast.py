"""`cast`: closest hits of arbitrary rays, in bulk; `occluded`: whether anything lies along them."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from . import _checks, _core
from .render import poll_function, threads_argument
from .scene import Scene


@dataclass
class CastResult:
    """t (N,): closest hit in units of each ray's direction, inf on a miss; normal (N, 3): unit
    world-space normal, 0 on a miss; object_id, material_id (N,) int32: -1 on a miss. Floats are
    float64 for precision "double", float32 for "float"."""

    t: np.ndarray
    normal: np.ndarray
    object_id: np.ndarray
    material_id: np.ndarray


def cast(
    scene: Scene,
    origins: ArrayLike,
    directions: ArrayLike,
    *,
    t_min: float = 0.0,
    t_max: float = math.inf,
    precision: str = "double",
    sphere_method: str = "robust",
    threads: int | None = None,
    check: bool = True,
    cancel: Callable[[], bool] | None = None,
) -> CastResult:
    """Cast N rays P(t) = origin + t·direction and report each one's closest hit with t in
    [t_min, t_max). Directions need not be unit length. Inputs are rounded to `precision`.

    With check=True (the default) non-finite coordinates and zero directions raise ValueError
    naming the ray; with check=False they are cast anyway and are guaranteed to miss.
    """
    out = _cast(scene, origins, directions, t_min, t_max, precision, sphere_method, threads, check, cancel, False)
    return CastResult(out["t"], out["normal"], out["object_id"], out["material_id"])


def occluded(
    scene: Scene,
    origins: ArrayLike,
    directions: ArrayLike,
    *,
    t_min: float = 0.0,
    t_max: float = math.inf,
    precision: str = "double",
    sphere_method: str = "robust",
    threads: int | None = None,
    check: bool = True,
    cancel: Callable[[], bool] | None = None,
) -> np.ndarray:
    """Whether anything lies along each of N rays with t in [t_min, t_max): (N,) bool, exactly
    where `cast` would report a hit (np.isfinite(cast(...).t)), found sooner: each ray's search stops
    at the first hit it meets (shadow and visibility rays). Arguments and errors as for `cast`."""
    out = _cast(scene, origins, directions, t_min, t_max, precision, sphere_method, threads, check, cancel, True)
    return np.isfinite(out["t"])


def _cast(scene: Scene, origins: ArrayLike, directions: ArrayLike, t_min: float, t_max: float, precision: str,
          sphere_method: str, threads: int | None, check: bool, cancel: Callable[[], bool] | None,
          any_hit: bool) -> dict:
    """The arguments checked, then the core's cast (any_hit: its occlusion query)."""
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a durer.Scene, got {type(scene).__name__}")
    check = _checks.boolean(check, "check")
    origins = _checks.float_array(origins, "origins", (None, 3), finite=check)
    directions = _checks.float_array(directions, "directions", (origins.shape[0], 3), finite=check)
    if check:
        zero = ~directions.any(axis=1)
        if zero.any():
            raise ValueError(f"directions[{int(np.argmax(zero))}] must not be the zero vector")
    t_min, t_max = _checks.real(t_min, "t_min"), _checks.real(t_max, "t_max")
    _checks.string(precision, "precision")
    _checks.string(sphere_method, "sphere_method")
    out = _core.cast(
        scene._core, origins, directions, t_min, t_max, precision, sphere_method,
        threads_argument(threads), poll_function(None, cancel), any_hit,
    )
    if out["cancelled"]:
        raise RuntimeError("cast cancelled")
    return out
