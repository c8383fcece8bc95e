"""Scenes whose pixels' exact values are known: a flat white half-plane on black, seen by a camera of
one unit per pixel, where a pixel's value is the fraction of it the half-plane covers."""

from __future__ import annotations

import math

import numpy as np

import durer

WHITE_ON_BLACK = (0.0, 0.0, 0.0, 1.0)


def half_plane_scene(theta: float, c: float) -> durer.Scene:
    """A white half-plane {p in z = 0 : cos(theta)·x + sin(theta)·y >= c} on black, flat colours
    (no lights): a pixel's exact value is the fraction of it the half-plane covers."""
    scene = durer.Scene()
    scene.background = WHITE_ON_BLACK
    white = scene.add_material((1, 1, 1))
    n = np.array([math.cos(theta), math.sin(theta), 0.0])
    d = np.array([-math.sin(theta), math.cos(theta), 0.0])
    big = 1000.0
    corner = c * n - big * d
    scene.add_plane((0, 0, 1), 0.0, material=white, bounds=(corner, 2 * big * d, big * n))
    return scene


def pixel_camera(width: int, height: int) -> durer.OrthographicCamera:
    """Orthographic, looking down -z, one unit per pixel: pixel (i, j) (column i, row j from the
    top) spans x in i - W/2 + [0, 1], y in H/2 - j - [1, 0]."""
    return durer.OrthographicCamera((0, 0, 1), (0, 0, -1), (0, 1, 0), float(max(width, height)))


def pixel_centres(width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    x = np.arange(width) + 0.5 - width / 2
    y = height / 2 - np.arange(height) - 0.5
    return np.meshgrid(x, y)


def _ramp_integral(t: np.ndarray) -> np.ndarray:
    """An antiderivative of clip(t, 0, 1)."""
    return np.where(t < 0, 0.0, np.where(t <= 1, t * t / 2, t - 0.5))


def half_plane_coverage(theta: float, c: float, width: int, height: int) -> np.ndarray:
    """Exact covered fraction of every pixel (0 < theta < pi/2): for u across the pixel, the covered
    height is clip(a + b·u, 0, 1), whose integral over u in [-1/2, 1/2] is closed-form."""
    x, y = pixel_centres(width, height)
    s, k = math.sin(theta), math.cos(theta)
    a = 0.5 + y - (c - k * x) / s
    b = k / s
    return (_ramp_integral(a + b / 2) - _ramp_integral(a - b / 2)) / b


def vertical_edge_coverage(c: float, width: int, height: int) -> np.ndarray:
    """theta = 0: the half-plane x >= c."""
    x, _ = pixel_centres(width, height)
    return np.clip(x + 0.5 - c, 0.0, 1.0)


def render_values(scene, width, height, **kwargs) -> np.ndarray:
    return durer.render(scene, pixel_camera(width, height), width, height, passes="color", **kwargs).color[..., 0]


# A tilted edge across a 48 x 48 image: about a hundred pixels with every kind of cut.
THETA, C, SIZE = 0.6, 0.37, 48
COVERAGE = half_plane_coverage(THETA, C, SIZE, SIZE)
COVERAGE[COVERAGE < 1e-9], COVERAGE[COVERAGE > 1 - 1e-9] = 0.0, 1.0  # uncut pixels: exactly 0 or 1
CUT = (COVERAGE > 0) & (COVERAGE < 1)


def discs_coverage(discs: list[tuple[float, float, float]], width: int, height: int, steps: int = 40000) -> np.ndarray:
    """The fraction of every pixel (of pixel_camera's image) the union of the discs (centre x, y and
    radius each) covers, by the midpoint rule across the pixel of the union of the chords' parts
    within it (error ~1e-7: the chords' square-root ends)."""
    xs, ys = pixel_centres(width, height)
    share = np.zeros((height, width))
    u = (np.arange(steps) + 0.5) / steps - 0.5
    for j in range(height):
        for i in range(width):
            near = [(cx, cy, r) for cx, cy, r in discs
                    if abs(xs[j, i] - cx) <= r + 0.5 and abs(ys[j, i] - cy) <= r + 0.5]
            if not near:
                continue  # beyond every disc's bounding box: 0
            x = xs[j, i] + u
            spans = []  # each disc's chord within the pixel: (bottom, top); an empty one has top <= bottom
            for cx, cy, radius in near:
                half = np.sqrt(np.maximum(radius * radius - (x - cx) ** 2, 0.0))
                spans.append((np.maximum(cy - half, ys[j, i] - 0.5), np.minimum(cy + half, ys[j, i] + 0.5)))
            bottoms, tops = np.array([b for b, _ in spans]), np.array([t for _, t in spans])
            order = np.argsort(bottoms, axis=0, kind="stable")
            bottoms, tops = np.take_along_axis(bottoms, order, 0), np.take_along_axis(tops, order, 0)
            covered, reached = np.zeros(steps), np.full(steps, ys[j, i] - 0.5)
            for bottom, top in zip(bottoms, tops):  # by their bottoms: each adds what lies above the ones before
                covered += np.maximum(top - np.maximum(bottom, reached), 0.0)
                reached = np.maximum(reached, top)
            share[j, i] = np.mean(covered)
    return share


def disc_coverage(cx: float, cy: float, radius: float, width: int, height: int, steps: int = 40000) -> np.ndarray:
    """The fraction of every pixel (of pixel_camera's image) the disc of centre (cx, cy) and `radius`
    covers (discs_coverage of the one disc)."""
    return discs_coverage([(cx, cy, radius)], width, height, steps)
