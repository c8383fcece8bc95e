"""Type stubs of the C++ binding. Use the `durer` package: it checks shapes and types first."""

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

_Triple = tuple[float, float, float]

# Option names, in the core's order (cpp/include/durer/Options.h).
KERNEL_SET: str  # the instruction set of the hot kernels this CPU runs: "x86-64-v4", "x86-64-v3", "x86-64-v2", "native" or "generic"
PRECISIONS: tuple[str, ...]  # ("float", "double")
SPHERE_METHODS: tuple[str, ...]  # ("algebraic", "geometric", "robust")
SAMPLERS: tuple[str, ...]  # ("center", "random", "stratified", "sobol", "adaptive")
PASSES: tuple[str, ...]  # ("color", "depth", "normal", "object_id", "material_id")
DEFAULT_PASSES: tuple[str, ...]  # ("color", "depth", "normal")
DEPTHS: tuple[str, ...]  # ("ray", "planar")
PROJECTIONS: tuple[str, ...]  # ("orthographic", "perspective")
FITS: tuple[str, ...]  # ("auto", "horizontal", "vertical")
SHADING_MODES: tuple[str, ...]  # ("auto", "flat", "lit")
# (name, components, default) per field of Material, in its order (cpp/include/durer/Material.h):
# default is a tuple of floats for a colour (3 components), a float for a scalar (1).
MATERIAL_FIELDS: tuple[tuple[str, int, tuple[float, float, float] | float], ...]
# The accepted numbers per precision (Limits.h, docs/numerics.md): {"float": {"coordinate": 1e18, "color": 1e18}, ...}
LIMITS: dict[str, dict[str, float]]
RENDER_LIMITS: dict[str, int]
# A reflective material's Phong exponent from which its highlight is the mirror's glint (Material.h):
# area lights are left to the mirror direction.
MIRROR_GLINT_EXPONENT: float

class CameraSpec:
    def __init__(
        self, projection: str, center: _Triple, direction: _Triple, up: _Triple, size: float, fit: str,
        shift_x: float, shift_y: float, pixel_aspect: float, t_min: float, t_max: float, clip_planes: bool = False,
        aperture_radius: float = 0.0, focus_distance: float = 1.0, aperture_blades: int = 0,
        aperture_rotation: float = 0.0, aperture_ratio: float = 1.0,
    ) -> None: ...

class Scene:
    def __init__(self) -> None: ...
    def add_material(self, **fields: _Triple | float) -> int: ...  # named as MATERIAL_FIELDS; others default
    def add_spheres(
        self, centers: NDArray[np.float64], radii: NDArray[np.float64], materials: NDArray[np.int32],
        transform: NDArray[np.float64] | None, colors: NDArray[np.float64] | None = None,
        one_sided: NDArray[np.uint8] | None = None,
    ) -> int: ...
    @property
    def hierarchy_counts(self) -> dict[str, float]: ...
    def move_spheres(
        self, ids: NDArray[np.int32], centers: NDArray[np.float64], radii: NDArray[np.float64] | None
    ) -> None: ...
    def add_plane(
        self, normal: _Triple, offset: float, material: int, bounds: Sequence[_Triple] | None,
        transform: NDArray[np.float64] | None,
    ) -> int: ...
    def add_triangles(
        self, vertices: NDArray[np.float64], materials: NDArray[np.int32], transform: NDArray[np.float64] | None,
        colors: NDArray[np.float64] | None = None,
    ) -> int: ...
    def add_mesh(
        self, vertices: NDArray[np.float64], faces: NDArray[np.int64], material: int,
        transform: NDArray[np.float64] | None, colors: NDArray[np.float64] | None = None,
        normals: NDArray[np.float64] | None = None,
    ) -> int: ...
    def add_mesh_instances(
        self, vertices: NDArray[np.float64], faces: NDArray[np.int64], material: int,
        transforms: NDArray[np.float64], colors: NDArray[np.float64] | None = None,
        instance_colors: NDArray[np.float64] | None = None, normals: NDArray[np.float64] | None = None,
    ) -> int: ...
    def add_boxes(
        self, lo: NDArray[np.float64], hi: NDArray[np.float64], materials: NDArray[np.int32],
        transform: NDArray[np.float64] | None, colors: NDArray[np.float64] | None = None,
    ) -> int: ...
    def add_directional_light(
        self, direction: _Triple, color: _Triple, shadows: bool, half_angle: float, samples: int, soft: bool,
    ) -> None: ...
    def add_point_light(
        self, position: _Triple, color: _Triple, attenuation: _Triple, shadows: bool, radius: float, samples: int,
        soft: bool,
    ) -> None: ...
    def add_spot_light(
        self, position: _Triple, direction: _Triple, color: _Triple, attenuation: _Triple, cos_half_angle: float,
        blend: float, shadows: bool, radius: float, samples: int, soft: bool,
    ) -> None: ...
    def add_area_light(
        self, position: _Triple, u: _Triple, v: _Triple, color: _Triple, ellipse: bool, samples: int, shadows: bool,
    ) -> None: ...
    shading: str
    background: tuple[float, float, float, float]
    ambient: _Triple
    @property
    def sphere_count(self) -> int: ...
    @property
    def plane_count(self) -> int: ...
    @property
    def triangle_count(self) -> int: ...
    @property
    def stored_triangle_count(self) -> int: ...
    @property
    def box_count(self) -> int: ...
    @property
    def transform_count(self) -> int: ...
    @property
    def material_count(self) -> int: ...
    @property
    def object_count(self) -> int: ...
    @property
    def light_count(self) -> int: ...

def render(
    scene: Scene, camera: CameraSpec, width: int, height: int, spp: int, seed: int, sampler: str,
    target_error: float, min_spp: int, time_limit: float, precision: str,
    sphere_method: str, passes: Sequence[str], depth: str, threads: int, shade_back: bool, max_bounces: int,
    min_weight: float, ambient_occlusion: tuple[int, float] | None, poll: Callable[[float], bool],
    out: dict[str, NDArray[np.float32] | NDArray[np.int32] | None], region: tuple[int, int, int, int],
) -> dict[str, object]: ...
def cast(
    scene: Scene, origins: NDArray[np.float64], directions: NDArray[np.float64], t_min: float, t_max: float,
    precision: str, sphere_method: str, threads: int, poll: Callable[[float], bool], any_hit: bool,
) -> dict[str, object]: ...  # any_hit: t of the first hit found (inf: none), and no normal or ids
def camera_rays(camera: CameraSpec, width: int, height: int, precision: str) -> tuple[NDArray[np.floating], NDArray[np.floating]]: ...
def default_thread_count() -> int: ...
def is_invertible(matrix: NDArray[np.float64]) -> bool: ...  # a (3, 4) affine matrix, by the core's one rule
def are_invertible(matrices: NDArray[np.float64]) -> NDArray[np.bool_]: ...
