from __future__ import annotations

import numpy as np
import pytest

import durer

METHODS = ("algebraic", "geometric", "robust")
PRECISIONS = ("float", "double")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261122)


@pytest.fixture(params=METHODS)
def method(request: pytest.FixtureRequest) -> str:
    return request.param


@pytest.fixture(params=PRECISIONS)
def precision(request: pytest.FixtureRequest) -> str:
    return request.param


def tolerance(precision: str) -> float:
    """Relative tolerance of t for ordinary (well-conditioned) cases."""
    return 1e-5 if precision == "float" else 1e-12


def unit_sphere_scene() -> durer.Scene:
    scene = durer.Scene()
    scene.add_spheres([[0.0, 0.0, 0.0]], [1.0])
    return scene


def cast_one(scene: durer.Scene, origin, direction, **kwargs) -> durer.CastResult:
    return durer.cast(scene, np.array([origin], float), np.array([direction], float), **kwargs)
