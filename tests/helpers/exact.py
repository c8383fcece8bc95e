"""Exact answers of ray/sphere and ray/plane tests (mpmath, 60 digits) from the inputs as rounded to
the precision under test, and the spec a cast is judged by (`judge`). The tolerances are derived
in tests/core/test_numerics.py's docstring; tests/core/test_numerics*.py use them."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import mpmath
import numpy as np

import durer

DTYPE = {"float": np.float32, "double": np.float64}
INF = math.inf
NAN = math.nan

# --- tolerances, in units of u (see the module docstring for the derivations) ---------------------
WELL_CONDITIONED = 32   # textbook methods, ordinary cases: |t - t*| <= 32u(|t*| + (|f| + r)/|d|) where h² >= r²/4
ROBUST_T = 16           # robust: |t - t*| <= 16u(|t*| + r/|d|) where h² >= r²/4 (f and c are carried exactly)
GRAZING_POSITION = 64   # grazing hits lie within G = 64u(|f| + r) of the sphere
GRAZING_ZONE = 32       # margin on r² - p² where the robust method may miss or graze: 32u(r² + p²)
FAR_BAND = 2            # in units of ε = 2u: a miss is allowed where p > r - 2ε|f| (the core: r - ε|f|)
PLANE = 8               # |t - t*| <= 8u(S_N + |t*| S_D)/|n·d| + 2u|t*|
PLANE_DIVISION = 2
NORMAL = 4              # sphere normal: 2(δt|d| + 4u(|o| + |t||d| + |c|))/r + 8u

MP = mpmath.MPContext()  # a private context: the global mpmath precision stays untouched
MP.dps = 60


def unit_roundoff(precision: str) -> float:
    return float(np.finfo(DTYPE[precision]).eps) / 2


def rounded(values: Any, precision: str) -> np.ndarray:
    """`values` as the core sees them: doubles rounded to nearest in `precision` (beyond range: inf)."""
    with np.errstate(over="ignore"):
        return np.asarray(values, dtype=np.float64).astype(DTYPE[precision])


def mp_vector(values: np.ndarray) -> list:
    return [MP.mpf(float(x)) for x in values]


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def norm(a):
    return MP.sqrt(dot(a, a))


# --- primitives ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Sphere:
    center: Any
    radius: Any


@dataclass(frozen=True)
class Plane:
    normal: Any   # need not be unit
    offset: Any   # points p with normal·p = offset


def stored_plane(plane: Plane, precision: str) -> tuple[np.ndarray, np.ndarray]:
    """The plane's unit normal and point as the core stores them (Scene.cpp: normalised in double
    after scaling by the largest component, point = unit offset · unit normal), then rounded."""
    nx, ny, nz = (float(v) for v in plane.normal)
    largest = max(abs(nx), abs(ny), abs(nz))
    sx, sy, sz = nx / largest, ny / largest, nz / largest
    length = math.sqrt(sx * sx + sy * sy + sz * sz)
    unit = (sx / length, sy / length, sz / length)
    unit_offset = float(plane.offset) / largest / length
    point = tuple(unit_offset * c for c in unit)
    return rounded(unit, precision), rounded(point, precision)


def build_scene(primitives: tuple) -> tuple[durer.Scene, list[int]]:
    scene = durer.Scene()
    ids = []
    for p in primitives:
        if isinstance(p, Sphere):
            ids.append(int(scene.add_spheres([p.center], [p.radius])[0]))
        else:
            ids.append(scene.add_plane(p.normal, p.offset))
    return scene, ids


# --- exact answers ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Root:
    """An exact root t of one primitive and how a reported hit is measured against it."""

    t: Any                      # mpf
    tol: float                  # a hit within tol of t is this root
    required: bool              # missing it (if it lies clearly inside [t_min, t_max)) is wrong
    position_tol: float | None  # grazing: the reported point must lie within this of the surface
    real: bool = True           # False: the closest approach of a ray that misses by less than rounding


@dataclass
class Exact:
    """One primitive's exact answer for one ray (from the rounded inputs)."""

    roots: list[Root]
    surface_distance: Callable[[Any], Any]  # t -> distance of o + t·d from the surface
    normal_check: Callable[[float, np.ndarray, Root], str | None]
    info: dict = field(default_factory=dict)


def representable(t, precision: str) -> bool:
    return abs(t) <= float(np.finfo(DTYPE[precision]).max)


def exact_sphere(o, d, sphere: Sphere, precision: str, *, robust: bool = True) -> Exact:
    """Roots of |o + t·d - c|² = r² for the rounded inputs, with the robust method's tolerances
    (robust=True) or the looser ones the textbook methods meet on ordinary cases (robust=False)."""
    u = unit_roundoff(precision)
    o_r, d_r = rounded(o, precision), rounded(d, precision)
    c_r, r_r = rounded(sphere.center, precision), rounded(sphere.radius, precision)
    finite = bool(np.isfinite(o_r).all() and np.isfinite(d_r).all() and np.isfinite(c_r).all()
                  and np.isfinite(r_r)) and bool(d_r.any())
    if not finite:
        return Exact([], lambda t: MP.inf, lambda *a: None, {"finite": False})
    o_m, d_m, c_m, r = mp_vector(o_r), mp_vector(d_r), mp_vector(c_r), MP.mpf(float(r_r))
    f = sub(o_m, c_m)
    with np.errstate(over="ignore", invalid="ignore"):
        f_core = mp_vector(o_r - c_r)  # what the core computes: f rounded once
    e = norm(sub(f_core, f)) if all(MP.isfinite(x) for x in f_core) else MP.inf
    dd = dot(d_m, d_m)
    nd = MP.sqrt(dd)
    f_len = norm(f)
    p2 = dot(cross(f, d_m), cross(f, d_m)) / dd
    h2 = r * r - p2
    t_ca = -dot(f, d_m) / dd
    g_pos = GRAZING_POSITION * u * (f_len + r)
    # Misses allowed: the robust method treats the sphere as radius r - ε|f| (so that the rounding
    # of f can never make a false hit) with a margin of 8ε(r² + p²); doubled here.
    # The robust method carries f = o - c exactly, so only its margin on r² - p² may turn a hit into a
    # miss or a miss into a hit. The textbook methods round f (and more): their band is wider.
    r_in = r if robust else max(r - 2 * FAR_BAND * u * f_len, MP.mpf(0))
    z_miss = r * r - r_in * r_in + GRAZING_ZONE * u * (r * r + p2)
    z_hit = GRAZING_ZONE * u * (r * r + p2) + (0 if robust else 4 * e * (r + e))

    def wc(t):
        if robust:
            return ROBUST_T * u * (abs(t) + r / nd)
        return WELL_CONDITIONED * u * (abs(t) + (f_len + r) / nd)

    def surface_distance(t):
        return abs(norm(sub([o_m[i] + t * d_m[i] for i in range(3)], c_m)) - r)

    roots: list[Root] = []
    if h2 > 0:
        h = MP.sqrt(h2)
        for t in (t_ca - h / nd, t_ca + h / nd):
            if h2 >= r * r / 4:
                tol, pos = wc(t), None
            else:  # h moves by at most min(√δ, δ/2h) when h² is off by δ <= z_hit
                tol = wc(t) + min(MP.sqrt(2 * z_hit), z_hit / h) / nd
                pos = g_pos
            required = h2 > z_miss and representable(t, precision)
            roots.append(Root(t, float(tol), required, None if pos is None else float(pos)))
    elif h2 >= -z_hit:  # a graze by less than rounding: one optional pseudo-root at the closest approach
        tol = wc(t_ca) + MP.sqrt(2 * z_hit) / nd
        roots.append(Root(t_ca, float(tol), False, float(g_pos), real=False))

    def normal_check(t: float, normal: np.ndarray, root: Root) -> str | None:
        bound = 2 * (root.tol * nd + NORMAL * u * (norm(o_m) + abs(MP.mpf(t)) * nd + norm(c_m))) / r + 8 * u
        length = float(np.linalg.norm(normal.astype(np.float64)))
        if abs(length - 1) > 8 * u:
            return f"normal {normal} is not unit length (|n| - 1 = {length - 1:.3g})"
        if bound >= 0.5:
            return None
        point = [o_m[i] + root.t * d_m[i] for i in range(3)]
        expected = [x / norm(sub(point, c_m)) for x in sub(point, c_m)]
        error = float(norm(sub(mp_vector(normal), expected)))
        return None if error <= bound else f"normal {normal} off by {error:.3g} > {float(bound):.3g}"

    info = {"finite": True, "h2": h2, "z_miss": z_miss, "z_hit": z_hit, "r2": r * r, "p2": p2, "f_exact": e == 0}
    return Exact(roots, surface_distance, normal_check, info)


def exact_plane(o, d, plane: Plane, precision: str) -> Exact:
    """t = n·(q - o)/(n·d) for the stored (rounded) unit normal n and point q."""
    u = unit_roundoff(precision)
    n_r, q_r = stored_plane(plane, precision)
    o_r, d_r = rounded(o, precision), rounded(d, precision)
    if not (np.isfinite(o_r).all() and np.isfinite(d_r).all() and np.isfinite(q_r).all()):
        return Exact([], lambda t: MP.inf, lambda *a: None, {"finite": False})
    n_m, q_m, o_m, d_m = mp_vector(n_r), mp_vector(q_r), mp_vector(o_r), mp_vector(d_r)
    denominator = dot(n_m, d_m)
    numerator = dot(n_m, sub(q_m, o_m))

    def surface_distance(t):
        return abs(dot(n_m, sub([o_m[i] + t * d_m[i] for i in range(3)], q_m))) / norm(n_m)

    def normal_check(t: float, normal: np.ndarray, root: Root) -> str | None:
        if np.abs(normal.astype(np.float64) - n_r.astype(np.float64)).max() > 4 * u:
            return f"normal {normal} is not the stored unit normal {n_r}"
        return None

    roots = []
    if denominator != 0:  # a ray parallel to or in the plane has no single intersection: a miss
        t = numerator / denominator
        s_n = sum(abs(n_m[i] * (q_m[i] - o_m[i])) for i in range(3))
        s_d = sum(abs(n_m[i] * d_m[i]) for i in range(3))
        tol = PLANE * u * (s_n + abs(t) * s_d) / abs(denominator) + PLANE_DIVISION * u * abs(t)
        # A ray parallel to the plane within the rounding of n·d (a few u of Σ|n_i d_i|) may be computed
        # parallel, or in it: a miss is then allowed, a hit judged as any other.
        parallel = abs(denominator) <= PLANE * u * s_d
        # An unbounded plane ends at the coordinate limit (docs/numerics.md, "Planes end at the limit"):
        # a hit is owed only where its point lies within it by more than the point's rounding and t's tolerance.
        reach = max(abs(o_m[i] + t * d_m[i]) for i in range(3)) + tol * max(abs(x) for x in d_m)
        within = reach * (1 + 8 * u) < durer._core.LIMITS[precision]["coordinate"]
        roots.append(Root(t, float(tol), representable(t, precision) and within and not parallel, None))
    return Exact(roots, surface_distance, normal_check, {"finite": True, "denominator": denominator})


def exact_answers(primitives: tuple, o, d, precision: str, *, robust: bool = True) -> list[Exact]:
    return [exact_sphere(o, d, p, precision, robust=robust) if isinstance(p, Sphere)
            else exact_plane(o, d, p, precision) for p in primitives]


def judge(exacts: list[Exact], t: float, index: int, normal: np.ndarray, t_min: float, t_max: float,
          precision: str) -> list[str]:
    """Problems with a reported result (t, primitive `index` or -1) against the exact answers."""
    problems = []

    def clearly_inside(root: Root) -> bool:
        return root.t - root.tol >= t_min and root.t + root.tol < t_max

    required = [(k, r) for k, e in enumerate(exacts) for r in e.roots if r.required and clearly_inside(r)]
    if index < 0:
        if t != INF:
            problems.append(f"a miss must report t = inf, got {t}")
        for k, r in required:
            problems.append(f"false miss: primitive {k} has an exact root t* = {MP.nstr(r.t, 17)} "
                            f"(tolerance {r.tol:.3g})")
        return problems
    if not math.isfinite(t):
        return [f"a hit with non-finite t = {t}"]
    if not t_min <= t < t_max:
        problems.append(f"hit t = {t!r} outside [t_min, t_max) = [{t_min}, {t_max})")
    exact = exacts[index]
    t_m = MP.mpf(t)
    matches = [r for r in exact.roots
               if abs(t_m - r.t) <= r.tol and r.t + r.tol >= t_min and r.t - r.tol < t_max]
    if not matches:
        if exact.roots:
            near = min(exact.roots, key=lambda r: abs(t_m - r.t))
            problems.append(f"hit t = {t!r} is no root: nearest exact root {MP.nstr(near.t, 17)}, error "
                            f"{MP.nstr(abs(t_m - near.t), 3)} = {float(abs(t_m - near.t) / near.tol):.3g} x tolerance")
        else:
            problems.append(f"false hit t = {t!r}: primitive {index} has no exact root "
                            f"(distance from its surface {MP.nstr(exact.surface_distance(t_m), 3)})")
        return problems
    root = min(matches, key=lambda r: abs(t_m - r.t))
    if root.position_tol is not None:
        distance = exact.surface_distance(t_m)
        if distance > root.position_tol:
            problems.append(f"grazing hit t = {t!r} lies {MP.nstr(distance, 3)} from the surface "
                            f"> {root.position_tol:.3g}")
    tol = max(r.tol for r in matches)
    for k, r in required:
        if r.t + r.tol < t_m - tol:
            problems.append(f"not the closest: primitive {k} has a root at {MP.nstr(r.t, 17)} before t = {t!r}")
    message = exact.normal_check(t, normal, root)
    if message:
        problems.append(message)
    return problems
