"""Named quality presets: render settings a user can pick without knowing samplers.

    durer.render(scene, camera, 1920, 1080, **durer.preset("final"))

docs/accuracy.md (`python -m durer accuracy`) reports each preset's measured time and error.
"""

from __future__ import annotations

from typing import Any

PRESETS: dict[str, dict[str, Any]] = {
    # One ray per pixel centre in single precision: the fastest look at a scene.
    "draft": {"sampler": "center", "spp": 1, "precision": "float"},
    # A few stratified samples: edges already smooth.
    "preview": {"sampler": "stratified", "spp": 4, "precision": "float"},
    # Samples where they matter: 8 per pixel first (enough not to miss what is a few pixels across),
    # then up to 64 where the estimated error or an edge asks for them.
    "final": {"sampler": "adaptive", "spp": 64, "min_spp": 8, "target_error": 0.005, "precision": "double"},
    # Converged: what the others are measured against.
    "reference": {"sampler": "stratified", "spp": 1024, "precision": "double"},
}


def preset(name: str) -> dict[str, Any]:
    """The render keyword arguments of preset `name` ("draft", "preview", "final", "reference"), a copy."""
    if name not in PRESETS:
        raise ValueError(f"preset must be one of {', '.join(repr(p) for p in PRESETS)}; got {name!r}")
    return dict(PRESETS[name])
