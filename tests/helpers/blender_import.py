"""The one rule for importing Blender's modules (bpy, bmesh) in the tests.

.ci/setup installs bpy unless DURER_SKIP_BPY=1, its documented opt-out: only then may the Blender tests
skip when bpy is missing. Otherwise a missing bpy is an import error, not ~250 silently skipped tests."""

from __future__ import annotations

import importlib
import os

import pytest


def blender_module(name: str):
    """The module `name` (bpy, bmesh): skipped if missing under DURER_SKIP_BPY=1, else imported plainly."""
    if os.environ.get("DURER_SKIP_BPY", "0") == "1":
        return pytest.importorskip(name, reason="DURER_SKIP_BPY=1: bpy (Blender 5.0 from PyPI) is not installed")
    return importlib.import_module(name)
