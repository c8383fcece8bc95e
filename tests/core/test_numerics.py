"""Hard cases of the ray/sphere and ray/plane tests, each checked against its exact answer.

Every case states a ray (origin, direction, t range) and one primitive. It runs in both precisions.
Its expected answer is computed with mpmath (60 digits) from the inputs *as rounded to the precision
under test* -- exactly the numbers the core works with -- so the only error measured is the core's own
arithmetic. The spec the answers are judged by (`judge`) is the documented contract of
`sphere_method="robust"` (the default) and of the plane test:

* A reported hit is finite, lies in [t_min, t_max), is within the tolerance below of an exact root of
  the primitive it names, and no exact root of any primitive lies clearly before it (the closest).
* A miss is right unless an exact root lies clearly inside [t_min, t_max) ("clearly": by more than
  the tolerance) and is not in the grazing zone. A root too large for the precision is no answer: the
  ray must miss (t is never inf on a hit).
* Grazing (documented): the robust method reports a hit only where r² - p² (p: distance from the centre
  to the ray's line) exceeds its rounding-error bound, so rays within a few ulps of the tangent miss;
  an exact tangent (a double root) is a miss. In that zone (below) a miss is always right and a hit
  must land on the sphere within the position tolerance. Outside it the robust method must decide
  like the exact answer.
* Any input NaN or infinite gives a miss (cast with check=False). Finite inputs beyond the precision's
  limits (docs/numerics.md, "Accepted ranges") are refused with a ValueError naming the field; within
  them no intermediate result overflows.

Tolerances, with u = ε/2 the unit roundoff (float: 2^-24 ≈ 5.96e-8, double: 2^-53 ≈ 1.11e-16),
f = o - c, h² = r² - p² and everything exact from the rounded inputs:

* Sphere, well conditioned (h² >= r²/4), robust: |t - t*| <= 16u(|t*| + r/|d|)  [ROBUST_T]. The robust
  method carries f = o - c exactly (TwoSum), scales d exactly, forms p² from nearly exact cross
  products and c = |f|² - r² by a compensated sum: the root is off by a few roundings of t itself and
  of the sphere's size, never of |f| (the errors observed stay far below this). The textbook methods,
  asserted on ordinary cases only, get 32u(|t*| + (|f| + r)/|d|) [WELL_CONDITIONED], which the textbook
  b² - 4ac still exceeds by factors up to 10⁶ on the far spheres.
* Sphere, grazing (h² < r²/4): the hit point P = o + t·d (exact, from the reported t) lies within
  G = 64u(|f| + r) of the sphere [GRAZING_POSITION], and |t - t*| <= tol + min(√(2δ), δ/h)/|d| with
  δ = 32u(r² + p²) the error bound of the robust method's h²: h moves by at most min(√δ, δ/2h).
* Grazing zone: the robust method reports a hit only where r² - p² > 8ε(r² + p²). A miss is allowed
  where h² <= 32u(r² + p²) (four times its margin) [GRAZING_ZONE], and a hit on an exact miss only
  where p² - r² <= 32u(r² + p²), passing the position test. Nothing depends on |f|: a sphere 10⁹
  radii away is resolved in float too. (The textbook methods round f: for them the zone widens by
  their rounding of f, [FAR_BAND].)
* Plane (t = n·(q - o)/(n·d), q the stored point): |t - t*| <= 8u(S_N + |t*|·S_D)/|n·d| + 2u|t*|
  with S_N = Σ|n_i (q_i - o_i)| and S_D = Σ|n_i d_i| [PLANE]: first-order error of a 4-rounding
  numerator (γ4·S_N), a 3-rounding denominator (relative γ3·S_D/|n·d|) and the division, doubled.
  Measured from a point of the plane this is a few ulps of |q - o|; the naive (offset - n·o)/(n·d)
  errs by u(|offset| + Σ|n_i o_i|)/|n·d|: 4·10³ to 3·10⁵ times this tolerance in the far oblique
  plane cases below (test_plane_tolerance_rejects_the_naive_formula).
* Normals: a sphere's normal is within 2(δt·|d| + 4u(|o| + |t||d| + |c|))/r + 8u of (P* - c)/r
  (asserted only where that is < 0.5); a plane's normal is the stored unit normal.

The textbook methods (`algebraic`, `geometric`) are expected to break down on these cases: their
error is recorded (`record_property`: in junit XML, nothing printed) and asserted only on the cases
marked ordinary, where all three methods must agree with the exact answer.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

import durer
from durer.render import PRECISIONS
from helpers.exact import (
    DTYPE,
    INF,
    MP,
    NAN,
    Exact,
    Plane,
    Sphere,
    build_scene,
    exact_answers,
    judge,
    representable,
    rounded,
    stored_plane,
    unit_roundoff,
)


def cast_case(case: Case, precision: str, method: str) -> tuple[durer.CastResult, list[int]] | None:
    """The case cast with `method`; None where it is refused as expected (beyond the limits)."""
    if per_precision(case.expect, precision) == "refused":
        with pytest.raises(ValueError, match=case.refused):
            scene, _ = build_scene(case.primitives_for(precision))
            durer.cast(scene, np.array([case.origin_for(precision)], float),
                       np.array([case.direction_for(precision)], float), precision=precision, sphere_method=method,
                       check=False)
        return None
    scene, ids = build_scene(case.primitives_for(precision))
    result = durer.cast(scene, np.array([case.origin_for(precision)], float),
                        np.array([case.direction_for(precision)], float),
                        t_min=per_precision(case.t_min, precision), t_max=per_precision(case.t_max, precision),
                        precision=precision, sphere_method=method, check=False)
    return result, ids


def result_index(result: durer.CastResult, ids: list[int]) -> int:
    object_id = int(result.object_id[0])
    return -1 if object_id == -1 else ids.index(object_id)


def relative_error(case: Case, precision: str, result: durer.CastResult, exacts: list[Exact], ids) -> str:
    """A short verdict for the record: 'miss ok', 'false miss', 'false hit', or the error in units of u|t*|."""
    t, index = float(result.t[0]), result_index(result, ids)
    problems = judge(exacts, t, index, result.normal[0], case.t_min_for(precision), case.t_max_for(precision),
                     precision)
    if index < 0:
        return "false miss" if problems else "miss ok"
    roots = exacts[index].roots
    if not roots:
        return "false hit"
    near = min(roots, key=lambda r: abs(MP.mpf(t) - r.t))
    error = abs(MP.mpf(t) - near.t) / (abs(near.t) if near.t else 1)
    return f"{float(error) / unit_roundoff(precision):.3g} u{' (out of bound)' if problems else ''}"


# --- the cases -----------------------------------------------------------------------------------
def per_precision(value: Any, precision: str) -> Any:
    """A case field: the same for both precisions, {"float": ..., "double": ...} or f(precision)."""
    if callable(value):
        return value(precision)
    if isinstance(value, dict):
        return value[precision]
    return value


@dataclass(frozen=True)
class Case:
    """One hard case. `expect` (per precision) checks that the case is what its doc says and adds
    the documented behaviour on top of `judge`:

    hit      the exact answer has a root clearly inside [t_min, t_max), outside the grazing zone
    miss     the exact answer has none (or none representable); the robust method must miss
    tangent  the exact answer is a double root (r² = p² exactly); the robust method must miss
    graze    the exact answer is a hit inside the grazing zone, or outside it: `judge` decides
    any      whatever the rounded inputs give (where rounding to float moves the ray by ~the radius)
    refused  beyond the precision's limits (docs/numerics.md, durer._core.LIMITS): a ValueError whose
             message matches `refused` (the field), from the add or the cast
    """

    id: str
    doc: str
    primitives: tuple
    origin: Any
    direction: Any
    expect: Any = "hit"
    t_min: Any = 0.0
    t_max: Any = INF
    ordinary: bool = False  # all three sphere methods must get it right
    refused: str = ""       # with expect "refused": the field the ValueError names (a regex)

    def origin_for(self, precision: str):
        return tuple(float(x) for x in per_precision(self.origin, precision))

    def direction_for(self, precision: str):
        return tuple(float(x) for x in per_precision(self.direction, precision))

    def primitives_for(self, precision: str) -> tuple:
        return per_precision(self.primitives, precision)

    def t_min_for(self, precision: str) -> float:
        return float(rounded(per_precision(self.t_min, precision), precision))

    def t_max_for(self, precision: str) -> float:
        return float(rounded(per_precision(self.t_max, precision), precision))


def nudge(value: float, toward: float) -> Callable[[str], float]:
    """`value` moved by one ulp toward `toward`, in the precision under test."""
    return lambda precision: float(np.nextafter(DTYPE[precision](value), DTYPE[precision](toward)))


def add(a, b, k=1.0):
    return tuple(float(x) + k * float(y) for x, y in zip(a, b, strict=True))


# Oblique unit axes with exact lengths: (2, -3, 6)/7 and two perpendicular ones.
AXIS = (2 / 7, -3 / 7, 6 / 7)
PERP = (3 / 7, 6 / 7, 2 / 7)        # AXIS·PERP = 0
PERP2 = (6 / 7, -2 / 7, -3 / 7)     # AXIS × PERP (up to sign)


def far_sphere_case(ratio: float, aim: float, expect_float: str) -> Case:
    """Camera at the origin, unit sphere at distance `ratio` along AXIS; the ray aims at the point
    aim·r off the centre across the disc (f = -c is exact: the robust method's own error only)."""
    center = tuple(ratio * a for a in AXIS)
    direction = add(center, PERP, aim)
    where = "near the centre of the disc" if aim < 0.5 else "near the edge of the disc"
    return Case(
        f"far-sphere-1e{round(math.log10(ratio))}-{'centre' if aim < 0.5 else 'edge'}",
        f"Origin (0, 0, 0); direction c + {aim}·(3, 6, 2)/7 (oblique, |d| ~ {ratio:g}); sphere r = 1 at "
        f"c = {ratio:g}·(2, -3, 6)/7 (distance/radius {ratio:g}). The ray passes {aim} r from the centre "
        f"({where}): the near root t* ~ 1 - {math.sqrt(1 - aim * aim):.3g}/{ratio:g}. Expected: a hit within "
        f"the well-conditioned bound. In float the rounded direction is off by ~u·{ratio:g} radii, and "
        f"beyond 1/ε = 2^23 radii the robust method documents a miss: expect={expect_float!r}.",
        (Sphere(center, 1.0),), (0.0, 0.0, 0.0), direction,
        expect={"double": "hit", "float": expect_float}, ordinary=ratio <= 10,
    )


def far_origin_case(ratio: float, expect_float: str) -> Case:
    """A sphere near 0 seen from far away along an oblique direction: f = o - c is rounded."""
    center = (0.25, -0.5, 0.125)
    origin = add(center, AXIS, ratio * 3.0)
    direction = add(tuple(-a for a in AXIS), PERP2, 0.5 / ratio)  # passes 0.5 r from the centre
    return Case(
        f"far-origin-1e{round(math.log10(ratio))}",
        f"Origin c + {3 * ratio:g}·(2, -3, 6)/7, direction -(2, -3, 6)/7 tilted by 0.5/{ratio:g} along "
        f"(6, -2, -3)/7; sphere r = 3 at c = (0.25, -0.5, 0.125): distance/radius {ratio:g}, the ray passes "
        f"~0.5 r from the centre. o - c is rounded (error u·|f|). Expected: a hit near t* ~ {3 * ratio - 2.6:g} "
        f"in double; in float expect={expect_float!r} (u|f| ~ {5.96e-8 * ratio:.2g} r).",
        (Sphere(center, 3.0),), origin, direction, expect={"double": "hit", "float": expect_float},
    )


def ground_case(radius: float, direction, what: str, height: float = 1.0, expect="hit") -> Case:
    return Case(
        f"ground-1e{round(math.log10(radius))}-{what}",
        f"Origin (0.5, -0.25, {height:g}), {height:g} above the top of a huge ground sphere r = {radius:g} at "
        f"c = (0, 0, -{radius:g}); direction {direction} ({what}). Expected: a hit just below the origin "
        f"(t* from mpmath) within the well-conditioned/grazing bound, which scales with u(|f| + r): in float "
        f"for r >= 1e6 the rounding of f = o - c is as large as the height (the bound says so, honestly).",
        (Sphere((0.0, 0.0, -radius), radius),), (0.5, -0.25, height), direction, expect=expect,
        ordinary=radius <= 1e3 and what == "down",
    )


UNIT = Sphere((0.0, 0.0, 0.0), 1.0)
# Pythagorean tangents: centre c, radius 5, tangent point c + (3, 4, 0), direction (-4, 3, 12) ⟂ (3, 4, 0).
# Moving the origin along +x moves the line away from the centre (|f⊥|² grows by 6δx).
TANGENT_CENTER = (1000.0, -2000.0, 3000.0)
TANGENT_ORIGIN = (1163.0, -2116.0, 2520.0)  # c + (3, 4, 0) + 40·(4, -3, -12): t = 40 at the tangent point
BIG_TANGENT_CENTER = (2.0**20, -(2.0**21), 3 * 2.0**19)
BIG_TANGENT_ORIGIN = (1052675.0, -2100220.0, 1560576.0)  # c + (3, 4, 0) + 1024·(4, -3, -12)
ON_SPHERE = Sphere((10.0, 20.0, 30.0), 13.0)  # (13, 24, 42) = c + (3, 4, 12) is exactly on it
# The sphere below reaches 2.1·s: just inside each precision's coordinate limit.
NEAR_OVERFLOW = {p: durer._core.LIMITS[p]["coordinate"] / 2.2 for p in ("double", "float")}


def nudged_x(origin, toward: float) -> Callable[[str], tuple]:
    """`origin` with its x moved by one ulp toward `toward`, in the precision under test."""
    def make(precision: str) -> tuple:
        return (nudge(origin[0], toward)(precision), origin[1], origin[2])
    return make


def tangent_cases(name: str, sphere: Sphere, origin, direction, t: float) -> list[Case]:
    """The exact tangent and the origin moved 1 ulp (of x, in the precision under test) either side."""
    inside, outside = nudged_x(origin, -INF), nudged_x(origin, INF)
    where = f"sphere r = {sphere.radius:g} at c = {sphere.center}; direction {direction}"
    return [
        Case(f"{name}-exact", f"Origin {origin}, {where}: the line touches the sphere at t = {t:g} exactly "
             f"(a double root, r² = p² in exact arithmetic). Expected (documented): a miss for the robust "
             f"method, whose hits need r² - p² > 8ε(r² + p²).",
             (sphere,), origin, direction, expect="tangent"),
        Case(f"{name}-1ulp-inside", f"As {name}-exact with origin x moved 1 ulp (of the precision) toward "
             f"the centre: r² - p² ~ 2·(x - c_x)·ulp(x) > 0, a true hit. Decision: where that is inside the "
             f"grazing zone (within the robust method's rounding bound, e.g. the unit sphere) a miss is the "
             f"documented answer and a hit is accepted only on the grazing bound; where it is outside (a "
             f"coarse ulp: x ~ 1e6, in both precisions) the robust method must report the hit.",
             (sphere,), inside, direction, expect="graze"),
        Case(f"{name}-1ulp-outside", f"As {name}-exact with origin x moved 1 ulp away: the line misses the "
             f"sphere by ~ulp(x). o - c is exact. Expected: a miss (a hit would be false).",
             (sphere,), outside, direction, expect="miss"),
    ]


def _cases() -> list[Case]:
    cases: list[Case] = []
    # Far spheres: distance/radius 10 ... 10^8, camera at the origin.
    for k in range(1, 9):
        ratio = 10.0**k
        cases.append(far_sphere_case(ratio, 0.1, "hit" if k <= 6 else "any"))
        cases.append(far_sphere_case(ratio, 0.8, "hit" if k <= 5 else "any"))
    cases.append(Case(
        "far-sphere-1e8-dead-centre",
        "Origin (0, 0, 0); direction = c exactly; sphere r = 1 at c = 1e8·(2, -3, 6)/7. The exact near root "
        "is 1 - r/|c| (relative 1e-8 from 1): the textbook b² - 4ac loses all of its digits in double. "
        "Expected: a hit, t within 32u of 1 - r/|c|, in both precisions.",
        (Sphere(tuple(1e8 * a for a in AXIS), 1.0),), (0.0, 0.0, 0.0), tuple(1e8 * a for a in AXIS),
        expect={"double": "hit", "float": "any"}))
    cases.append(Case(
        "far-sphere-1e4-grazing-edge",
        "Origin (0, 0, 0); direction c + 0.99·(3, 6, 2)/7; sphere r = 1 at c = 1e4·(2, -3, 6)/7: the ray "
        "passes 0.99 r from the centre (h² = 0.0199 r², grazing class). Expected: a hit within the grazing "
        "bound, the hit point on the sphere within 64u(|f| + r).",
        (Sphere(tuple(1e4 * a for a in AXIS), 1.0),), (0.0, 0.0, 0.0), add(tuple(1e4 * a for a in AXIS), PERP, 0.99)))
    cases.append(far_origin_case(1e2, "hit"))
    cases.append(far_origin_case(1e4, "hit"))
    cases.append(far_origin_case(1e7, "any"))
    # Huge spheres as ground.
    for radius in (1e3, 1e6, 1e9):
        cases.append(ground_case(radius, (0.0, 0.0, -1.0), "down"))
        cases.append(ground_case(radius, (0.6, -0.3, -0.5), "oblique"))
    cases.append(ground_case(1e6, (1.0, 0.25, -1e-2), "near-horizontal"))
    cases.append(ground_case(1e9, (1.0, 0.25, -1e-3), "near-horizontal", expect={"double": "hit", "float": "any"}))
    cases.append(ground_case(1e6, (0.3, 0.1, -1.0), "oblique-low", height=1e-3))
    # Tangents and one ulp either side.
    cases += tangent_cases("tangent-unit-axis", UNIT, (1.0, 0.0, 5.0), (0.0, 0.0, -1.0), 5.0)
    cases += tangent_cases("tangent-oblique", Sphere(TANGENT_CENTER, 5.0), TANGENT_ORIGIN, (-4.0, 3.0, 12.0), 40.0)
    cases += tangent_cases("tangent-oblique-1e6", Sphere(BIG_TANGENT_CENTER, 5.0), BIG_TANGENT_ORIGIN,
                           (-4.0, 3.0, 12.0), 1024.0)
    # Origin exactly on the sphere.
    cases += [
        Case("on-sphere-axis-in", "Origin (0, 0, 1) on the unit sphere, direction (0, 0, -1) (inward). Roots 0 "
             "and 2. Expected (documented): t = 0 within the bound (the origin is a root) or the next root, 2.",
             (UNIT,), (0.0, 0.0, 1.0), (0.0, 0.0, -1.0), expect="any", ordinary=True),
        Case("on-sphere-axis-out", "Origin (0, 0, 1) on the unit sphere, direction (0, 0, 1) (outward). Roots -2 "
             "and 0. Expected: t = 0 within the bound (the origin is a root) or a miss; never a positive t.",
             (UNIT,), (0.0, 0.0, 1.0), (0.0, 0.0, 1.0), expect="any", ordinary=True),
        Case("on-sphere-oblique-in", "Origin (13, 24, 42) = c + (3, 4, 12), exactly on the sphere r = 13 at "
             "c = (10, 20, 30); direction (-3, -4, -12) + (1, -0.5, 0) (inward). Expected: t ≈ 0 within the "
             "bound, or the far root.",
             (ON_SPHERE,), (13.0, 24.0, 42.0), (-2.0, -4.5, -12.0), expect="any"),
        Case("on-sphere-oblique-out", "Origin (13, 24, 42) on the sphere r = 13 at c = (10, 20, 30); direction "
             "(3, 4, 12) + (0.5, -1, 0) (outward). Expected: t ≈ 0 within the bound or a miss.",
             (ON_SPHERE,), (13.0, 24.0, 42.0), (3.5, 3.0, 12.0), expect="any"),
        Case("on-sphere-oblique-in-offset", "As on-sphere-oblique-in with t_min = 1e-3 (a secondary ray leaving "
             "the surface). Expected: the far root, t* ~ 2·13·|cos|/|d|, within the well-conditioned bound.",
             (ON_SPHERE,), (13.0, 24.0, 42.0), (-2.0, -4.5, -12.0), t_min=1e-3),
        Case("on-sphere-oblique-out-offset", "As on-sphere-oblique-out with t_min = 1e-3. Expected: a miss (the "
             "only roots are 0 and negative).",
             (ON_SPHERE,), (13.0, 24.0, 42.0), (3.5, 3.0, 12.0), t_min=1e-3, expect="miss"),
        Case("on-sphere-inexact", "Origin c + r·(2, -3, 6)/7 rounded (so within an ulp of the sphere r = 0.7 at "
             "c = (0.1, 0.2, 0.3)), direction -(2, -3, 6) + (0.5, 0.5, 0) (inward). Expected: t ≈ 0 within the "
             "bound, or the far root.",
             (Sphere((0.1, 0.2, 0.3), 0.7),), add((0.1, 0.2, 0.3), AXIS, 0.7), (-1.5, 3.5, -6.0), expect="any"),
        Case("on-sphere-far", "Origin c + (0, 0, 2.5) on the sphere r = 2.5 at c = (1e5, 2e5, -3e5) (all exact "
             "in float), direction (0.1, 0.2, -1) (inward). Expected: t ≈ 0 within the bound, or the far root.",
             (Sphere((1e5, 2e5, -3e5), 2.5),), (1e5, 2e5, -3e5 + 2.5), (0.1, 0.2, -1.0), expect="any"),
    ]
    # Origin inside.
    cases += [
        Case("inside-centre", "Origin at the centre (1, 2, 3) of the sphere r = 2, direction (0.3, -0.4, 0.2). "
             "Expected: the far root t* = r/|d|, outward normal.",
             (Sphere((1.0, 2.0, 3.0), 2.0),), (1.0, 2.0, 3.0), (0.3, -0.4, 0.2), ordinary=True),
        Case("inside-near-surface-out", "Origin (0, 0, 1 - 2^-40) (float: 1 - 2^-14) just inside the unit "
             "sphere, direction (0.25, 0, 1) (outward). Expected: a hit, t* ~ 2^-40 (2^-14), within the bound.",
             (UNIT,), {"double": (0.0, 0.0, 1 - 2.0**-40), "float": (0.0, 0.0, 1 - 2.0**-14)}, (0.25, 0.0, 1.0)),
        Case("inside-near-surface-in", "Origin (0, 0, 1 - 2^-40) (float: 1 - 2^-14) just inside the unit "
             "sphere, direction (0.25, 0, -1) (inward). Expected: the far root t* ~ 2/|d|·cos.",
             (UNIT,), {"double": (0.0, 0.0, 1 - 2.0**-40), "float": (0.0, 0.0, 1 - 2.0**-14)}, (0.25, 0.0, -1.0)),
        Case("inside-huge", "Origin (1e3, -2e3, 5e2) inside the sphere r = 1e9 at c = 0, direction "
             "(2, -3, 6)/7. Expected: t* ~ 1e9, within the well-conditioned bound.",
             (Sphere((0.0, 0.0, 0.0), 1e9),), (1e3, -2e3, 5e2), AXIS),
        Case("inside-far", "Origin c + (1, -2, 3) inside the sphere r = 10 at c = (1e6, -1e6, 1e6), direction "
             "(-1, 0.5, 0.25). Expected: the far root (o - c is exact).",
             (Sphere((1e6, -1e6, 1e6), 10.0),), (1e6 + 1, -1e6 - 2, 1e6 + 3), (-1.0, 0.5, 0.25)),
    ]
    # Direction lengths.
    base_o, base_d = (0.2, -0.1, 5.0), (-0.01, 0.02, -1.0)
    for name, scale in [("tiny", {"double": 1e-30, "float": 1e-18}), ("huge", {"double": 1e30, "float": 1e18}),
                        ("tiny-extreme", {"double": 1e-200, "float": 1e-35}),
                        ("huge-extreme", {"double": 1e200, "float": 1e35}),
                        ("unnormalised", {"double": 0.37, "float": 0.37})]:
        cases.append(Case(
            f"direction-{name}", f"Origin {base_o}, direction {base_d}·{scale['double']:g} (float: "
            f"·{scale['float']:g}); unit sphere at 0. t is in units of d: t* ~ 4/|d|. Expected: a hit, t within "
            f"the well-conditioned bound (relative ~32u).",
            (UNIT,), base_o, lambda p, s=scale: tuple(x * s[p] for x in base_d), ordinary=name == "unnormalised"))
    cases += [
        Case("direction-subnormal", "Origin (0, 0, 2^-58), direction (0, 0, -2^-1070) (double: subnormal; float: "
             "(0, 0, -2^-140), subnormal), sphere r = 2^-60 at 0 (double); t* = 3·2^1010 (double) is finite. "
             "The exact power-of-two scale 2^1070 overflows. Expected: refused (a direction's largest "
             "component must be a normal number of the precision).",
             (Sphere((0.0, 0.0, 0.0), 2.0**-60),), (0.0, 0.0, 2.0**-58),
             {"double": (0.0, 0.0, -(2.0**-1070)), "float": (0.0, 0.0, -(2.0**-140))}, expect="refused",
             refused=r"^directions\[0\] must have its largest \|component\| in \["),
        Case("direction-t-overflow", "Origin (0, 0, 1e10), direction (0, 0, -1e-300) (float: -1e-35), unit "
             "sphere at 0: t* ~ 1e310 (float: 1e45) is not representable. Expected: a miss (t is never inf).",
             (UNIT,), (0.0, 0.0, 1e10), {"double": (0.0, 0.0, -1e-300), "float": (0.0, 0.0, -1e-35)},
             expect="miss"),
        Case("direction-t-overflow-behind", "As direction-t-overflow, pointing away (sphere behind) with t_min = "
             "-inf (orthographic cameras): t* ~ -1e310 is not representable. Expected: a miss, never t = -inf.",
             (UNIT,), (0.0, 0.0, 1e10), {"double": (0.0, 0.0, 1e-300), "float": (0.0, 0.0, 1e-35)},
             t_min=-INF, expect="miss"),
        Case("direction-huge-components", "Origin (0, 0, 5), direction (1e-10, 2e-10, -1)·1.5e308 (float: "
             "beyond its range: refused), unit sphere at 0: |d|² overflows; the power-of-two scale of a "
             "component above 2^1023 is the subnormal 2^-1023, still exact. Expected: double a hit at "
             "t* ~ 4/1.5e308 within the bound; float refused.",
             (UNIT,), (0.0, 0.0, 5.0), (1.5e298, 3e298, -1.5e308), expect={"double": "hit", "float": "refused"},
             refused=r"^directions\[0\] must have its largest"),
    ]
    # Overflow-range coordinates.
    cases += [
        Case("overflow-near-limit", "Origin 0, sphere r = s/10 at c = s·(1, 2, -2) with s = limit/2.2 (the "
             "sphere reaches 2.1·s, just inside the coordinate limit: 4.5e35 in double, 4.5e17 in float), "
             "direction c + 0.3 r·(2, -2, -1)/3. Expected: a hit within the well-conditioned bound (no square "
             "overflows).",
             {p: (Sphere((s, 2 * s, -2 * s), s / 10),) for p, s in NEAR_OVERFLOW.items()}, (0.0, 0.0, 0.0),
             {p: (s + s / 50, 2 * s - s / 50, -2 * s - s / 100) for p, s in NEAR_OVERFLOW.items()}),
        Case("overflow-sphere", "Origin 0, sphere r = 1e199 at c = (1e200, 2e200, -2e200) (float: inf after "
             "rounding), direction c (dead centre): r² and |f|² overflow in double. Expected: refused by the "
             "add (beyond every precision's coordinate limit).",
             (Sphere((1e200, 2e200, -2e200), 1e199),), (0.0, 0.0, 0.0), (1e200, 2e200, -2e200),
             expect="refused", refused=r"^centers\[0\] ± radii\[0\] must lie within ±1e\+36"),
        Case("overflow-origin", "Origin s·(1, 2, -2), s = 1e200 (float: 1e25, finite, but |f|² ~ 1e51 "
             "overflows), direction -(1, 2, -2) aimed at the sphere r = 1 at (0.5, 0.25, 0) near 0. Expected: "
             "refused by the cast (the origin is beyond the coordinate limit).",
             (Sphere((0.5, 0.25, 0.0), 1.0),), {"double": (1e200, 2e200, -2e200), "float": (1e25, 2e25, -2e25)},
             (-1.0, -2.0, 2.0), expect="refused", refused=r"^origins\[0\] must lie within ±1e\+(36|18)"),
        Case("overflow-float-range", "Origin (0, 0, 1e35), direction (0, 0, -1), sphere r = 1e30 at 0. Double: "
             "a hit at t* = 1e35 - 1e30; float: beyond its coordinate limit (1e35 would fit float, its squares "
             "would not). Expected: double a hit, float refused naming the origin.",
             (Sphere((0.0, 0.0, 0.0), 1e30),), (0.0, 0.0, 1e35), (0.0, 0.0, -1.0),
             expect={"double": "hit", "float": "refused"},
             refused=r"^origins\[0\] must lie within ±1e\+18 with precision='float', got 1e\+35$"),
        Case("overflow-ground", "Ground sphere r = 1e300 at (0, 0, -r) (float: r = 1e32), origin (0, 0, 1e295) "
             "(float: 1e27) above its top, direction (0.1, 0, -1): r² overflows. Expected: refused (beyond the "
             "coordinate limits).",
             {"double": (Sphere((0.0, 0.0, -1e300), 1e300),), "float": (Sphere((0.0, 0.0, -1e32), 1e32),)},
             {"double": (0.0, 0.0, 1e295), "float": (0.0, 0.0, 1e27)}, (0.1, 0.0, -1.0), expect="refused",
             refused=r"^(centers\[0\] ± radii\[0\]|origins\[0\]) must lie within ±1e\+(36|18)"),
    ]
    # Planes.
    oblique_point = tuple(1e7 * c for c in (1 / 3, 2 / 3, 2 / 3))
    cases += [
        Case("plane-far-axis", "Plane z = 1e7 (normal (0, 0, 1), offset 1e7); origin (0.5, -0.25, 0), direction "
             "(0.001, 0.002, 1). Expected: t* ~ 1e7 within the plane bound.",
             (Plane((0, 0, 1), 1e7),), (0.5, -0.25, 0.0), (0.001, 0.002, 1.0), ordinary=True),
        Case("plane-far-axis-close", "Plane z = 1e7; origin (3.5, -2.25, 1e7 - 0.75) just below it, direction "
             "(0.1, 0.2, 1). Expected: t* ~ 0.75 (from the rounded origin) within a few u.",
             (Plane((0, 0, 1), 1e7),), (3.5, -2.25, 1e7 - 0.75), (0.1, 0.2, 1.0)),
        Case("plane-far-oblique", "Plane (1, 2, 2)·p = 3e7 (unit normal (1, 2, 2)/3, 1e7 from 0); origin = its "
             "point 1e7·(1, 2, 2)/3 + 0.5·n + 100·(2, -1, 0), direction (-0.3, -0.5, -0.6). Expected: t* ~ 0.4 "
             "within a few u; a naive (offset - n·o)/(n·d) errs by ~u·2e7.",
             (Plane((1, 2, 2), 3e7),), add(add(oblique_point, (1 / 3, 2 / 3, 2 / 3), 0.5), (2, -1, 0), 100.0),
             (-0.3, -0.5, -0.6)),
        Case("plane-far-oblique-generic", "Plane (0.3, -0.7, 0.5)·p = -1e7; origin -1e7·n/|n|² + (5, 2, -1), "
             "direction (-0.2, -0.6, 0.3). Expected: t* ~ 0.8 within the plane bound (far from 0, close to the plane).",
             (Plane((0.3, -0.7, 0.5), -1e7),), add(tuple(-1e7 * c / 0.83 for c in (0.3, -0.7, 0.5)), (5, 2, -1)),
             (-0.2, -0.6, 0.3)),
        Case("plane-nearly-parallel", "Plane z = 0; origin (0, 0, 1), direction (1, 0.5, -1e-7). Expected: "
             "t* = 1e7 (the rounded -1e-7) within the plane bound.",
             (Plane((0, 0, 1), 0.0),), (0.0, 0.0, 1.0), (1.0, 0.5, -1e-7)),
        Case("plane-nearly-parallel-oblique", "Plane (1, 2, 2)·p = 3; origin 0, direction (2, -1, 0) - 1e-6·(1, 2, "
             "2)/3 (nearly in the plane's direction). Expected: t* ~ 1e6 within the plane bound (which grows "
             "with the cancellation in n·d).",
             (Plane((1, 2, 2), 3.0),), (0.0, 0.0, 0.0), add((2, -1, 0), (1 / 3, 2 / 3, 2 / 3), 1e-6)),
        Case("plane-far-nearly-parallel", "Plane z = 1e7; origin (0, 0, 1e7 - 2), direction (1, 1, 1e-5). Expected: "
             "t* ~ 2e5 within the plane bound.",
             (Plane((0, 0, 1), 1e7),), (0.0, 0.0, 1e7 - 2), (1.0, 1.0, 1e-5)),
        Case("plane-ray-in-plane", "Plane z = 7; origin (1, 2, 7) on it, direction (1, 1, 0) in it: n·d = 0 and "
             "n·(q - o) = 0. Expected: a miss (documented: no single intersection).",
             (Plane((0, 0, 1), 7.0),), (1.0, 2.0, 7.0), (1.0, 1.0, 0.0), expect="miss"),
        Case("plane-ray-in-oblique-plane", "Plane x + y = 0; origin (3, -3, 5) on it, direction (-1, 1, 2) in it "
             "(n·d = 0 exactly: n_x = n_y). Expected: a miss.",
             (Plane((1, 1, 0), 0.0),), (3.0, -3.0, 5.0), (-1.0, 1.0, 2.0), expect="miss"),
        Case("plane-parallel", "Plane z = 7; origin (1, 2, 8), direction (1, 1, 0): parallel, 1 above. "
             "Expected: a miss.",
             (Plane((0, 0, 1), 7.0),), (1.0, 2.0, 8.0), (1.0, 1.0, 0.0), expect="miss"),
        Case("plane-parallel-orthographic", "As plane-parallel with t_min = -inf (orthographic cameras): n·d = 0 "
             "gives t = -1/0 = -inf. Expected: a miss (a parallel ray misses; t is never inf on a hit).",
             (Plane((0, 0, 1), 7.0),), (1.0, 2.0, 8.0), (1.0, 1.0, 0.0), t_min=-INF, expect="miss"),
        Case("plane-t-overflow-orthographic", "Plane z = 7; origin (1, 2, 8), direction (1, 1, 1e-320) (float: "
             "1e-44, both subnormal) with t_min = -inf: t* ~ -1e320 (float -1e44) is not representable. "
             "Expected: a miss.",
             (Plane((0, 0, 1), 7.0),), (1.0, 2.0, 8.0), {"double": (1.0, 1.0, 1e-320), "float": (1.0, 1.0, 1e-44)},
             t_min=-INF, expect="miss"),
        Case("plane-origin-on-plane", "Plane z = 7; origin (1, 2, 7) on it, direction (0.3, 0.1, -1). Expected: "
             "t = 0 exactly (n·(q - o) = 0): a hit at the origin.",
             (Plane((0, 0, 1), 7.0),), (1.0, 2.0, 7.0), (0.3, 0.1, -1.0)),
        Case("plane-origin-on-plane-leaving", "Plane z = 7; origin (1, 2, 7) on it, direction (0.3, 0.1, 1), "
             "t_min = 1e-6 (a secondary ray leaving the surface). Expected: a miss.",
             (Plane((0, 0, 1), 7.0),), (1.0, 2.0, 7.0), (0.3, 0.1, 1.0), t_min=1e-6, expect="miss"),
        Case("plane-origin-on-far-oblique", "Plane (1, 2, 2)·p = 3e7; origin its stored point 1e7·(1, 2, 2)/3, "
             "direction (0.1, -0.2, 0.5). Expected: t = 0 within the bound (the origin is on the plane to "
             "within its rounding).",
             (Plane((1, 2, 2), 3e7),), lambda p: tuple(stored_plane(Plane((1, 2, 2), 3e7), p)[1]),
             (0.1, -0.2, 0.5), expect="any"),
        Case("plane-behind-orthographic", "Plane z = -5; origin 0, direction (0.2, 0.1, 1) (away), t_min = -inf. "
             "Expected: a hit at t* = -5.",
             (Plane((0, 0, 1), -5.0),), (0.0, 0.0, 0.0), (0.2, 0.1, 1.0), t_min=-INF),
        Case("plane-tiny-normal", "Plane (0, 0, 1e-300)·p = 1e-293 (z = 1e7); origin (1, 2, 1e7 - 3), direction "
             "(0.5, 0, 1). Expected: t* = 3 (from the stored point) within the plane bound.",
             (Plane((0, 0, 1e-300), 1e-293),), (1.0, 2.0, 1e7 - 3), (0.5, 0.0, 1.0)),
        Case("plane-huge-normal", "Plane (3e300, 4e300, 0)·p = 1e301 (0.6x + 0.8y = 2); origin (10, -3, 1), "
             "direction (-1, 0.5, 0.2). Expected: t* within the plane bound.",
             (Plane((3e300, 4e300, 0), 1e301),), (10.0, -3.0, 1.0), (-1.0, 0.5, 0.2), ordinary=True),
        Case("plane-tiny-direction", "Plane (1, 2, 2)·p = 30; origin (1, 1, 1), direction (1, 1, 1)·1e-30 (float: "
             "1e-18). Expected: t* = 5e30 (float: 5e18) within the plane bound.",
             (Plane((1, 2, 2), 30.0),), (1.0, 1.0, 1.0),
             {"double": (1e-30, 1e-30, 1e-30), "float": (1e-18, 1e-18, 1e-18)}),
    ]
    return cases


CASES = _cases()
SPHERE_CASES = [c for c in CASES if any(isinstance(p, Sphere) for p in c.primitives_for("double"))]


def case_exacts(case: Case, precision: str, *, robust: bool = True) -> list[Exact]:
    return exact_answers(case.primitives_for(precision), case.origin_for(precision), case.direction_for(precision),
                         precision, robust=robust)


def _check_expectation(case: Case, precision: str, exacts: list[Exact]) -> None:
    """The case is what its doc says (a test of the test): e.g. a "hit" case is a hit in the rounded inputs."""
    expect = per_precision(case.expect, precision)
    t_min, t_max = case.t_min_for(precision), case.t_max_for(precision)
    inside = [r for e in exacts for r in e.roots
              if r.required and r.t - r.tol >= t_min and r.t + r.tol < t_max]
    info = exacts[0].info
    if expect == "hit":
        assert inside, f"case setup: {case.id} is not a clear hit in {precision}"
    elif expect == "miss":
        assert not [r for e in exacts for r in e.roots if r.real and r.t + r.tol >= t_min and r.t - r.tol < t_max
                    and representable(r.t, precision)], f"case setup: {case.id} is not a miss in {precision}"
    elif expect == "tangent":
        assert info["h2"] == 0 and info["f_exact"], f"case setup: {case.id} is not an exact tangent"
    elif expect == "graze":
        assert info["h2"] > 0, f"case setup: {case.id} does not meet the sphere"


@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_hard_case(case: Case, precision: str) -> None:
    """Robust method (the default) against the exact answer of `case` (its doc states the ray, the
    primitive and the expected behaviour); the tolerances are the module docstring's."""
    expect = per_precision(case.expect, precision)
    cast = cast_case(case, precision, "robust")
    if cast is None:
        return
    exacts = case_exacts(case, precision)
    _check_expectation(case, precision, exacts)
    result, ids = cast
    t, index = float(result.t[0]), result_index(result, ids)
    assert result.t.dtype == DTYPE[precision]
    problems = judge(exacts, t, index, result.normal[0], case.t_min_for(precision), case.t_max_for(precision),
                     precision)
    if expect in ("miss", "tangent") and index >= 0:
        problems.append(f"expected a miss ({expect}), got a hit at t = {t!r}")
    if index < 0:
        assert result.material_id[0] == -1 and not result.normal[0].any()
    assert not problems, f"{case.id} [{precision}]: {case.doc}\n" + "\n".join(problems)


@pytest.mark.parametrize("method", ["algebraic", "geometric"])
@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize("case", SPHERE_CASES, ids=[c.id for c in SPHERE_CASES])
def test_textbook_methods(case: Case, precision: str, method: str, record_property) -> None:
    """The textbook methods on the same cases: their error is recorded (junit XML property
    `error`), asserted only on ordinary cases; on every case a hit has a finite t in range."""
    cast = cast_case(case, precision, method)
    if cast is None:
        return
    exacts = case_exacts(case, precision, robust=False)
    result, ids = cast
    t = float(result.t[0])
    record_property("error", relative_error(case, precision, result, exacts, ids))
    if result.object_id[0] >= 0:
        assert math.isfinite(t) and case.t_min_for(precision) <= t < case.t_max_for(precision)
    if case.ordinary:
        problems = judge(exacts, t, result_index(result, ids), result.normal[0], case.t_min_for(precision),
                         case.t_max_for(precision), precision)
        assert not problems, f"{case.id} [{precision}, {method}]: " + "\n".join(problems)


# --- NaN, inf and zero inputs --------------------------------------------------------------------
BAD_RAYS = [
    ("origin-nan", (NAN, 0.0, 5.0), (0.0, 0.0, -1.0)),
    ("origin-inf", (0.0, 0.0, INF), (0.0, 0.0, -1.0)),
    ("origin-minus-inf", (0.0, 0.0, -INF), (0.0, 0.0, 1.0)),
    ("direction-nan", (0.0, 0.0, 5.0), (0.0, NAN, -1.0)),
    ("direction-inf", (0.0, 0.0, 5.0), (0.0, 0.0, -INF)),
    ("direction-inf-nan", (0.0, 0.0, 5.0), (INF, NAN, -1.0)),
    ("direction-zero", (0.0, 0.0, 5.0), (0.0, 0.0, 0.0)),
    ("all-nan", (NAN, NAN, NAN), (NAN, NAN, NAN)),
]


def cast_bad_ray(scene: durer.Scene, origin, direction, **kwargs) -> durer.CastResult:
    """The bad ray between two good copies of (0, 0, 5) -> (0, 0, -1) in one packet, unchecked."""
    good_o, good_d = (0.0, 0.0, 5.0), (0.0, 0.0, -1.0)
    origins = np.array([good_o, origin, good_o], float)
    directions = np.array([good_d, direction, good_d], float)
    result = durer.cast(scene, origins, directions, check=False, **kwargs)
    assert result.t[1] == INF, f"t = {result.t[1]} (object {result.object_id[1]})"
    assert result.object_id[1] == -1 and result.material_id[1] == -1 and not result.normal[1].any()
    return result


@pytest.mark.parametrize("t_min", [0.0, -INF], ids=["t_min-0", "t_min-minus-inf"])
@pytest.mark.parametrize("method", ["robust", "algebraic", "geometric"])
@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize(("name", "origin", "direction"), BAD_RAYS, ids=[b[0] for b in BAD_RAYS])
def test_unchecked_bad_rays_miss_spheres(name, origin, direction, precision, method, t_min) -> None:
    """check=False: a ray with a NaN, an infinite coordinate or a zero direction misses the unit
    sphere at 0 (straight ahead of the finite version of the ray), whatever the method and t_min;
    the good rays around it in the same packet still hit it at t = 4."""
    scene = durer.Scene()
    scene.add_spheres([[0.0, 0.0, 0.0]], [1.0])
    result = cast_bad_ray(scene, origin, direction, t_min=t_min, precision=precision, sphere_method=method)
    np.testing.assert_array_equal(result.t[[0, 2]], [4.0, 4.0])


@pytest.mark.parametrize("t_min", [0.0, -INF], ids=["t_min-0", "t_min-minus-inf"])
@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize(("name", "origin", "direction"), BAD_RAYS, ids=[b[0] for b in BAD_RAYS])
def test_unchecked_bad_rays_miss_planes(name, origin, direction, precision, t_min) -> None:
    """check=False: the same rays miss the plane z = -3 (ahead of the finite rays, which hit it at
    t = 8): no hit at t = 0 = n·(q - o)/inf, none at t = ±inf = n·(q - o)/0 when t_min = -inf."""
    scene = durer.Scene()
    scene.add_plane((0, 0, 1), -3.0)
    result = cast_bad_ray(scene, origin, direction, t_min=t_min, precision=precision)
    np.testing.assert_array_equal(result.t[[0, 2]], [8.0, 8.0])


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda s: durer.cast(s, [[NAN, 0, 5]], [[0, 0, -1]]), "origins"),
        (lambda s: durer.cast(s, [[0, 0, INF]], [[0, 0, -1]]), "origins"),
        (lambda s: durer.cast(s, [[0, 0, 5]], [[0, NAN, -1]]), "directions"),
        (lambda s: durer.cast(s, [[0, 0, 5]], [[0, 0, -INF]]), "directions"),
        (lambda s: durer.cast(s, [[0, 0, 5], [0, 0, 5]], [[0, 0, -1], [0, 0, 0]]), r"directions\[1\]"),
        (lambda s: durer.cast(s, [[0, 0, 5]], [[0, 0, -1]], t_min=NAN), "t_min"),
        (lambda s: durer.cast(s, [[0, 0, 5]], [[0, 0, -1]], t_max=NAN), "t_max"),
        (lambda s: s.add_spheres([[0, NAN, 0]], [1.0]), "centers"),
        (lambda s: s.add_spheres([[0, 0, 0]], [INF]), "radii"),
        (lambda s: s.add_plane((NAN, 0, 1), 0.0), "normal"),
        (lambda s: s.add_plane((0, 0, 1), INF), "offset"),
        (lambda s: s.add_plane((0, 0, 1e-300), 1e300), "offset"),  # offset/|normal| overflows
    ],
    ids=["origin-nan", "origin-inf", "direction-nan", "direction-inf", "direction-zero", "t_min-nan", "t_max-nan",
         "center-nan", "radius-inf", "normal-nan", "offset-inf", "offset-over-normal"],
)
def test_checked_bad_input_raises(call, message) -> None:
    """check=True (the default) and the scene's adds: non-finite input raises ValueError naming the field."""
    scene = durer.Scene()
    scene.add_spheres([[0.0, 0.0, 0.0]], [1.0])
    with pytest.raises(ValueError, match=message):
        call(scene)


@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize("case_id", ["plane-far-oblique", "plane-far-oblique-generic"])
def test_plane_tolerance_rejects_the_naive_formula(case_id: str, precision: str) -> None:
    """A test of the tolerance: t = (offset - n·o)/(n·d), computed in the precision under test from
    the same stored unit normal and unit offset, errs by ~u(|offset| + Σ|n_i o_i|)/|n·d| when the
    origin and the plane are both ~1e7 from 0 along an oblique normal; the PLANE bound rejects it."""
    case = next(c for c in CASES if c.id == case_id)
    plane = case.primitives_for(precision)[0]
    real = DTYPE[precision]
    n, _ = stored_plane(plane, precision)
    nx, ny, nz = (float(v) for v in plane.normal)
    largest = max(abs(nx), abs(ny), abs(nz))
    sx, sy, sz = nx / largest, ny / largest, nz / largest
    offset = real(float(plane.offset) / largest / math.sqrt(sx * sx + sy * sy + sz * sz))
    o, d = rounded(case.origin_for(precision), precision), rounded(case.direction_for(precision), precision)
    naive = (offset - (n[0] * o[0] + n[1] * o[1] + n[2] * o[2])) / (n[0] * d[0] + n[1] * d[1] + n[2] * d[2])
    exacts = case_exacts(case, precision)
    problems = judge(exacts, float(naive), 0, n, case.t_min_for(precision), case.t_max_for(precision), precision)
    assert problems and "is no root" in problems[0], f"the naive t = {naive!r} passes the plane tolerance"
