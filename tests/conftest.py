"""Fixtures shared by every test folder. Helpers shared by several test modules live in the
`helpers` package (tests/helpers/, on the path through pytest's `pythonpath` setting)."""

from __future__ import annotations

import numpy as np
import pytest

from durer.render import PRECISIONS, SPHERE_METHODS


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261122)


@pytest.fixture(params=SPHERE_METHODS)
def method(request: pytest.FixtureRequest) -> str:
    return request.param


@pytest.fixture(params=PRECISIONS)
def precision(request: pytest.FixtureRequest) -> str:
    return request.param
