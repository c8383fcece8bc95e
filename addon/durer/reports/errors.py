"""Error measures of an image against a reference, and the convergence slope of a series."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def pixel_errors(image: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(H, W): each pixel's RMS difference over the colour channels (RGB; alpha is ignored)."""
    image, reference = np.asarray(image, np.float64), np.asarray(reference, np.float64)
    if image.shape != reference.shape:
        raise ValueError(f"shapes differ: {image.shape} vs {reference.shape}")
    if image.ndim == 3 and image.shape[-1] >= 3:
        image, reference = image[..., :3], reference[..., :3]
    elif image.ndim == 2:
        image, reference = image[..., None], reference[..., None]
    return np.sqrt(np.mean((image - reference) ** 2, axis=-1))


def rmse(image: np.ndarray, reference: np.ndarray) -> float:
    """Root mean square colour error over every pixel and RGB channel."""
    return float(np.sqrt(np.mean(pixel_errors(image, reference) ** 2)))


def worst_pixel(image: np.ndarray, reference: np.ndarray) -> float:
    """The largest per-pixel RMS colour error (same units as `rmse`)."""
    return float(np.max(pixel_errors(image, reference)))


def fit_slope(x: Sequence[float], y: Sequence[float]) -> float:
    """Least-squares slope of log y against log x (the convergence order: -0.5 for plain Monte
    Carlo). Points with non-positive or non-finite values are left out; nan if fewer than 2 remain
    or x does not vary."""
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    keep = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    lx, ly = np.log(x[keep]), np.log(y[keep])
    if lx.size < 2 or np.ptp(lx) == 0:
        return float("nan")
    return float(np.polyfit(lx, ly, 1)[0])


def depth_differences(depth: np.ndarray, reference: np.ndarray) -> tuple[float, float, int]:
    """Max |depth - reference| and max of it / |reference| over pixels both hit, and the number of
    pixels where one hit and the other missed (inf depth)."""
    a, b = np.asarray(depth, np.float64), np.asarray(reference, np.float64)
    both = np.isfinite(a) & np.isfinite(b)
    disagree = int(np.count_nonzero(np.isfinite(a) != np.isfinite(b)))
    if not both.any():
        return 0.0, 0.0, disagree
    diff = np.abs(a[both] - b[both])
    scale = np.maximum(np.abs(b[both]), np.finfo(np.float64).tiny)
    return float(diff.max()), float((diff / scale).max()), disagree
