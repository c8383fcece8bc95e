"""World matrices of Blender objects as numpy arrays, and what the export asks of them."""

from __future__ import annotations

import numpy as np

from ... import _core

#: Relative spread of an object's axis scales above which its scale counts as non-uniform.
SCALE_TOLERANCE = 1e-4


def world_matrix(m) -> np.ndarray:
    return np.array(m, dtype=np.float64).reshape(4, 4)


def uniform_scale(m: np.ndarray) -> tuple[float, bool]:
    """Uniform scale factor of a 4x4 matrix (geometric mean of the axis scales) and whether the
    linear part is a uniform scale times a rotation."""
    s, uniform = uniform_scales(m[None, :3, :3])
    return float(s[0]), bool(uniform[0])


def uniform_scales(linear: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`uniform_scale` of many linear parts at once ((N, 3, 3)): the scale factors (0 for a
    singular one) and whether each is a uniform scale times a rotation. Each entry of all the
    matrices is one array here (a million particles' matrices take tens of milliseconds)."""
    m = np.ascontiguousarray(np.moveaxis(np.asarray(linear, np.float64), 0, -1))  # m[i, j]: row i, column j
    det = (m[0, 0] * (m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1]) - m[0, 1] * (m[1, 0] * m[2, 2] - m[1, 2] * m[2, 0])
           + m[0, 2] * (m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0]))
    s = np.abs(det) ** (1.0 / 3.0)
    s2 = np.where(s > 0, s * s, 1.0)
    lengths2 = [m[0, j] * m[0, j] + m[1, j] * m[1, j] + m[2, j] * m[2, j] for j in range(3)]  # the axis scales²
    spread = np.zeros(len(s))  # max |columns' Gram matrix / s² - identity|
    for j in range(3):
        np.maximum(spread, np.abs(lengths2[j] / s2 - 1.0), out=spread)
        for k in range(j + 1, 3):
            np.maximum(spread, np.abs((m[0, j] * m[0, k] + m[1, j] * m[1, k] + m[2, j] * m[2, k]) / s2), out=spread)
    norms = np.sqrt(lengths2)
    uniform = ((spread <= SCALE_TOLERANCE) & (np.ptp(norms, axis=0) <= SCALE_TOLERANCE * norms.max(axis=0)) & (s > 0))
    return s, uniform


def are_invertible(matrices: np.ndarray) -> np.ndarray:
    """is_invertible of each of (N, 4, 4) matrices at once: the core's rule, one call."""
    return _core.are_invertible(np.ascontiguousarray(matrices[:, :3, :], dtype=np.float64))


def transform_points(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    return p @ m[:3, :3].T + m[:3, 3]
