"""Differential traversal fuzz: a scene's accelerated search against a brute-force loop over its
primitives, through the public API only (used by tests/core/test_traversal_fuzz.py and
bench/fuzz_traversal.py; docs/reliability.md).

The brute force casts the same rays at a scene of each primitive alone (same materials, same
transform): a scene of one primitive has no hierarchy, and each primitive's t comes from the same
kernel as in the full scene, so the full scene's t must be the minimum of those, bit for bit (inf
for a miss), and its object, material and normal those of a primitive whose own t is that minimum
(primitives tied at exactly that t may win either way); and `durer.occluded` (the any-hit search)
must report a hit exactly for the rays some primitive alone is hit by.

A case is a list of batches (one add call each: spheres, triangles, boxes, a mesh or a plane, in
world space or under one of a few shared transforms, so transformed groups hold hierarchies of
their own) and rays mixing camera fans, random rays, rays aimed at primitives, grazing rays (tangent
to spheres, along box faces, through triangle edges and vertices), axis-parallel ones, and rays
starting on a primitive's surface in any direction (as reflection and shadow rays do; the "surface"
ray range gives them the least positive t_min, the renderer's secondary rays'). Arrays come
from a seeded numpy generator; hypothesis draws the seed and the shape of the case (counts,
coordinate scale, distance from the origin, precision, ray range), so it shrinks those, and
`reduce_case` then drops rays and primitives the failure does not need. `Case.source()` is a
runnable reproduction.

Spheres are tested with the robust method only. The textbook methods ("algebraic", "geometric")
report spurious hits where cancellation ruins them -- in float, a ray passing 50 radii from a sphere
of radius 1e-8 one unit away -- outside the sphere's box, and the hierarchy (rightly) never visits
them there, so a scene of 16 or more such spheres differs from its brute force by design
(tests/core/test_traversal_fuzz.py holds that case).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from hypothesis import strategies as st

import durer

KINDS = ("spheres", "triangles", "boxes", "mesh", "plane")
MATERIALS = ((0.8, 0.2, 0.2), (0.2, 0.8, 0.2), (0.2, 0.2, 0.8))  # added to every scene: ids 1, 2, 3
RAY_KINDS = ("fan", "random", "aimed", "grazing", "axis", "leaving")


@dataclass
class Batch:
    """One add call. spheres: centers (N, 3), radii (N,), maybe one_sided (N,) bools; triangles: vertices (N, 3, 3); boxes:
    lo, hi (N, 3); mesh: vertices (V, 3), faces (F, 3); plane: normal (3,), offset, bounds or None.
    material: (N,) ids (one for a mesh or plane); transform: world-from-object (3, 4) or None."""

    kind: str
    arrays: dict[str, Any]
    material: np.ndarray
    transform: np.ndarray | None = None

    def size(self) -> int:
        """Primitives in the batch (a mesh's faces; a plane is one)."""
        if self.kind == "plane":
            return 1
        return len(self.arrays["faces" if self.kind == "mesh" else next(iter(self.arrays))])

    def subset(self, keep: np.ndarray) -> Batch:
        """The batch with only primitives `keep` (indices); a mesh keeps all its vertices."""
        if self.kind == "plane":
            return self
        if self.kind == "mesh":
            return replace(self, arrays={"vertices": self.arrays["vertices"], "faces": self.arrays["faces"][keep]})
        return replace(self, arrays={k: v[keep] for k, v in self.arrays.items()}, material=self.material[keep])

    def add_to(self, scene: durer.Scene) -> None:
        a, m = self.arrays, self.material
        if self.kind == "spheres":
            scene.add_spheres(a["centers"], a["radii"], m, transform=self.transform, one_sided=a.get("one_sided", False))
        elif self.kind == "triangles":
            scene.add_triangles(a["vertices"], m, transform=self.transform)
        elif self.kind == "boxes":
            scene.add_boxes(a["lo"], a["hi"], m, transform=self.transform)
        elif self.kind == "mesh":
            scene.add_mesh(a["vertices"], a["faces"], int(m[0]), transform=self.transform)
        else:
            scene.add_plane(a["normal"], float(a["offset"]), int(m[0]), a["bounds"], transform=self.transform)

    def objects(self) -> int:
        """Object ids the batch takes (a mesh is one object)."""
        return 1 if self.kind in ("mesh", "plane") else self.size()

    def source(self) -> str:
        arrays = ", ".join(f"{k}={_literal(v)}" for k, v in self.arrays.items())
        return (f"Batch({self.kind!r}, dict({arrays}), {_literal(self.material)}, "
                f"{_literal(self.transform)})")


@dataclass
class Case:
    batches: list[Batch]
    origins: np.ndarray
    directions: np.ndarray
    options: dict[str, Any] = field(default_factory=dict)  # cast's t_min, t_max, precision, sphere_method
    ray_kinds: np.ndarray | None = None  # RAY_KINDS index of each ray, for messages

    def scene(self, batches: list[Batch] | None = None) -> durer.Scene:
        scene = durer.Scene()
        for diffuse in MATERIALS:
            scene.add_material(diffuse)
        for batch in self.batches if batches is None else batches:
            batch.add_to(scene)
        return scene

    def cast(self, scene: durer.Scene) -> durer.CastResult:
        # One thread: a case's few hundred rays are one work item anyway, and thousands of tiny casts
        # on a busy machine would otherwise wait on thread wake-ups.
        return durer.cast(scene, self.origins, self.directions, threads=1, **self.options)

    def occluded(self, scene: durer.Scene) -> np.ndarray:
        return durer.occluded(scene, self.origins, self.directions, threads=1, **self.options)

    def primitive_count(self) -> int:
        return sum(b.size() for b in self.batches)

    def source(self) -> str:
        """A script that reruns this case from the repository root and prints what differs."""
        batches = ",\n    ".join(b.source() for b in self.batches)
        return (
            "import sys; sys.path.insert(0, 'tests')\n"
            "import numpy as np\nfrom numpy import array, inf, nan, float64, int32, int64\n"
            "from helpers.traversal_fuzz import Batch, Case, compare\n"
            f"case = Case([\n    {batches},\n],\n"
            f"    origins={_literal(self.origins)},\n    directions={_literal(self.directions)},\n"
            f"    options={self.options!r})\n"
            "print(compare(case) or 'no difference')\n"
        )


def _literal(value: Any) -> str:
    """Python source for a number or array that evaluates back to it exactly (repr of a float
    round-trips; float32 arrays are written as float64 values, which hold them exactly)."""
    if value is None:
        return "None"
    if isinstance(value, tuple):
        return "(" + ", ".join(_literal(v) for v in value) + ",)"
    array = np.asarray(value)
    if array.ndim == 0:
        return repr(array.item())
    dtype = "bool" if array.dtype == bool else "int64" if array.dtype.kind in "iu" else "float64"
    return f"np.array({array.tolist()!r}, dtype={dtype})"


# --- the check -----------------------------------------------------------------------------------
def single_primitive_batches(case: Case) -> list[tuple[Batch, int]]:
    """Each primitive as a batch of its own, with its object id in the full scene."""
    singles = []
    object_id = 0
    for batch in case.batches:
        for i in range(batch.size()):
            singles.append((batch.subset(np.array([i])), object_id + (0 if batch.kind in ("mesh", "plane") else i)))
        object_id += batch.objects()
    return singles


def compare(case: Case) -> str | None:
    """None if the full scene's hits are the brute force's, else a description of the rays that
    differ (the first few, and how many)."""
    bad, message, _ = judge(case)
    return message if len(bad) else None


def judge(case: Case) -> tuple[np.ndarray, str, durer.CastResult]:
    """The indices of the rays whose hit differs from the brute force's, a description of them and
    the full scene's hits."""
    scene = case.scene()
    full, occluded = case.cast(scene), case.occluded(scene)
    n = len(case.origins)
    singles = single_primitive_batches(case)
    t = np.full((len(singles), n), np.inf, dtype=full.t.dtype)
    match = np.zeros((len(singles), n), dtype=bool)
    for p, (batch, object_id) in enumerate(singles):
        alone = case.cast(case.scene([batch]))
        t[p] = alone.t
        # Its own record, with its object id in the full scene: same material, bit-equal normal.
        same_normal = np.all((alone.normal == full.normal) | (np.isnan(alone.normal) & np.isnan(full.normal)), axis=1)
        match[p] = (alone.object_id == 0) & (full.object_id == object_id) & (alone.material_id == full.material_id) \
            & same_normal
    nearest = t.min(axis=0, initial=np.inf)
    winners = (t == nearest) & np.isfinite(t)
    missed = ~winners.any(axis=0)
    wrong_t = ~((full.t == nearest) | (np.isnan(full.t) & np.isnan(nearest)))
    miss_record = (full.object_id != -1) | (full.material_id != -1) | np.any(full.normal != 0, axis=1)
    wrong_record = np.where(missed, miss_record, ~np.any(winners & match, axis=0))
    wrong_occlusion = occluded != ~missed  # the any-hit search: a hit exactly where some primitive is hit
    bad = np.flatnonzero(wrong_t | wrong_record | wrong_occlusion)
    if not len(bad):
        return bad, "", full
    lines = [f"{len(bad)} of {n} rays differ from the brute force ({case.primitive_count()} primitives, "
             f"{case.options}); the first ones:"]
    for r in bad[:5]:
        kind = "" if case.ray_kinds is None else f" ({RAY_KINDS[case.ray_kinds[r]]})"
        tied = [singles[p][1] for p in np.flatnonzero(winners[:, r])]
        lines.append(
            f"  ray {r}{kind}: origin {case.origins[r].tolist()!r} direction {case.directions[r].tolist()!r}\n"
            f"    scene:       t {full.t[r]!r} object {full.object_id[r]} material {full.material_id[r]} "
            f"normal {full.normal[r].tolist()} occluded {bool(occluded[r])}\n"
            f"    brute force: t {nearest[r]!r} objects {tied}")
    return bad, "\n".join(lines), full


# --- reduction -----------------------------------------------------------------------------------
def reduce_case(case: Case, budget: int = 200) -> Case:
    """A smaller case that still fails: only its failing rays (the first alone if that fails too),
    then greedily fewer primitives (chunks of halving size), with at most `budget` re-checks."""
    checks = 0

    def fails(candidate: Case) -> bool:
        nonlocal checks
        checks += 1
        return compare(candidate) is not None

    bad = np.asarray(judge(case)[0])
    for keep in (len(bad), 1):  # every failing ray, then the first alone
        rays = bad[:keep]
        candidate = replace(case, origins=case.origins[rays], directions=case.directions[rays],
                            ray_kinds=None if case.ray_kinds is None else case.ray_kinds[rays])
        if len(rays) < len(case.origins) and fails(candidate):
            case, bad = candidate, np.arange(len(rays))  # the kept rays, numbered anew
    chunk = max(1, case.primitive_count() // 2)
    while chunk >= 1 and checks < budget:
        start, removed = 0, False
        while start < case.primitive_count() and checks < budget:
            candidate = _without(case, start, chunk)
            if fails(candidate):
                case, removed = candidate, True
            else:
                start += chunk
        if not removed:
            chunk //= 2
    return case


def _without(case: Case, start: int, count: int) -> Case:
    """The case without primitives [start, start + count) of its batches in turn."""
    batches = []
    offset = 0
    for batch in case.batches:
        size = batch.size()
        keep = np.array([i for i in range(size) if not start <= offset + i < start + count], dtype=np.int64)
        offset += size
        if len(keep) == size:
            batches.append(batch)
        elif len(keep):
            batches.append(batch.subset(keep))
    return replace(case, batches=batches)


# --- generation ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Shape:
    """What hypothesis draws (and shrinks); `make_case` turns it into arrays."""

    seed: int
    counts: tuple[int, int, int, int, int]  # spheres, triangles, boxes, mesh faces, planes
    transforms: int  # distinct transforms the batches share (0: all in world space)
    scale_exponent: float  # the scene spans about 10**scale_exponent
    offset_exponent: float  # and sits about 10**offset_exponent from the origin (0: at it)
    rays: int
    precision: str
    sphere_method: str
    ray_range: str  # "forward" (t in [0, inf)), "line" (-inf, inf), "window" (a finite [t_min, t_max)),
    # "surface" (t > 0: t_min the least positive double)


def shapes(max_primitives: int = 300) -> st.SearchStrategy[Shape]:
    count = st.integers(0, max_primitives)
    return st.builds(
        Shape,
        seed=st.integers(0, 2**32 - 1),
        counts=st.tuples(count, st.integers(0, max_primitives // 2), st.integers(0, max_primitives // 2),
                         st.integers(0, max_primitives // 2), st.integers(0, 3)),
        transforms=st.integers(0, 3),
        scale_exponent=st.sampled_from([0.0, -6.0, -3.0, 3.0, 6.0]),
        offset_exponent=st.sampled_from([0.0, 2.0, 4.0, 6.0]),
        rays=st.integers(1, 400),
        precision=st.sampled_from(["double", "float"]),
        sphere_method=st.just("robust"),  # the textbook methods' spurious hits: see the module docstring
        ray_range=st.sampled_from(["forward", "line", "window", "surface"]),
    )


def make_case(shape: Shape) -> Case:
    rng = np.random.default_rng(shape.seed)
    scale = 10.0 ** shape.scale_exponent
    offset = 0.0 if shape.offset_exponent == 0 else 10.0 ** shape.offset_exponent * _unit(rng)
    transforms = [_random_transform(rng, scale, offset) for _ in range(shape.transforms)]

    def transform() -> np.ndarray | None:
        # Half the batches in world space, the rest spread over the shared transforms.
        return transforms[rng.integers(len(transforms))] if transforms and rng.random() < 0.5 else None

    batches = []
    n_spheres, n_triangles, n_boxes, n_faces, n_planes = shape.counts
    for kind, total in (("spheres", n_spheres), ("triangles", n_triangles), ("boxes", n_boxes)):
        # One to three batches of a kind, so that world space and transformed groups both get some.
        for size in _split(rng, total):
            batches.append(_make_batch(rng, kind, size, scale, offset, transform()))
    if n_faces:
        batches.append(_make_batch(rng, "mesh", n_faces, scale, offset, transform()))
    for _ in range(n_planes):
        batches.append(_make_batch(rng, "plane", 1, scale, offset, transform()))
    rng.shuffle(batches)
    origins, directions, kinds = _make_rays(rng, shape.rays, batches, scale, offset)
    # A point cloud's spheres, one-sided (met from outside only), beside two-sided batches, drawn from
    # a stream of their own (every other draw as before). One flag a batch, as the export adds them:
    # a two-sided copy of a one-sided sphere, met at exactly the t a ray leaves the one-sided one, is
    # passed with it (docs/reliability.md).
    sides = np.random.default_rng([shape.seed, 1])
    for batch in batches:
        if batch.kind == "spheres" and sides.random() < 0.4:
            batch.arrays["one_sided"] = np.ones(batch.size(), bool)
    options: dict[str, Any] = {"precision": shape.precision, "sphere_method": shape.sphere_method}
    if shape.ray_range == "line":
        options["t_min"] = -math.inf
    elif shape.ray_range == "window":
        options["t_min"], options["t_max"] = sorted(float(x) for x in scale * 10.0 ** rng.uniform(-3, 3, 2))
    elif shape.ray_range == "surface":
        options["t_min"] = 5e-324
    return Case(batches, origins, directions, options, kinds)


def _split(rng: np.random.Generator, total: int) -> list[int]:
    if total == 0:
        return []
    cuts = np.sort(rng.integers(0, total + 1, rng.integers(0, 3)))
    return [int(s) for s in np.diff(np.concatenate([[0], cuts, [total]])) if s > 0]


def _unit(rng: np.random.Generator, n: int | None = None) -> np.ndarray:
    v = rng.normal(size=(3,) if n is None else (n, 3))
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _random_transform(rng: np.random.Generator, scale: float, offset: Any) -> np.ndarray:
    """A world-from-object affine map: rotation, scale (uniform, non-uniform or sheared) about the
    scene's centre, then a shift of up to the scene's size: a transformed batch stays near the rest."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    rotation = q * np.sign(np.diag(r))
    style = rng.integers(3)
    if style == 0:
        linear = rotation * 10.0 ** rng.uniform(-1, 1)
    elif style == 1:
        linear = rotation @ np.diag(10.0 ** rng.uniform(-1, 1, 3))
    else:
        linear = rotation @ (np.eye(3) + np.triu(rng.uniform(-1, 1, (3, 3)), 1))
    center = np.zeros(3) + offset
    return np.column_stack([linear, center - linear @ center + scale * rng.uniform(-0.5, 0.5, 3)])


def _sizes(rng: np.random.Generator, n: int, scale: float) -> np.ndarray:
    """Primitive sizes from tiny to overlapping: log-uniform over three decades below scale/4."""
    return scale * 10.0 ** rng.uniform(-3.5, -0.6, n)


def _make_batch(rng: np.random.Generator, kind: str, n: int, scale: float, offset: Any,
                transform: np.ndarray | None) -> Batch:
    """Primitives in a cube of side `scale` at `offset` (object space: a transformed batch lands near
    the transform's image of that cube, which has the same scale and a shifted centre)."""
    materials = rng.integers(0, len(MATERIALS) + 1, n).astype(np.int32)
    centers = offset + scale * rng.uniform(-0.5, 0.5, (n, 3))
    layout = rng.random()
    if layout < 0.2:  # a cluster: many primitives in a small region (deep, overlapping nodes)
        centers = offset + scale * (0.02 * rng.normal(size=(n, 3)))
    elif layout < 0.35:  # a lattice: equal centroids along axes, boxes sharing faces, rays along rows
        side = max(1, round(n ** (1 / 3)))
        centers = offset + scale / side * (rng.integers(0, side, (n, 3)) - side / 2)
    if kind == "spheres":
        radii = _sizes(rng, n, scale)
        if rng.random() < 0.15:  # copies: spheres repeated exactly, met at the same t in every cell they share
            copies = rng.integers(0, n, (2, n // 3))
            centers[copies[1]], radii[copies[1]] = centers[copies[0]], radii[copies[0]]
        return Batch(kind, {"centers": centers, "radii": radii}, materials, transform)
    if kind == "boxes":
        half = _sizes(rng, n, scale)[:, None] * rng.uniform(0.05, 1, (n, 3))
        if layout >= 0.2 and layout < 0.35:  # lattice cells: neighbours share faces exactly
            half = np.full((n, 3), scale / max(1, round(n ** (1 / 3))) / 2)
        lo, hi = centers - half, centers + half
        hi = np.maximum(hi, np.nextafter(lo, np.inf))  # far from the origin a tiny box rounds to nothing
        return Batch(kind, {"lo": lo, "hi": hi}, materials, transform)
    if kind == "triangles":
        vertices = centers[:, None, :] + _sizes(rng, n, scale)[:, None, None] * rng.normal(size=(n, 3, 3))
        flat = rng.random(n) < 0.2  # in an axis plane: a box of zero thickness around it
        axes = rng.integers(3, size=n)
        vertices[flat, :, axes[flat]] = vertices[flat, :1, axes[flat]]
        degenerate = rng.random(n) < 0.05  # kept, never hit
        vertices[degenerate, 2] = vertices[degenerate, 0] + 0.5 * (vertices[degenerate, 1] - vertices[degenerate, 0])
        return Batch(kind, {"vertices": vertices}, materials, transform)
    if kind == "mesh":
        return Batch(kind, _make_mesh(rng, n, scale, offset), materials[:1], transform)
    normal = _unit(rng)
    if rng.random() < 0.3:  # axis-aligned: rays along it graze it
        normal = np.eye(3)[rng.integers(3)] * rng.choice([-1.0, 1.0])
    point = offset + scale * rng.uniform(-0.5, 0.5, 3)
    bounds = None  # unbounded: the plane through `point`
    if rng.random() < 0.6:
        edge1 = np.cross(normal, _unit(rng))
        edge2 = np.cross(normal, edge1) * rng.uniform(0.2, 2)
        bounds = (point - 0.5 * scale * edge1, scale * edge1, scale * edge2)
        point = bounds[0]
    return Batch(kind, {"normal": normal, "offset": float(normal @ point), "bounds": bounds}, materials[:1], transform)


def _make_mesh(rng: np.random.Generator, faces: int, scale: float, offset: Any) -> dict[str, np.ndarray]:
    """A closed, watertight surface: a bumpy sphere triangulated as a latitude-longitude grid with
    at least `faces` faces (cut down to `faces`; shared edges and vertices everywhere)."""
    rows = max(2, int(math.sqrt(faces / 2)))
    cols = max(3, -(-faces // (2 * rows)))
    theta = np.linspace(0, math.pi, rows + 1)[1:-1]
    phi = np.linspace(0, 2 * math.pi, cols, endpoint=False)
    grid = np.stack(np.meshgrid(theta, phi, indexing="ij"), -1).reshape(-1, 2)
    directions = np.column_stack([np.sin(grid[:, 0]) * np.cos(grid[:, 1]), np.sin(grid[:, 0]) * np.sin(grid[:, 1]),
                                  np.cos(grid[:, 0])])
    unit = np.vstack([directions, [[0, 0, 1], [0, 0, -1]]])
    radius = scale * rng.uniform(0.05, 0.3) * (1 + 0.2 * rng.uniform(-1, 1, len(unit)))
    vertices = offset + scale * rng.uniform(-0.3, 0.3, 3) + radius[:, None] * unit
    top, bottom = len(unit) - 2, len(unit) - 1
    index = np.arange(len(directions)).reshape(rows - 1, cols)
    tris = []
    for c in range(cols):
        c2 = (c + 1) % cols
        tris.append((top, index[0, c], index[0, c2]))
        tris.append((bottom, index[-1, c2], index[-1, c]))
        for r in range(rows - 2):
            tris.append((index[r, c], index[r + 1, c], index[r + 1, c2]))
            tris.append((index[r, c], index[r + 1, c2], index[r, c2]))
    return {"vertices": vertices, "faces": np.array(tris[:faces], dtype=np.int64)}


def _targets(rng: np.random.Generator, batches: list[Batch], n: int) -> tuple[np.ndarray, np.ndarray]:
    """n world-space points on primitives (and a tangent direction at each, for grazing rays):
    sphere surface points with a tangent, box faces with a direction in the face, triangle edges
    and vertices with the edge's direction, plane points with a direction in the plane."""
    points, tangents = np.zeros((n, 3)), np.zeros((n, 3))
    sized = [b for b in batches if b.size()]
    for j in range(n):
        batch = sized[rng.integers(len(sized))]
        i = int(rng.integers(batch.size()))
        a = batch.arrays
        if batch.kind == "spheres":
            normal = _unit(rng)
            p = a["centers"][i] + a["radii"][i] * normal
            t = np.cross(normal, _unit(rng))
        elif batch.kind == "boxes":
            lo, hi = a["lo"][i], a["hi"][i]
            axis = rng.integers(3)
            p = rng.uniform(lo, hi)
            p[axis] = (lo if rng.random() < 0.5 else hi)[axis]
            t = _unit(rng)
            t[axis] = 0
            if rng.random() < 0.5:  # along an edge or the face's axes
                t = np.eye(3)[(axis + 1 + rng.integers(2)) % 3]
        elif batch.kind in ("triangles", "mesh"):
            v = a["vertices"][i] if batch.kind == "triangles" else a["vertices"][a["faces"][i]]
            k = rng.integers(3)
            s = rng.choice([0.0, 1.0, rng.uniform(), 0.5])
            p = v[k] + s * (v[(k + 1) % 3] - v[k])
            t = v[(k + 1) % 3] - v[k]
        else:
            normal = a["normal"] / np.linalg.norm(a["normal"])
            if a["bounds"] is not None:
                corner, e1, e2 = a["bounds"]
                p = corner + rng.choice([0.0, 1.0, rng.uniform()]) * e1 + rng.uniform() * e2
            else:  # the point nearest the origin, moved along the plane
                p = normal * a["offset"] + np.cross(normal, _unit(rng)) * rng.uniform(0, 1)
            t = np.cross(normal, _unit(rng))
        if batch.transform is not None:
            p = batch.transform[:, :3] @ p + batch.transform[:, 3]
            t = batch.transform[:, :3] @ t
        points[j], tangents[j] = p, t
    return points, tangents


def _make_rays(rng: np.random.Generator, n: int, batches: list[Batch], scale: float,
               offset: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """n rays, each of a random RAY_KINDS kind, their origins inside the scene's cube or outside it
    (up to a few sizes away). Directions have lengths from 1e-3 to 1e3."""
    center = np.zeros(3) + offset
    kinds = rng.integers(len(RAY_KINDS), size=n)
    if not any(b.size() for b in batches):
        kinds[kinds >= 2] = 1
    origins = center + scale * rng.uniform(-2, 2, (n, 3)) * np.where(rng.random((n, 1)) < 0.5, 0.5, 1)
    directions = rng.normal(size=(n, 3))
    fan = kinds == 0
    if fan.any():  # a camera: one origin, directions through a grid over the scene's cube
        eye = center + scale * 2.5 * _unit(rng)
        if rng.random() < 0.3:
            eye = center + scale * 0.2 * _unit(rng)  # inside the scene
        m = int(fan.sum())
        side = max(1, int(math.ceil(math.sqrt(m))))
        u, v = np.meshgrid(np.linspace(-0.6, 0.6, side), np.linspace(-0.6, 0.6, side))
        forward = center - eye if np.linalg.norm(center - eye) > 0 else _unit(rng)
        right = np.cross(forward, _unit(rng))
        up = np.cross(right, forward) / np.linalg.norm(forward)
        grid = forward + u.ravel()[:m, None] * right + v.ravel()[:m, None] * up
        origins[fan], directions[fan] = eye, grid
    leaving = kinds == 5
    if leaving.any():  # from a point on a primitive, any direction: half leave it, half go through
        origins[leaving] = _targets(rng, batches, int(leaving.sum()))[0]
    aimed = (kinds == 2) | (kinds == 3)
    if aimed.any():
        points, tangents = _targets(rng, batches, int(aimed.sum()))
        grazing = kinds[aimed] == 3
        start = origins[aimed]
        lengths = np.linalg.norm(tangents[grazing], axis=1, keepdims=True)
        unit_tangents = tangents[grazing] / np.where(lengths > 0, lengths, 1)
        start[grazing] = points[grazing] - unit_tangents * scale * rng.uniform(0.05, 2, (int(grazing.sum()), 1))
        along = points - start
        along[grazing] = tangents[grazing]
        origins[aimed], directions[aimed] = start, along
    axis = kinds == 4
    if axis.any():  # axis-parallel: two zero components (infinite slab reciprocals)
        signs = rng.choice([-1.0, 1.0], int(axis.sum()))
        directions[axis] = np.eye(3)[rng.integers(3, size=int(axis.sum()))] * signs[:, None]
    directions *= 10.0 ** rng.uniform(-3, 3, (n, 1))
    zero = ~np.any(directions != 0, axis=1)
    directions[zero] = (1.0, 0.0, 0.0)
    return origins, directions, kinds


# --- running -------------------------------------------------------------------------------------
@dataclass
class Tally:
    """What a fuzz run tried."""

    cases: int = 0
    primitives: int = 0
    rays: int = 0  # rays of the full scenes
    casts: int = 0  # rays cast in all, the brute force's included
    hits: int = 0
    wins: Counter[str] = field(default_factory=Counter)  # hits by primitive kind ("... transformed")
    grazing_hits: int = 0
    precisions: Counter[str] = field(default_factory=Counter)  # cases by precision

    def record(self, case: Case, full: durer.CastResult) -> None:
        hit = full.object_id >= 0
        self.cases += 1
        self.primitives += case.primitive_count()
        self.rays += len(case.origins)
        self.casts += len(case.origins) * (1 + case.primitive_count())
        self.hits += int(hit.sum())
        labels = [b.kind + (" transformed" if b.transform is not None else "") for b in case.batches
                  for _ in range(b.objects())]
        self.wins.update(labels[i] for i in full.object_id[hit])
        self.grazing_hits += int((hit & (case.ray_kinds == RAY_KINDS.index("grazing"))).sum())
        self.precisions[case.options["precision"]] += 1

    def __str__(self) -> str:
        return (f"{self.cases} cases, {self.primitives} primitives, {self.rays} rays ({self.hits} hits, "
                f"{self.grazing_hits} of them grazing), {self.casts} rays cast with the brute force's; "
                f"hits by kind: {dict(sorted(self.wins.items()))}")


class Difference(AssertionError):
    """A case whose accelerated hits differ from the brute force's."""

    def __init__(self, case: Case, message: str) -> None:
        super().__init__(message)
        self.case = case


def fuzz(cfg: Any, tally: Tally, max_primitives: int = 300, seed: int | None = None) -> None:
    """Runs hypothesis with settings `cfg` (and `seed`, if given) over `shapes(max_primitives)`; on a
    difference raises an AssertionError holding the reduced case's description and its reproduction
    script."""
    import hypothesis

    @cfg
    @hypothesis.given(shapes(max_primitives))
    def one(shape: Shape) -> None:
        case = make_case(shape)
        bad, message, full = judge(case)
        tally.record(case, full)
        if len(bad):
            raise Difference(case, f"{shape}\n{message}")

    if seed is not None:
        one = hypothesis.seed(seed)(one)
    try:
        one()
    except Difference as found:  # hypothesis's shrunk case, made smaller still
        reduced = reduce_case(found.case)
        raise AssertionError(f"{found}\n\nReduced to {reduced.primitive_count()} primitives and "
                             f"{len(reduced.origins)} rays:\n{compare(reduced)}\n\n"
                             f"Reproduction (run from the repository root):\n\n{reduced.source()}") from None
