"""Property tests of the ray/primitive tests over wide magnitude ranges (hypothesis, derandomised).

Random spheres, planes and rays -- centres up to 1e6 from 0, radii 1e-3 ... 1e4, direction lengths
1e-6 ... 1e6, in both precisions -- checked against exact answers computed with mpmath from the
inputs as rounded to the precision under test (`test_numerics.exact_answers`). Rays are aimed at the
primitives (through a random point of a sphere's disc, a little beyond its rim, or a plane's random
point) so that hits, near misses and grazing rays are all frequent.

1. A reported hit point P = o + t·d (exact, from the reported t) lies on the surface it names within
   a bound proportional to ulp × magnitude: a sphere within 64u(|o - c| + r) of its radius (for a
   well-conditioned hit this follows from |δt| <= 32u(|t*| + (|f| + r)/|d|) since |t*||d| <= |f| + r;
   for a grazing one it is the grazing bound itself); a plane within
   8u(S_N + |t|·S_D) + 2u|t||n·d| of it (the plane bound on t times |n·d|) -- see test_numerics.
2. The reported hit is the closest: against the exact roots of every primitive of a random scene
   (2-5 spheres strung along the ray, or 16-24 so that a sphere hierarchy is used, maybe a plane),
   no root lies clearly (by more than the tolerances) before the reported one, the reported one is
   within its tolerance, and a miss happens only where every exact root is optional (grazing within
   rounding, or beyond the range).
3. The robust method is never less accurate than the textbook ones beyond its bound: where
   `algebraic` or `geometric` is right per mpmath, `robust` is right too and its error exceeds theirs by
   at most its own tolerance; it misses only where the documented grazing rule allows it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import durer
from durer.render import PRECISIONS
from helpers.exact import (
    GRAZING_POSITION,
    MP,
    PLANE,
    PLANE_DIVISION,
    Plane,
    Sphere,
    build_scene,
    dot,
    exact_answers,
    judge,
    mp_vector,
    norm,
    rounded,
    stored_plane,
    sub,
    unit_roundoff,
)

PROPERTY_SETTINGS = settings(
    derandomize=True, deadline=None, database=None, max_examples=60, suppress_health_check=[HealthCheck.too_slow]
)


# --- strategies ----------------------------------------------------------------------------------
def magnitudes(lo_exponent: float, hi_exponent: float) -> st.SearchStrategy[float]:
    """10^x with x uniform in [lo, hi]: every order of magnitude equally often."""
    return st.floats(lo_exponent, hi_exponent).map(lambda x: 10.0**x)


@st.composite
def unit_vectors(draw) -> tuple[float, float, float]:
    """Uniform on the sphere (z uniform, azimuth uniform): no rejection, no filtering."""
    z = draw(st.floats(-1.0, 1.0))
    phi = draw(st.floats(0.0, 2 * math.pi))
    s = math.sqrt(max(0.0, 1 - z * z))
    return (s * math.cos(phi), s * math.sin(phi), z)


def scaled(v, k: float) -> tuple[float, float, float]:
    return (v[0] * k, v[1] * k, v[2] * k)


def plus(a, b) -> tuple[float, float, float]:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def minus(a, b) -> tuple[float, float, float]:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def length(v) -> float:
    return math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)


@st.composite
def spheres(draw) -> Sphere:
    center = scaled(draw(unit_vectors()), draw(magnitudes(-2, 6)))
    return Sphere(center, draw(magnitudes(-3, 4)))


@st.composite
def planes(draw) -> Plane:
    normal = scaled(draw(unit_vectors()), draw(magnitudes(-3, 3)))  # need not be unit
    offset = draw(st.sampled_from([-1.0, 1.0])) * draw(magnitudes(-2, 6)) * length(normal)
    return Plane(normal, offset)


@st.composite
def rays_at(draw, target) -> tuple[tuple, tuple]:
    """A ray from a random origin (up to 1e6 from 0, or near the target) through `target`, with a
    random direction length in 1e-6 ... 1e6."""
    origin = draw(st.one_of(
        unit_vectors().flatmap(lambda u: magnitudes(-2, 6).map(lambda m: scaled(u, m))),
        unit_vectors().flatmap(lambda u: magnitudes(-2, 4).map(lambda m: plus(target, scaled(u, m)))),
    ))
    aim = minus(target, origin)
    if length(aim) == 0:
        aim = (1.0, 0.0, 0.0)
    direction = scaled(aim, draw(magnitudes(-6, 6)) / length(aim))
    return origin, direction


@st.composite
def point_of_disc(draw, sphere: Sphere) -> tuple[float, float, float]:
    """The centre plus an offset of up to 1.2 r (inside the disc, on the rim, a little beyond)."""
    spread = draw(st.one_of(st.floats(0.0, 1.2), st.floats(0.97, 1.03), st.floats(0.9999, 1.0001)))
    return plus(sphere.center, scaled(draw(unit_vectors()), spread * sphere.radius))


@st.composite
def single_primitive_cases(draw, kind: str):
    if kind == "sphere":
        primitive = draw(spheres())
        target = draw(point_of_disc(primitive))
    else:
        primitive = draw(planes())
        n, q = stored_plane(primitive, "double")
        offset = scaled(draw(unit_vectors()), draw(magnitudes(-2, 5)))
        along = sum(float(a) * b for a, b in zip(n, offset, strict=True))
        target = plus(tuple(float(x) for x in q), minus(offset, scaled(tuple(float(a) for a in n), along)))
    origin, direction = draw(rays_at(target))
    return primitive, origin, direction


# --- helpers -------------------------------------------------------------------------------------
def cast(primitives, origin, direction, precision, method="robust", t_min=0.0):
    scene, ids = build_scene(primitives)
    result = durer.cast(scene, np.array([origin]), np.array([direction]), precision=precision,
                        sphere_method=method, t_min=t_min)
    object_id = int(result.object_id[0])
    return float(result.t[0]), (-1 if object_id == -1 else ids.index(object_id)), result.normal[0]


def surface_error_and_bound(primitive, origin, direction, t: float, precision: str):
    """Distance of the exact point o + t·d from the surface, and the property-1 bound for it."""
    u = unit_roundoff(precision)
    o_m, d_m = mp_vector(rounded(origin, precision)), mp_vector(rounded(direction, precision))
    t_m = MP.mpf(t)
    p_m = [o_m[i] + t_m * d_m[i] for i in range(3)]
    if isinstance(primitive, Sphere):
        c_m = mp_vector(rounded(primitive.center, precision))
        r = MP.mpf(float(rounded(primitive.radius, precision)))
        return abs(norm(sub(p_m, c_m)) - r), GRAZING_POSITION * u * (norm(sub(o_m, c_m)) + r)
    n_r, q_r = stored_plane(primitive, precision)
    n_m, q_m = mp_vector(n_r), mp_vector(q_r)
    s_n = sum(abs(n_m[i] * (q_m[i] - o_m[i])) for i in range(3))
    s_d = sum(abs(n_m[i] * d_m[i]) for i in range(3))
    bound = PLANE * u * (s_n + abs(t_m) * s_d) + PLANE_DIVISION * u * abs(t_m) * abs(dot(n_m, d_m))
    return abs(dot(n_m, sub(p_m, q_m))) / norm(n_m), bound


# --- 1. hit points lie on the surface ------------------------------------------------------------
@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize("kind", ["sphere", "plane"])
@PROPERTY_SETTINGS
@given(data=st.data())
def test_hit_point_lies_on_the_surface(kind: str, precision: str, data) -> None:
    """A reported hit point is on the surface within 64u(|o - c| + r) (sphere) or the plane bound."""
    primitive, origin, direction = data.draw(single_primitive_cases(kind))
    t, index, normal = cast((primitive,), origin, direction, precision)
    if index < 0:  # no point to check: the miss must be right, as in property 2 (a graze within rounding, or behind)
        problems = judge(exact_answers((primitive,), origin, direction, precision), t, index, normal, 0.0, math.inf,
                         precision)
        assert not problems, "\n".join(problems)
        return
    assert math.isfinite(t) and t >= 0
    error, bound = surface_error_and_bound(primitive, origin, direction, t, precision)
    assert error <= bound, f"hit point {MP.nstr(error, 3)} from the surface > bound {MP.nstr(bound, 3)}"


# --- 2. the reported hit is the closest ----------------------------------------------------------
@st.composite
def small_scenes(draw, sphere_counts: st.SearchStrategy[int]):
    """Spheres strung along a ray (so that they occlude each other) and maybe a plane across it."""
    origin = scaled(draw(unit_vectors()), draw(magnitudes(-2, 6)))
    heading = draw(unit_vectors())
    scale = draw(magnitudes(-2, 4))  # the scene's size
    primitives = []
    for _ in range(draw(sphere_counts)):
        along = draw(st.floats(-0.5, 10.0)) * scale
        radius = scale * draw(magnitudes(-3, 0))
        offset = scaled(draw(unit_vectors()), radius * draw(st.floats(0.0, 1.3)))
        primitives.append(Sphere(plus(plus(origin, scaled(heading, along)), offset), radius))
    if draw(st.booleans()):
        normal = draw(unit_vectors())
        point = plus(origin, scaled(heading, draw(st.floats(-1.0, 12.0)) * scale))
        primitives.append(Plane(normal, sum(n * p for n, p in zip(normal, point, strict=True))))
    direction = scaled(heading, draw(magnitudes(-6, 6)))
    t_min = draw(st.sampled_from([0.0, 0.0, -math.inf]))
    return tuple(primitives), origin, direction, t_min


def check_closest(precision: str, case) -> None:
    primitives, origin, direction, t_min = case
    t, index, normal = cast(primitives, origin, direction, precision, t_min=t_min)
    exacts = exact_answers(primitives, origin, direction, precision)
    t_min_r = float(rounded(t_min, precision))
    problems = judge(exacts, t, index, normal, t_min_r, math.inf, precision)
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("precision", PRECISIONS)
@PROPERTY_SETTINGS
@given(case=small_scenes(st.integers(2, 5)))
def test_reported_hit_is_the_closest(precision: str, case) -> None:
    """The robust cast of a small scene agrees with the exact closest root over all its primitives."""
    check_closest(precision, case)


@pytest.mark.parametrize("precision", PRECISIONS)
@settings(PROPERTY_SETTINGS, max_examples=20)
@given(case=small_scenes(st.integers(16, 24)))
def test_reported_hit_is_the_closest_among_many(precision: str, case) -> None:
    """As above with 16-24 spheres: enough for the core to put them in a hierarchy (a bounding box
    rounded the wrong way, or a traversal that stops early, would hide the closest sphere)."""
    check_closest(precision, case)


# --- 3. robust is never less accurate than the textbook methods -----------------------------------
@st.composite
def hard_sphere_cases(draw):
    """One sphere, far (distance/radius 1 ... 1e8) or huge, aimed at any point of its disc or rim."""
    radius = draw(magnitudes(-3, 4))
    distance = radius * draw(magnitudes(0, 8))
    origin = scaled(draw(unit_vectors()), draw(magnitudes(-2, 6)))
    center = plus(origin, scaled(draw(unit_vectors()), distance))
    sphere = Sphere(center, radius)
    target = draw(point_of_disc(sphere))
    aim = minus(target, origin)
    if length(aim) == 0:
        aim = minus(center, origin)
    direction = scaled(aim, draw(magnitudes(-6, 6)) / length(aim))
    return sphere, origin, direction


@pytest.mark.parametrize("precision", PRECISIONS)
@PROPERTY_SETTINGS
@given(case=hard_sphere_cases())
def test_robust_is_never_less_accurate(precision: str, case) -> None:
    """Where a textbook method is right per mpmath, robust is right too, its error at most the
    textbook error plus its own tolerance, and a robust miss only where the grazing rule allows."""
    sphere, origin, direction = case
    exacts = exact_answers((sphere,), origin, direction, precision)
    roots = exacts[0].roots
    robust_t, robust_index, robust_normal = cast((sphere,), origin, direction, precision)
    robust_problems = judge(exacts, robust_t, robust_index, robust_normal, 0.0, math.inf, precision)
    for method in ("algebraic", "geometric"):
        t, index, normal = cast((sphere,), origin, direction, precision, method)
        if judge(exacts, t, index, normal, 0.0, math.inf, precision):
            continue  # the textbook method is wrong here: nothing to compare
        assert not robust_problems, f"{method} is right, robust is not: " + "; ".join(robust_problems)
        if index < 0 or robust_index < 0:
            continue  # both right: a miss is right for both, or robust's miss is an allowed graze
        t_m, r_m = MP.mpf(t), MP.mpf(robust_t)
        root = min(roots, key=lambda r: abs(t_m - r.t))
        if root is not min(roots, key=lambda r: abs(r_m - r.t)):
            continue  # both right, at different roots: the origin is on the sphere within rounding
        assert abs(r_m - root.t) <= abs(t_m - root.t) + root.tol, (
            f"robust error {MP.nstr(abs(r_m - root.t), 3)} > {method} error {MP.nstr(abs(t_m - root.t), 3)} "
            f"+ tolerance {root.tol:.3g}"
        )
