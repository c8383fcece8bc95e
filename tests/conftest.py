from __future__ import annotations

import numpy as np
import pytest


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
