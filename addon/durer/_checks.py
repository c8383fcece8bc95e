"""Argument checks shared by the public API: each error names the argument it is about.

The boundary between Python and the core: Python checks types, shapes and dtypes (and that a
number fits the C type it is passed as, and an image's size, which a region is checked against);
the core checks values (ranges, finiteness, option names, invertibility) and its
std::invalid_argument arrives as a ValueError naming the argument."""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np

from . import _core


def _numeric_array(value: Any, name: str) -> np.ndarray:
    try:
        array = np.asarray(value)
    except (TypeError, ValueError) as error:  # ragged nesting and the like
        raise TypeError(f"{name} must be an array of numbers: {error}") from None
    if array.dtype.kind not in "iuf":
        raise TypeError(f"{name} must contain real numbers, got dtype {array.dtype}")
    return array


def _check_shape(array: np.ndarray, name: str, shape: tuple[int | str | None, ...]) -> None:
    """ValueError naming `name` unless `array` has `shape`: an int is that length, None or a name ("F") any."""
    if array.ndim != len(shape) or any(isinstance(s, int) and s != n for s, n in zip(shape, array.shape)):
        wanted = "(" + ", ".join("N" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
        raise ValueError(f"{name} must have shape {wanted}, got {array.shape}")


def _empty_as(array: np.ndarray, shape: tuple[int | str | None, ...]) -> np.ndarray:
    """`[]` as the empty array of `shape` when its first axis may be 0: np.asarray([]) has shape (0,), whatever
    axes the caller meant, and a caller passing [] for "none" means N = 0."""
    free = not isinstance(shape[0], int) or shape[0] == 0
    if array.shape == (0,) and len(shape) > 1 and free and all(isinstance(s, int) for s in shape[1:]):
        return array.reshape((0, *shape[1:]))
    return array


def float_array(value: Any, name: str, shape: tuple[int | str | None, ...], *, finite: bool = True) -> np.ndarray:
    """`value` as a C-contiguous float64 array of `shape` (None: any length)."""
    array = _empty_as(_numeric_array(value, name), shape)
    _check_shape(array, name, shape)
    array = np.ascontiguousarray(array, dtype=np.float64)
    if finite and not np.isfinite(array).all():
        bad = np.argwhere(~np.isfinite(array))[0]
        raise ValueError(f"{name} must be finite, got {array[tuple(bad)]} at index {tuple(int(i) for i in bad)}")
    return array


def integer_array(value: Any, name: str, shape: tuple[int | str | None, ...], dtype: type[np.integer]) -> np.ndarray:
    """`value` as a C-contiguous array of `shape` and integer `dtype`, each value fitting it (an empty one
    may have any numeric dtype: [] is float64 to numpy)."""
    array = _empty_as(_numeric_array(value, name), shape)
    if array.dtype.kind not in "iu" and array.size:
        raise TypeError(f"{name} must hold integers, got dtype {array.dtype}")
    _check_shape(array, name, shape)
    limits = np.iinfo(dtype)
    if array.size and (array.min() < limits.min or array.max() > limits.max):
        raise ValueError(f"{name} must fit in {limits.dtype}")
    return np.ascontiguousarray(array, dtype=dtype)


def one_of_shapes(value: Any, name: str, *shapes: tuple[int, ...]) -> np.ndarray | None:
    """`value` as a C-contiguous float64 array of one of `shapes` (told apart by their number of
    axes), or None for None; its values are the core's to check (per-primitive colours)."""
    if value is None:
        return None
    array = _numeric_array(value, name)
    for s in shapes:  # [] takes the first shape that may be empty
        array = _empty_as(array, s)
    shape = next((s for s in shapes if len(s) == array.ndim), None)
    if shape is None or array.shape != shape:
        raise ValueError(f"{name} must have shape {' or '.join(str(s) for s in shapes)}, got {array.shape}")
    return float_array(array, name, shape, finite=False)


def vector3(value: Any, name: str) -> tuple[float, float, float]:
    """Three real numbers (finiteness, non-zero length and the like are the core's to check)."""
    x, y, z = float_array(value, name, (3,), finite=False)
    return float(x), float(y), float(z)


def color(value: Any, name: str, channels: tuple[int, ...] = (3,)) -> tuple[float, ...]:
    """A colour of one of `channels` real components (the core checks that they are finite, >= 0)."""
    array = _numeric_array(value, name)
    if array.ndim != 1 or array.shape[0] not in channels:
        wanted = " or ".join(f"({c},)" for c in channels)
        raise ValueError(f"{name} must have shape {wanted}, got {array.shape}")
    return tuple(float(c) for c in array.astype(np.float64))


def components(value: Any, name: str, count: int) -> float | tuple[float, ...]:
    """`count` real numbers: a float for 1, else a tuple of `count` floats (their values are the
    core's to check)."""
    if count == 1:
        return real(value, name)
    return tuple(float(c) for c in float_array(value, name, (count,), finite=False))


def real(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    try:
        return float(value)
    except OverflowError:  # an int (or Fraction) beyond the largest double; infinity is math.inf
        raise ValueError(f"{name} must be within the range of a float (|x| < 1.8e308), got a number too large "
                         "for one") from None


def finite_real(value: Any, name: str) -> float:
    x = real(value, name)
    if not np.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x}")
    return x


def integer(value: Any, name: str, minimum: int | None = None, maximum: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    n = int(value)
    if minimum is not None and n < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {n}")
    if maximum is not None and n > maximum:
        raise ValueError(f"{name} must be <= {maximum}, got {n}")
    return n


#: The largest image width or height (and spp): the core's (scene/Limits.h, which keeps width·height·spp
#: inside int64; the core checks it too).
MAX_IMAGE_SIDE: int = _core.RENDER_LIMITS["side"]


def image_side(value: Any, name: str) -> int:
    """An image's width or height: an integer in [1, MAX_IMAGE_SIDE] (render's rule, checked before the
    arguments that depend on it, such as a region)."""
    return integer(value, name, 1, MAX_IMAGE_SIDE)


def items(value: Any, count: int, name: str, form: str) -> tuple:
    """The `count` items of a short sequence argument (a region, ambient occlusion's pair): TypeError
    naming `name` for a value that is not a sequence, ValueError for one of another length; `form`
    says what it should be, as "(samples, distance)"."""
    try:
        result = tuple(value)
    except TypeError:
        raise TypeError(f"{name} must be {form} or None, got {type(value).__name__}") from None
    if len(result) != count:
        raise ValueError(f"{name} must be {form} or None, got {len(result)} items: {value!r}")
    return result


def c_int(value: Any, name: str) -> int:
    """An integer that fits the core's C int (its range is the core's to check)."""
    return integer(value, name, -(2**31), 2**31 - 1)


def string(value: Any, name: str) -> str:
    """An option name (which names are valid is the core's to check: durer._core's tuples)."""
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a string, got {type(value).__name__}")
    return value


def boolean(value: Any, name: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {type(value).__name__}")
    return bool(value)


def flags(value: Any, name: str, n: int) -> np.ndarray | None:
    """One bool or (n,) bools as (n,) uint8 flags; None where none is set (the core's default)."""
    array = np.asarray(value)
    if array.dtype != np.bool_:
        raise TypeError(f"{name} must be True, False or an array of bools, got {array.dtype if array.ndim else type(value).__name__}")
    if array.ndim not in (0, 1) or (array.ndim == 1 and array.shape[0] != n):
        raise ValueError(f"{name} must be one bool or {n} bools, got shape {array.shape}")
    return np.ascontiguousarray(np.broadcast_to(array, (n,)), dtype=np.uint8) if array.any() else None


def transform(value: Any, name: str = "transform") -> np.ndarray | None:
    """A world-from-object affine matrix, (4, 4) with bottom row (0, 0, 0, 1) or (3, 4), as a
    C-contiguous (3, 4) float64 array; None stays None (the identity). It must be invertible by the
    core's one rule (`_core.is_invertible`)."""
    if value is None:
        return None
    array = _numeric_array(value, name)
    if array.shape not in ((4, 4), (3, 4)):
        raise ValueError(f"{name} must have shape (4, 4) or (3, 4), got {array.shape}")
    array = array.astype(np.float64)
    if not np.isfinite(array).all():
        raise ValueError(f"{name} must be finite")
    if array.shape == (4, 4):
        if not np.array_equal(array[3], [0.0, 0.0, 0.0, 1.0]):
            raise ValueError(f"{name} must be affine: its bottom row must be (0, 0, 0, 1), got {tuple(array[3].tolist())}")
        array = array[:3]
    array = np.ascontiguousarray(array)
    if not _core.is_invertible(array):
        raise ValueError(f"{name} must be invertible (it is singular, or its inverse overflows)")
    return array


def transforms(value: Any, name: str = "transforms") -> np.ndarray:
    """(N, 4, 4) or (N, 3, 4) world-from-object affine matrices, N >= 1, as a C-contiguous (N, 3, 4)
    float64 array (the core checks each is invertible, naming it)."""
    array = _numeric_array(value, name)
    if array.ndim != 3 or array.shape[1:] not in ((4, 4), (3, 4)) or array.shape[0] < 1:
        raise ValueError(f"{name} must have shape (N, 4, 4) or (N, 3, 4) with N >= 1, got {array.shape}")
    array = array.astype(np.float64)
    if array.shape[1] == 4:
        wrong = np.flatnonzero(np.any(array[:, 3] != (0.0, 0.0, 0.0, 1.0), axis=1))
        if wrong.size:
            raise ValueError(f"{name}[{wrong[0]}] must be affine: its bottom row must be (0, 0, 0, 1), got "
                             f"{tuple(array[wrong[0], 3].tolist())}")
        array = array[:, :3]
    return np.ascontiguousarray(array)


def is_invertible(matrix: Any) -> bool:
    """Whether `transform` takes `matrix`: finite, (4, 4) with bottom row (0, 0, 0, 1) or (3, 4), and
    invertible by the core's rule (the one every transform passed to a Scene must meet). A matrix of
    another shape is not a transform at all, so it is not one either."""
    try:
        transform(matrix)
    except ValueError:
        return False
    return True
