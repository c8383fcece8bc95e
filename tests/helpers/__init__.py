"""Helpers shared by several test modules: `core` (small scenes and casts), `exact` (mpmath answers
and the numerics spec), `blender` (scenes built with the real bpy), `blender_import` (when the Blender
tests may skip) and `exr` (reading Blender's EXRs); here, the repository's folders the tests read."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "scenes"
CORPUS = SCENES / "6837"
