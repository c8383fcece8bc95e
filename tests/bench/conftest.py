"""The bench/ scripts imported as modules, as they run: with bench/ on the path (they import
primary_rays from it)."""

from __future__ import annotations

import importlib

import pytest

from helpers import ROOT


@pytest.fixture
def import_bench(monkeypatch):
    """importlib.import_module with bench/ first on the path; OPENBLAS_NUM_THREADS, which the scripts
    set when imported, is undone after the test."""
    monkeypatch.syspath_prepend(str(ROOT / "bench"))
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "1")
    return importlib.import_module
