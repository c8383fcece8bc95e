"""The accuracy report's ambient-occlusion section: noise and time against AO samples per hit."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...render import render
from ...showcase import showcase_scene
from ..errors import fit_slope, rmse, worst_pixel
from ..scenes import effect_scene
from .measure import REFERENCE_SEED, SEED, Config, timed

#: The scene: the showcase geometry (spheres resting on a plane) lit by its sun with shadows.
SCENE_FLAGS = dict(lights=True, shadows=True, specular=False, reflective=False, transparent=False)
DISTANCE = float("inf")


@dataclass(frozen=True)
class OcclusionSettings:
    size: tuple[int, int]
    samples: tuple[int, ...]
    reference_samples: int


def settings_for(config: Config) -> OcclusionSettings:
    """AO samples 1, 4, 16, 64 against 4,096 (quick: 1, 4, 16 against 256) at the anti-aliasing size."""
    if config.quick:
        return OcclusionSettings(config.aa_size, (1, 4, 16), 256)
    return OcclusionSettings(config.aa_size, (1, 4, 16, 64), 4096)


@dataclass
class OcclusionRow:
    samples: int | None  # None: AO off
    ms: float
    ao_rays: int
    rmse: float          # against the reference
    worst: float


@dataclass
class Occlusion:
    settings: OcclusionSettings
    runs: int
    reference_ms: float
    darkening: float     # RMS of (reference - AO off): how much AO changes the image
    rows: list[OcclusionRow] = field(default_factory=list)

    @property
    def slope(self) -> float:
        """Fitted log RMSE / log AO samples."""
        on = [r for r in self.rows if r.samples is not None]
        return fit_slope([r.samples for r in on], [r.rmse for r in on])


def measure_occlusion(config: Config) -> Occlusion:
    """The scene without AO and at each AO sample count (1 spp at the pixel centres, so the only
    noise is AO's), timed in the same rounds, against a `reference_samples` render of another seed."""
    settings = settings_for(config)
    scene = effect_scene(**SCENE_FLAGS)
    _, camera = showcase_scene()
    width, height = settings.size
    reference = render(scene, camera, width, height, passes=("color",), seed=REFERENCE_SEED,
                       ambient_occlusion=(settings.reference_samples, DISTANCE))
    counts: list[int | None] = [None, *settings.samples]
    renders = [lambda out, n=n: render(scene, camera, width, height, passes=("color",), seed=SEED, out=out,
                                       ambient_occlusion=None if n is None else (n, DISTANCE)) for n in counts]
    medians, results = timed(renders, config.timing_runs, reuse=True)
    rows = [OcclusionRow(n, ms, int(r.stats["ao_rays"]), rmse(r.color, reference.color),
                         worst_pixel(r.color, reference.color)) for n, ms, r in zip(counts, medians, results)]
    return Occlusion(settings, config.timing_runs, reference.stats["milliseconds"], rows[0].rmse, rows)


def markdown_section(occlusion: Occlusion) -> list[str]:
    """The page's lines for ambient occlusion."""
    s = occlusion.settings
    width, height = s.size
    off, most = occlusion.rows[0], occlusion.rows[-1]
    ns_per_ray = (most.ms - off.ms) * 1e6 / most.ao_rays
    lines = ["| AO samples | ms | time / AO off | AO rays per pixel | RMSE | worst pixel |",
             "| ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in occlusion.rows:
        lines.append(f"| {'off' if r.samples is None else r.samples} | {r.ms:.1f} | {r.ms / off.ms:.2f} | "
                     f"{r.ao_rays / (width * height):.1f} | {r.rmse:.2e} | {r.worst:.2e} |")
    return [
        "",
        "## Ambient occlusion",
        "",
        f"`render(..., ambient_occlusion=(samples, inf))` on the showcase geometry (spheres resting on a plane, "
        f"its sun with shadows) at {width}×{height}, 1 spp (pixel centres: AO is the only noise), against a "
        f"{s.reference_samples}-sample AO render of another seed; *off* is the render without AO, whose error is "
        f"AO's whole effect on the image (RMS {occlusion.darkening:.2e}). AO rays are Owen-scrambled Sobol' "
        "directions, so the RMSE falls faster than the spp^-0.5 of independent rays "
        f"(fitted slope {occlusion.slope:+.2f}). An AO ray stops at its first hit, like a shadow ray; at "
        f"{most.samples} samples each added {ns_per_ray:.0f} ns to the render. Times: the core's timer, median of "
        f"{occlusion.runs} rounds.",
        "",
        *lines,
    ]
