"""Differential fuzz of the traversal: random scenes (spheres, triangles, meshes, boxes, planes, in
world space and in transformed groups, up to a few hundred primitives so that hierarchies are built)
and random rays (camera fans, random, aimed, grazing, axis-parallel; inside and outside the scene;
coordinates from 1e-6 to 1e6 scales, clusters far from the origin; float and double) give bit for bit
the nearest t, and the object, material and normal, of a brute-force loop over every primitive
(tests/helpers/traversal_fuzz.py; docs/reliability.md). Derandomised: the same cases on every run.
DURER_FUZZ_EXAMPLES=N runs N cases instead of the default (never fewer); bench/fuzz_traversal.py
runs fresh random cases for a given time.
"""

from __future__ import annotations

import contextlib
import io
import os
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

import durer
from helpers.traversal_fuzz import Batch, Case, Tally, compare, fuzz, judge, reduce_case

DEFAULT_EXAMPLES = 50
EXAMPLES = max(DEFAULT_EXAMPLES, int(os.environ.get("DURER_FUZZ_EXAMPLES", DEFAULT_EXAMPLES)))


def test_traversal_matches_brute_force():
    tally = Tally()
    fuzz(settings(derandomize=True, database=None, deadline=None, max_examples=EXAMPLES,
                  suppress_health_check=[HealthCheck.too_slow]), tally)
    # The cases reach what they are meant to: every primitive kind is hit, in world space and in
    # transformed groups; grazing rays hit; both precisions are tried.
    kinds = {"spheres", "triangles", "boxes", "mesh", "plane"}
    assert kinds <= set(tally.wins) and {k + " transformed" for k in kinds} <= set(tally.wins), tally
    assert tally.grazing_hits > 100, tally
    assert 0.2 < tally.hits / tally.rays < 0.9, tally
    assert tally.precisions["float"] >= 5 and tally.precisions["double"] >= 5, tally.precisions
    assert tally.primitives / tally.cases > 100, tally


# A float scene of 18 tiny spheres one unit from a ray's origin (found by this fuzz): the textbook
# "algebraic" method reports hits for spheres the ray passes 20+ radii away (cancellation), outside
# their boxes, where the hierarchy does not look. The robust method, which the fuzz uses, misses them.
TINY_CENTERS = np.array([
    [-3.0148695549074463e-07, -4.092469543808781e-07, 8.033238598685067e-08],
    [-2.013038671810774e-07, 1.7199487795635936e-07, -3.0048455603178667e-07],
    [4.421131105064978e-07, -1.3488983175517144e-07, -3.9450472042977045e-07],
    [1.291081515397092e-07, 4.271545530678674e-07, -5.962284528421601e-08],
    [4.545904936907372e-07, -1.0418631235298292e-10, -7.477137515092446e-08],
    [1.202134520153778e-07, 4.950965052353241e-07, 4.489436749377653e-07],
    [1.0663577576717986e-07, 2.2949656098399839e-07, 4.362499146542287e-08],
    [4.350724237877682e-07, 3.158535541215321e-07, -4.972614998298519e-07],
    [3.5740427658756935e-07, -4.6641442469453564e-07, 2.2965544642994405e-07],
    [-3.24344379397441e-07, 3.6317892234988655e-07, 4.146122024909171e-08],
    [-2.002881094626152e-07, -7.731277880234154e-08, -4.71680328854537e-07],
    [-3.75716723500436e-07, 1.706244146936303e-07, 1.4718951157425007e-07],
    [1.1538511148125386e-07, -1.1632244573811655e-07, 4.97209935789211e-07],
    [4.808353387762301e-07, 1.855419844806947e-07, 1.5045927626781629e-07],
    [1.8844673057094006e-07, -1.110785760208962e-07, -3.6490349497758874e-07],
    [3.902743520047923e-07, -2.728424064666203e-07, 1.2318714468604242e-07],
    [2.0e-07, 2.0e-07, 2.0e-07],
    [-2.0e-07, -2.0e-07, 2.0e-07],
])
TINY_RADII = np.array([
    4.9821138923650516e-08, 8.76043793070571e-09, 1.0839400535949857e-08, 6.008672478385e-08,
    5.040828976919498e-09, 4.265818351035103e-08, 1.055668432683471e-08, 2.510160198895624e-09,
    8.108164303069788e-09, 1.2009217753580583e-07, 1.6170602302659396e-07, 3.4483081647519017e-09,
    1.4369329682255737e-08, 2.712821596260953e-09, 1.672900409918531e-08, 8.626019865798368e-10, 1e-8, 1e-8,
])
ORIGIN = np.array([[-0.15291306281246955, 0.4664647312098165, -0.2219979939415181]])
DIRECTION = np.array([[9.160724826776566, -27.944949071290907, 13.299489568675456]])


def tiny_spheres_case(sphere_method: str) -> Case:
    batch = Batch("spheres", {"centers": TINY_CENTERS, "radii": TINY_RADII}, np.zeros(18, dtype=np.int32))
    return Case([batch], ORIGIN, DIRECTION, {"precision": "float", "sphere_method": sphere_method})


def test_the_check_sees_the_textbook_methods_spurious_hits():
    case = tiny_spheres_case("algebraic")
    # The ray misses every sphere (exactly, in the float inputs), yet "algebraic" hits some of them
    # alone, spheres it passes 20 radii away among them ...
    o, d = ORIGIN[0].astype(np.float32).astype(float), DIRECTION[0].astype(np.float32).astype(float)
    c = TINY_CENTERS.astype(np.float32).astype(float)
    f = o - c
    distance = np.linalg.norm(f - (f @ d)[:, None] * d / (d @ d), axis=1)
    assert (distance > 1.2 * TINY_RADII).all()
    alone = [durer.cast(case.scene([case.batches[0].subset(np.array([i]))]), ORIGIN, DIRECTION,
                        **case.options).t[0] for i in range(18)]
    assert sum(np.isfinite(alone) & (distance > 20 * TINY_RADII)) >= 3
    # ... and the hierarchy's search does not find the nearest of those: the check reports it.
    bad, message, full = judge(case)
    assert list(bad) == [0] and full.t[0] != min(alone) and "1 of 1 rays differ" in message
    # The robust method misses every sphere, alone and together.
    assert compare(tiny_spheres_case("robust")) is None
    assert np.isinf(durer.cast(tiny_spheres_case("robust").scene(), ORIGIN, DIRECTION, precision="float").t[0])


# A float mesh at 1e6 (found by this fuzz): the ray's origin, rounded to float, lies exactly on the
# edge two triangles share and on both their boxes' faces. With t_min = -inf it meets both at t
# rounded a little below 0, each its own way; the hierarchy entered the lower one's box at exactly 0
# and dropped it for the other's higher t, until triangle boxes were grown by the error of that t.
MESH_VERTICES = np.array([
    [14722.133904764107, 835765.2555667873, -548889.2374414542],
    [14722.12737468817, 835765.2263523719, -548889.2275356904],
    [14722.178603044838, 835765.2555667873, -548889.2512158985],
    [14722.047763032233, 835765.1779791013, -548889.2476700969],
    [14722.107099530289, 835765.173099393, -548889.253521053],
    [14722.159907023897, 835765.199054501, -548889.2493431295],
    [14722.217409371147, 835765.2555667873, -548889.2855456343],
    [14722.041448645543, 835765.1670422627, -548889.2949200127],
    [14722.114463595535, 835765.1313357037, -548889.2850086144],
    [14722.167817064264, 835765.192417189, -548889.2965669181],
    [14722.224236150465, 835765.2555667873, -548889.3372606398],
    [14722.031493984005, 835765.1498002831, -548889.3372606398],
    [14722.116030375882, 835765.1224500508, -548889.3372606398],
    [14722.182012825971, 835765.1805055307, -548889.3372606398],
    [14722.20949822061, 835765.2555667873, -548889.3856987393],
    [14722.040637465285, 835765.1656372573, -548889.3802732707],
    [14722.109785371287, 835765.1578672319, -548889.3783534123],
    [14722.171007467188, 835765.1897401231, -548889.3796794678],
    [14722.057388905872, 835765.1946516035, -548889.4075994353],
    [14722.108138713525, 835765.167205892, -548889.4269846443],
    [14722.072414585271, 835765.2206768437, -548889.434523116],
    [14722.101601765826, 835765.2042787647, -548889.4629910063],
])
MESH_FACES = np.array([[3, 7, 8], [3, 8, 4], [7, 11, 12], [7, 12, 8], [11, 15, 16], [11, 16, 12], [15, 18, 19], [15, 19, 16], [18, 20, 21], [1, 2, 0], [5, 9, 6], [5, 6, 2], [9, 13, 10], [9, 10, 6], [13, 17, 14], [13, 14, 10]])
EDGE_ORIGIN = [[14722.104271033128, 835765.1294809296, -548889.3305847696]]
EDGE_DIRECTION = [[-0.0018749940260744085, 0.0010269143111390716, 0.0008587059947242075]]


def test_a_ray_leaving_a_meshs_shared_edge_finds_the_lower_t():
    case = Case([Batch("mesh", {"vertices": MESH_VERTICES, "faces": MESH_FACES}, np.array([1]))],
                np.array(EDGE_ORIGIN), np.array(EDGE_DIRECTION), {"precision": "float", "t_min": -np.inf})
    alone = [durer.cast(case.scene([case.batches[0].subset(np.array([i]))]), case.origins, case.directions,
                        **case.options).t[0] for i in range(len(MESH_FACES))]
    hit = np.flatnonzero(np.isfinite(alone))
    assert len(hit) == 2 and all(-1e-6 < alone[i] < 0 for i in hit) and alone[hit[0]] != alone[hit[1]]
    assert len(MESH_FACES) >= 16  # enough for a hierarchy
    assert compare(case) is None
    assert durer.cast(case.scene(), case.origins, case.directions, **case.options).t[0] == min(alone)


def test_reduction_and_reproduction():
    case = tiny_spheres_case("algebraic")
    reduced = reduce_case(case)
    # Still failing, with fewer spheres, but at least the 16 that make a hierarchy.
    assert compare(reduced) is not None and 16 <= reduced.primitive_count() < 18
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(reduced.source(), "<reproduction>", "exec"), {})
    assert printed.getvalue() == compare(reduced) + "\n"


def test_reduction_keeps_the_failing_ray_wherever_it_was():
    # Two rays that agree with the brute force (away from the spheres), then the failing one: the
    # reduction keeps that ray alone, numbered 0 (it once indexed the kept rays by their old numbers).
    case = tiny_spheres_case("algebraic")
    away = -DIRECTION / np.linalg.norm(DIRECTION)
    case = replace(case, origins=np.concatenate([ORIGIN, ORIGIN, ORIGIN]),
                   directions=np.concatenate([away, 2 * away, DIRECTION]))
    assert list(judge(case)[0]) == [2]
    reduced = reduce_case(case)
    np.testing.assert_array_equal(reduced.origins, ORIGIN)
    np.testing.assert_array_equal(reduced.directions, DIRECTION)
    assert list(judge(reduced)[0]) == [0]


@pytest.mark.parametrize("kind", ["triangles", "boxes", "mesh", "plane"])
def test_reproduction_rebuilds_the_case_exactly(kind):
    from helpers.traversal_fuzz import Shape, make_case

    counts = {"triangles": (0, 20, 0, 0, 0), "boxes": (0, 0, 20, 0, 0), "mesh": (0, 0, 0, 30, 0),
              "plane": (0, 0, 0, 0, 2)}[kind]
    case = make_case(Shape(7, counts, 2, 6.0, 6.0, 40, "float", "robust", "window"))
    namespace: dict = {}
    source = case.source().replace("print(compare(case) or 'no difference')\n", "")
    exec(compile(source, "<reproduction>", "exec"), namespace)
    rebuilt = namespace["case"]
    assert rebuilt.options == case.options
    np.testing.assert_array_equal(rebuilt.origins, case.origins)
    np.testing.assert_array_equal(rebuilt.directions, case.directions)
    a, b = case.cast(case.scene()), rebuilt.cast(rebuilt.scene())
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_array_equal(a.object_id, b.object_id)
