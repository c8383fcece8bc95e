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
    singular one) and whether each is a uniform scale times a rotation."""
    norms = np.linalg.norm(linear, axis=1)  # each column's length: the axis scales
    s = np.abs(np.linalg.det(linear)) ** (1.0 / 3.0)
    safe = np.where(s > 0, s, 1.0)
    gram = np.einsum("nij,nik->njk", linear, linear) / (safe * safe)[:, None, None]
    uniform = ((np.abs(gram - np.eye(3)).max(axis=(1, 2)) <= SCALE_TOLERANCE)
               & (np.ptp(norms, axis=1) <= SCALE_TOLERANCE * norms.max(axis=1)) & (s > 0))
    return s, uniform


def are_invertible(matrices: np.ndarray) -> np.ndarray:
    """is_invertible of each of (N, 4, 4) matrices at once: the core's rule, one call."""
    return _core.are_invertible(np.ascontiguousarray(matrices[:, :3, :], dtype=np.float64))


def transform_points(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    return p @ m[:3, :3].T + m[:3, 3]
