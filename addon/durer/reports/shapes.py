"""Exact answers for triangles, boxes and ellipsoids (mpmath, 60 digits, from the inputs as rounded
to the precision under test), the rounding zone where a hit or miss may go either way, and the
sweep `python -m durer numerics` prints for them next to the spheres' (docs/numerics.md).

Each exact answer comes with a margin: how far inside the shape the ray passes, relative to the
shape's size (negative: outside). A ray with |margin| <= zone(...) passes within rounding of an
edge, a corner or the silhouette, where either answer is right; beyond it the answer must be exact,
and t within the documented bound of the exact t.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import mpmath
import numpy as np
from numpy.typing import ArrayLike

if TYPE_CHECKING:
    from ..scene import Scene

MP = mpmath.MPContext()  # a private context: the global mpmath precision stays untouched
MP.dps = 60
KINDS = ("triangle", "box", "ellipsoid")
DTYPE = {"float": np.float32, "double": np.float64}


def unit_roundoff(precision: str) -> float:
    return float(np.finfo(DTYPE[precision]).eps) / 2


def _v(values) -> list:
    return [MP.mpf(float(x)) for x in values]


def _sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def exact_triangle(
    o: ArrayLike, d: ArrayLike, v0: ArrayLike, v1: ArrayLike, v2: ArrayLike
) -> tuple[float | None, float]:
    """t >= 0 where the ray meets the triangle's plane (None if parallel or behind), and the margin:
    the smallest barycentric coordinate of that point, times the ratio of the triangle's smallest
    height to its longest edge (so a sliver's margin is its width over its length)."""
    o, d, a, b, c = (_v(x) for x in (o, d, v0, v1, v2))
    n = _cross(_sub(b, a), _sub(c, a))
    denominator = _dot(n, d)
    if denominator == 0:
        return None, -1.0
    t = _dot(n, _sub(a, o)) / denominator
    p = [o[i] + t * d[i] for i in range(3)]
    area2 = _dot(n, n)
    weights = [_dot(_cross(_sub(c, b), _sub(p, b)), n) / area2, _dot(_cross(_sub(a, c), _sub(p, c)), n) / area2,
               _dot(_cross(_sub(b, a), _sub(p, a)), n) / area2]
    longest = max(MP.sqrt(_dot(e, e)) for e in (_sub(b, a), _sub(c, b), _sub(a, c)))
    height = MP.sqrt(area2) / longest
    margin = float(min(weights) * height / longest)
    return (float(t) if t >= 0 else None), margin


def exact_box(o: ArrayLike, d: ArrayLike, lo: ArrayLike, hi: ArrayLike) -> tuple[float | None, float]:
    """The first t >= 0 on the closed box's surface (the exit for an origin inside), and the margin:
    (t_far - t_near) over the t the box's size takes to cross, so a ray through an edge or corner has 0."""
    o, d, lo, hi = (_v(x) for x in (o, d, lo, hi))
    near, far = MP.mpf("-inf"), MP.mpf("inf")
    for a in range(3):
        if d[a] == 0:
            if o[a] < lo[a] or o[a] > hi[a]:
                return None, -1.0
            continue
        t0, t1 = (lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]
        near, far = max(near, min(t0, t1)), min(far, max(t0, t1))
    size = max(hi[a] - lo[a] for a in range(3)) / MP.sqrt(_dot(d, d))
    margin = float((far - near) / size)
    if far < near or far < 0:
        return None, min(margin, -0.0)
    return float(near if near >= 0 else far), margin


def exact_ellipsoid(o: ArrayLike, d: ArrayLike, world_from_object: ArrayLike) -> tuple[float | None, float]:
    """The unit sphere at the origin seen through world_from_object ((3, 4) or (4, 4), as given):
    the first t >= 0 on it, and the margin 1 - p² where p is the ray's closest approach to the
    centre in object space (0: tangent)."""
    m = MP.matrix([[MP.mpf(float(world_from_object[i][j])) for j in range(3)] for i in range(3)])
    offset = MP.matrix([MP.mpf(float(world_from_object[i][3])) for i in range(3)])
    inverse = m ** -1
    lo = inverse * (MP.matrix(_v(o)) - offset)
    ld = inverse * MP.matrix(_v(d))
    a = sum(ld[i] ** 2 for i in range(3))
    b = sum(lo[i] * ld[i] for i in range(3))
    c = sum(lo[i] ** 2 for i in range(3)) - 1
    closest = c + 1 - b * b / a
    margin = float(1 - closest)
    disc = b * b - a * c
    if disc < 0:
        return None, margin
    root = MP.sqrt(disc)
    for t in ((-b - root) / a, (-b + root) / a):
        if t >= 0:
            return float(t), margin
    return None, margin


def zone(kind: str, precision: str, distance_over_size: float, condition: float = 1.0) -> float:
    """|margin| within which a hit or a miss is right (rounding of the inputs' differences over the
    ray's length): 64u times distance/size (and the transform's condition number)."""
    return 64 * unit_roundoff(precision) * (1 + distance_over_size) * condition


def t_bound(kind: str, precision: str, t: float, reach: float, cosine: float, condition: float = 1.0) -> float:
    """The documented bound on |t - t*|: 64u(|t*| + reach) over |cos| of the angle to the surface's
    normal (triangles, whose t comes from the plane; boxes and ellipsoids: 1), times the transform's
    condition number; reach is the distance from the origin to the shape's far side over |d|."""
    steepness = abs(cosine) if kind == "triangle" else 1.0
    return 64 * unit_roundoff(precision) * (abs(t) + reach) * condition / steepness


@dataclass
class ShapeRow:
    kind: str
    precision: str
    scale: float        # distance / size (triangles, boxes), or the condition number (ellipsoids)
    worst_error: float  # worst |t - t*| / the documented bound, over decided hits
    worst_relative: float  # worst |t - t*| / t*
    decided: int        # rays outside the rounding zone
    hits: int           # of them, exact hits reported as hits (the t errors are theirs)
    false_hits: int     # decided misses reported as hits
    false_misses: int   # decided hits reported as misses


DIRECTION = np.array([0.36, -0.48, 0.8])  # oblique, so no coordinate is trivially exact
RATIOS = tuple(10.0**k for k in range(0, 10))     # triangles and boxes: distance / size
CONDITIONS = tuple(10.0**k for k in range(0, 9, 2))  # ellipsoids: longest / shortest axis
RAYS_PER_POINT = 256


def _frame(rng: np.random.Generator) -> np.ndarray:
    """A random rotation (columns: an orthonormal frame)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


#: What `shape_case` returns: (add(scene), exact(o, d), reach(o, d), cosine(d), origins, directions,
#: distance/size, condition).
ShapeCase = tuple[Callable[["Scene"], object], Callable[[np.ndarray, np.ndarray], tuple[float | None, float]],
                  Callable[[np.ndarray, np.ndarray], float], Callable[[np.ndarray], float], np.ndarray, np.ndarray,
                  float, float]


def shape_case(
    kind: str, scale: float, precision: str, rng: np.random.Generator, size: float = 1.0
) -> ShapeCase | None:
    """One shape of size about `size` (`scale` sizes away along DIRECTION; an ellipsoid with axes sqrt(scale),
    1, 1/sqrt(scale) 10 longest axes away) with its inputs rounded to `precision`, and RAYS_PER_POINT
    rays from near the origin aimed across it. Returns (add(scene), exact(o, d), reach(o, d), cosine(d),
    origins, directions, distance/size, condition), or None where the rounding collapses the shape."""
    dtype = DTYPE[precision]
    rounded = lambda x: (np.asarray(x, np.float64) * size).astype(dtype).astype(np.float64)  # noqa: E731
    frame = _frame(rng)
    if kind == "ellipsoid":
        axes = np.array([np.sqrt(scale), 1.0, 1 / np.sqrt(scale)])
        center = DIRECTION * 10 * axes[0]
        matrix = rounded(np.hstack([frame * axes, center[:, None]]))
        corners = matrix[:, 3] + np.concatenate([matrix[:, :3].T, -matrix[:, :3].T])  # the axes' tips
        add = lambda s: s.add_spheres([[0, 0, 0]], 1.0, transform=matrix)  # noqa: E731
        exact = lambda o, d: exact_ellipsoid(o, d, matrix)  # noqa: E731
        extent, condition, ratio = axes[0], scale, 10.0
    elif kind == "triangle":
        center = DIRECTION * scale
        vertices = rounded(center + (frame @ np.array([[1, 0, 0], [-0.5, 0.866, 0], [-0.5, -0.866, 0]]).T).T)
        corners = vertices
        add = lambda s: s.add_triangles(vertices[None])  # noqa: E731
        exact = lambda o, d: exact_triangle(o, d, *vertices)  # noqa: E731
        extent, condition, ratio = 1.0, 1.0, scale
    else:
        center = DIRECTION * scale
        lo, hi = rounded(center - [0.5, 0.35, 0.2]), rounded(center + [0.5, 0.35, 0.2])
        if not (lo < hi).all():
            return None  # the precision cannot hold a unit box this far out
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        add = lambda s: s.add_boxes([lo], [hi])  # noqa: E731
        exact = lambda o, d: exact_box(o, d, lo, hi)  # noqa: E731
        extent, condition, ratio = 1.0, 1.0, scale
    side = np.cross(DIRECTION, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    up = np.cross(side, DIRECTION)
    lateral = rng.uniform(-1.2, 1.2, (RAYS_PER_POINT, 2)) * extent
    origins = rounded(rng.uniform(-1, 1, (RAYS_PER_POINT, 3)))
    targets = size * (center + lateral[:, :1] * side + lateral[:, 1:] * up)
    if kind == "ellipsoid":  # aimed across its own axes, or a thin one would be missed by most rays
        ball = rng.normal(size=(RAYS_PER_POINT, 3))
        ball *= rng.uniform(0, 1.3, (RAYS_PER_POINT, 1)) / np.linalg.norm(ball, axis=1, keepdims=True)
        targets = matrix[:, 3] + (matrix[:, :3] @ ball.T).T
    directions = (targets - origins).astype(dtype).astype(np.float64)
    normal = np.cross(corners[1] - corners[0], corners[2] - corners[0]) if kind == "triangle" else np.ones(3)
    if not np.linalg.norm(normal) > 0:
        return None  # the precision cannot hold a unit triangle this far out
    normal = normal / np.linalg.norm(normal)
    reach = lambda o, d: np.max(np.linalg.norm(corners - o, axis=1)) / np.linalg.norm(d)  # noqa: E731
    cosine = lambda d: float(normal @ d / np.linalg.norm(d))  # noqa: E731
    return add, exact, reach, cosine, origins, directions, ratio, condition


def judge(kind: str, precision: str, scale: float, got_t: np.ndarray, case: ShapeCase) -> ShapeRow:
    """Compare a cast's t with the exact answers of `case` (from shape_case)."""
    _, exact, reach, cosine, origins, directions, ratio, condition = case
    row = ShapeRow(kind, precision, scale, 0.0, 0.0, 0, 0, 0, 0)
    for o, d, g in zip(origins, directions, got_t):
        t, margin = exact(o, d)
        if abs(margin) <= zone(kind, precision, ratio, condition):
            continue
        row.decided += 1
        hit = t is not None and margin > 0
        if not hit:
            row.false_hits += bool(np.isfinite(g))
        elif not np.isfinite(g):
            row.false_misses += 1
        else:
            row.hits += 1
            bound = t_bound(kind, precision, t, reach(o, d), cosine(d), condition)
            row.worst_error = max(row.worst_error, abs(float(g) - t) / bound)
            row.worst_relative = max(row.worst_relative, abs(float(g) - t) / t)
    return row


def sweep(seed: int = 1) -> list[ShapeRow]:
    from ..cast import cast
    from ..scene import Scene

    rows = []
    for kind in KINDS:
        for precision in DTYPE:
            for scale in CONDITIONS if kind == "ellipsoid" else RATIOS:
                case = shape_case(kind, scale, precision, np.random.default_rng(seed))
                if case is None:
                    rows.append(ShapeRow(kind, precision, scale, float("nan"), float("nan"), 0, 0, 0, 0))
                    continue
                scene = Scene()
                case[0](scene)
                got = cast(scene, case[4], case[5], precision=precision).t
                rows.append(judge(kind, precision, scale, got, case))
    return rows


def markdown_table(rows: list[ShapeRow]) -> str:
    lines = []
    for kind, title, what in (("triangle", "Triangles", "distance / size"), ("box", "Boxes", "distance / size"),
                              ("ellipsoid", "Ellipsoids", "condition number (axes √κ : 1 : 1/√κ)")):
        scales = sorted({r.scale for r in rows if r.kind == kind})
        lines += [f"**{title}** by {what}: worst relative error of t (worst error over the documented bound, "
                  f"decided hits of {RAYS_PER_POINT} rays), wrong answers beyond the rounding zone", "",
                  f"| precision | " + " | ".join(f"10^{int(round(np.log10(s)))}" for s in scales) + " |",
                  "| --- | " + " | ".join("---" for _ in scales) + " |"]
        for precision in DTYPE:
            cells = []
            for s in scales:
                r = next(r for r in rows if r.kind == kind and r.precision == precision and r.scale == s)
                wrong = [f"{n} {w}" for n, w in ((r.false_hits, "false hits"), (r.false_misses, "false misses")) if n]
                if not r.hits:
                    cells.append("—" + (" " + ", ".join(wrong) if wrong else ""))
                    continue
                cells.append(f"{r.worst_relative:.0e} ({r.worst_error:.2f}, {r.hits} hits)" +
                             (" " + ", ".join(wrong) if wrong else ""))
            lines.append(f"| {precision} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines).rstrip()
