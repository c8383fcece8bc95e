"""Orthographic and perspective cameras (MIT 6.837 conventions, plus Blender's fit and shift)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike

from . import _checks, _core

FITS: tuple[str, ...] = _core.FITS  # owned by the core (Options.h)


@dataclass(frozen=True)
class _Camera:
    """Common fields. `direction` and `up` need not be unit or orthogonal: the frame is
    horizontal = normalize(direction × up), up' = horizontal × direction. `fit` says which image
    dimension the size or field of view spans: "auto" the larger (6.837; Blender's Auto), or
    "horizontal"/"vertical". `shift` moves the image window by (x right, y up) in units of that
    span (Blender's shift_x/shift_y). `pixel_aspect` is a pixel's height / width on the image plane
    (Blender's pixel aspect y / x); "auto" fit compares width with height·pixel_aspect. Camera rays
    count hits with t in [t_min, t_max).

    Depth of field (a thin lens, as Cycles'): with `aperture_radius` > 0 (world units) each sample's
    ray leaves a point of the aperture — in the plane through `center` across the view axis, around
    the eye (perspective) or the pixel's own origin (orthographic) — toward the point where the
    pinhole ray meets the plane of focus, `focus_distance` along the view axis (required with an
    aperture). The aperture is a disc, or with `aperture_blades` from 3 to 100 the regular polygon
    inscribed in it turned by `aperture_rotation` radians; `aperture_ratio` > 1 narrows it horizontally (an
    anamorphic lens's oval bokeh). Anti-aliasing samples sample the lens too: more samples, less
    noise in the blur. `rays` gives the pinhole rays (through the lens's centre)."""

    center: tuple[float, float, float]
    direction: tuple[float, float, float]
    up: tuple[float, float, float]
    _projection: ClassVar[str]
    _size_name: ClassVar[str]
    _spec: _core.CameraSpec = field(init=False, repr=False, compare=False)

    def _build(self, size: float, fit: str, shift: ArrayLike, pixel_aspect: float, t_min: float, t_max: float,
               clip_planes: bool = False) -> None:
        lens = self._lens()
        set_ = object.__setattr__
        set_(self, "center", _checks.vector3(self.center, "center"))
        set_(self, "direction", _checks.vector3(self.direction, "direction"))
        set_(self, "up", _checks.vector3(self.up, "up"))
        size = _checks.real(size, self._size_name)
        _checks.string(fit, "fit")
        sx, sy = _checks.float_array(shift, "shift", (2,), finite=False)
        set_(self, "shift", (float(sx), float(sy)))
        t_min, t_max = _checks.real(t_min, "t_min"), _checks.real(t_max, "t_max")
        aspect = _checks.real(pixel_aspect, "pixel_aspect")
        clip_planes = _checks.boolean(clip_planes, "clip_planes")
        spec = _core.CameraSpec(self._projection, self.center, self.direction, self.up, size, fit, sx, sy, aspect,
                                t_min, t_max, clip_planes, **lens)
        set_(self, "_spec", spec)

    def _lens(self) -> dict[str, float | int]:
        # Types here; values (ranges, the limits per precision) by the core's checks.
        aperture = _checks.real(self.aperture_radius, "aperture_radius")
        focus = self.focus_distance
        if focus is None:
            if aperture > 0:
                raise ValueError("focus_distance must be given with aperture_radius > 0 (the plane of focus's "
                                 "distance along the view axis)")
            focus = 1.0
        return {"aperture_radius": aperture, "focus_distance": _checks.real(focus, "focus_distance"),
                # The core's int: its own check says which counts it takes.
                "aperture_blades": _checks.integer(self.aperture_blades, "aperture_blades", -2**31, 2**31 - 1),
                "aperture_rotation": _checks.real(self.aperture_rotation, "aperture_rotation"),
                "aperture_ratio": _checks.real(self.aperture_ratio, "aperture_ratio")}

    def __reduce__(self) -> tuple[type, tuple[Any, ...]]:
        # The core's CameraSpec does not pickle: a camera pickles as its constructor arguments.
        return type(self), tuple(getattr(self, f.name) for f in fields(self) if f.init)

    def rays(self, width: int, height: int, precision: str = "double") -> tuple[np.ndarray, np.ndarray]:
        """The pixel-centre rays: origins and unit directions, each (height, width, 3), top row
        first, exactly as `render` generates them with spp=1 (through a lens, it samples the lens
        even then: these are the rays through the lens's centre)."""
        width = _checks.image_side(width, "width")  # render's rule: the same rays
        height = _checks.image_side(height, "height")
        _checks.string(precision, "precision")
        return _core.camera_rays(self._spec, width, height, precision)


@dataclass(frozen=True)
class OrthographicCamera(_Camera):
    """Parallel rays along `direction`. The pixel at image position (x, y) in [0, 1]² casts from
    center + (x − ½)·size·horizontal + (y − ½)·size·up (for a square image; `size` spans the fitted
    dimension). t_min defaults to −inf as in 6.837: objects behind the centre are visible."""

    size: float = 1.0
    fit: str = "auto"
    shift: tuple[float, float] = (0.0, 0.0)
    pixel_aspect: float = 1.0
    t_min: float = -math.inf
    t_max: float = math.inf
    aperture_radius: float = 0.0
    focus_distance: float | None = None
    aperture_blades: int = 0
    aperture_rotation: float = 0.0
    aperture_ratio: float = 1.0
    _projection: ClassVar[str] = "orthographic"
    _size_name: ClassVar[str] = "size"

    def __post_init__(self) -> None:
        self._build(self.size, self.fit, self.shift, self.pixel_aspect, self.t_min, self.t_max)


@dataclass(frozen=True)
class PerspectiveCamera(_Camera):
    """Rays from `center` through an image plane; `fov_degrees` in (0, 180) spans the fitted
    dimension (the larger one by default). With `clip_planes`, t_min and t_max bound the distance
    along the view axis (a near and a far plane, as Blender's and Cycles' clip range) instead of t
    along each ray; t is still measured along the ray."""

    fov_degrees: float = 60.0
    fit: str = "auto"
    shift: tuple[float, float] = (0.0, 0.0)
    pixel_aspect: float = 1.0
    t_min: float = 0.0
    t_max: float = math.inf
    clip_planes: bool = False
    aperture_radius: float = 0.0
    focus_distance: float | None = None
    aperture_blades: int = 0
    aperture_rotation: float = 0.0
    aperture_ratio: float = 1.0
    _projection: ClassVar[str] = "perspective"
    _size_name: ClassVar[str] = "fov_degrees"

    def __post_init__(self) -> None:
        self._build(self.fov_degrees, self.fit, self.shift, self.pixel_aspect, self.t_min, self.t_max,
                    self.clip_planes)


Camera = OrthographicCamera | PerspectiveCamera
