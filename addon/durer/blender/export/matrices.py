"""World matrices of Blender objects as numpy arrays, and what the export asks of them."""

from __future__ import annotations

import numpy as np

from ... import _checks

#: Relative spread of an object's axis scales above which its scale counts as non-uniform.
SCALE_TOLERANCE = 1e-4


def world_matrix(m) -> np.ndarray:
    return np.array(m, dtype=np.float64).reshape(4, 4)


def uniform_scale(m: np.ndarray) -> tuple[float, bool]:
    """Uniform scale factor of a 4x4 matrix (geometric mean of the axis scales) and whether the
    linear part is a uniform scale times a rotation."""
    lin = m[:3, :3]
    norms = np.linalg.norm(lin, axis=0)
    det = abs(float(np.linalg.det(lin)))
    s = det ** (1.0 / 3.0)
    if s == 0.0:
        return 0.0, False
    gram = lin.T @ lin / (s * s)
    uniform = bool(np.abs(gram - np.eye(3)).max() <= SCALE_TOLERANCE) and bool(
        np.ptp(norms) <= SCALE_TOLERANCE * norms.max()
    )
    return s, uniform


def is_invertible(m: np.ndarray) -> bool:
    """Can the core take `m` as a transform (durer._checks.transform: the core's one rule)? The
    export puts a mesh it cannot take in world space instead."""
    try:
        _checks.transform(m, "matrix_world")
    except ValueError:
        return False
    return True


def transform_points(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    return p @ m[:3, :3].T + m[:3, 3]
