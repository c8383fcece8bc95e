"""The 3D view's Rendered mode: Dürer's image of the view, refined pass by pass off the main thread.

`view_camera` turns a view's matrices into a Dürer camera, `ProgressiveImage` keeps the running
mean of one-sample passes, `ViewportSession` ties them to the exported scene, and `view_update` /
`view_draw` are what the engine's hooks of the same names call (Blender calls both on its main
thread; only `texture` and `draw` need a GPU, which bpy in background mode has not).
"""

from __future__ import annotations

import threading
from dataclasses import asdict, replace
from typing import Any

import gpu
import numpy as np
from gpu_extras.presets import draw_texture_2d

import durer

from . import build, engine  # engine imports this module too: used at call time only
from .export import LensData, lens_data
from .export.depsgraph import export_depsgraph

#: The sampler of every pass: one uniformly random sample per pixel, independent between seeds, so
#: the running mean is an unbiased N-sample estimate of the box-filtered pixel (what any sampler's
#: F12 render converges to), its error falling as 1/√N.
PASS_SAMPLER = "random"


def view_camera(view_matrix: Any, window_matrix: Any, is_perspective: bool, width: int, height: int,
                lens: LensData | None = None) -> durer.OrthographicCamera | durer.PerspectiveCamera:
    """The Dürer camera whose width x height image is what OpenGL shows through these matrices
    (Blender's RegionView3D.view_matrix, world -> view, and window_matrix, view -> clip), through
    `lens` (default: a pinhole).

    Works alike for the perspective and orthographic views and the camera view, whose window matrix
    holds the scene camera's lens, sensor fit, shift and the view's camera zoom and offset. The
    frustum may be off-centre (a shift): its window becomes Dürer's `shift`. Clipping follows the
    near and far planes (for perspective as planes across the view axis, as the F12 camera and Cycles
    clip)."""
    view = np.array(view_matrix, dtype=np.float64).reshape(4, 4)
    win = np.array(window_matrix, dtype=np.float64).reshape(4, 4)
    to_world = np.linalg.inv(view)
    center = to_world[:3, 3]
    direction = -to_world[:3, 2] / np.linalg.norm(to_world[:3, 2])
    up = to_world[:3, 1] / np.linalg.norm(to_world[:3, 1])
    # The window's extent and centre: at unit distance (perspective) or in view units (orthographic).
    span_x, span_y = 2.0 / win[0, 0], 2.0 / win[1, 1]
    if is_perspective:
        mid_x, mid_y = win[0, 2] / win[0, 0], win[1, 2] / win[1, 1]
        # far/near beyond ~1.7e7 (a 6.837 scene's clip range) leaves float32's win[2, 2] at -1: no far plane.
        near = win[2, 3] / (win[2, 2] - 1.0)
        far = win[2, 3] / (win[2, 2] + 1.0) if win[2, 2] + 1.0 < 0.0 else np.inf
    else:
        mid_x, mid_y = -win[0, 3] / win[0, 0], -win[1, 3] / win[1, 1]
        near, far = (win[2, 3] + 1.0) / win[2, 2], (win[2, 3] - 1.0) / win[2, 2]
    common = {
        "fit": "horizontal",
        "shift": (mid_x / span_x, mid_y / span_x),
        "pixel_aspect": (span_y / height) / (span_x / width),
        "t_min": float(near),
        "t_max": float(far),
        **asdict(lens or LensData()),
    }
    center, direction, up = tuple(center), tuple(direction), tuple(up)
    if is_perspective:
        fov = float(np.degrees(2.0 * np.arctan(0.5 * span_x)))
        return durer.PerspectiveCamera(center, direction, up, fov_degrees=fov, clip_planes=True, **common)
    return durer.OrthographicCamera(center, direction, up, size=float(span_x), **common)


def region_camera(region_data, width: int, height: int,
                  lens: LensData | None = None) -> durer.OrthographicCamera | durer.PerspectiveCamera:
    """`view_camera` of a RegionView3D (`context.region_data`) drawn at width x height pixels."""
    return view_camera(region_data.view_matrix, region_data.window_matrix, region_data.is_perspective, width, height,
                       lens)


def camera_lens(cam_obj, depsgraph) -> LensData:
    """The depth of field of camera object `cam_obj` as evaluated in `depsgraph` (animated or driven
    settings as F12 renders them), which the camera view shows (its aperture and focus distance are
    world quantities: the view's zoom leaves them); none for no camera."""
    if cam_obj is None or cam_obj.type != "CAMERA":
        return LensData()
    return lens_data(cam_obj.evaluated_get(depsgraph))


def pass_kwargs(settings) -> dict:
    """durer.render's settings for a viewport pass, from scene.durer: the F12 render's precision,
    sphere method, threads, bounces and back-face shading; the sampling is the pass's own (ambient
    occlusion, an export's, is added by the session)."""
    kwargs = engine.render_kwargs(settings)
    for key in ("spp", "seed", "sampler", "target_error", "min_spp", "time_limit", "depth"):
        kwargs.pop(key, None)
    return kwargs


class ProgressiveImage:
    """The running mean of 1-sample passes (seeds seed, seed + 1, ...) of one view, rendered on a
    worker thread; `restart` cancels the passes under way (within the core's 0.1 s) and begins anew."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._cancel = threading.Event()
        self._worker: threading.Thread | None = None
        self._mean: np.ndarray | None = None
        self._passes = 0
        self._generation = 0
        #: The error that ended the last passes early (None if none did).
        self.error: str | None = None

    @property
    def passes(self) -> int:
        """How many passes the mean holds."""
        return self._passes

    @property
    def generation(self) -> int:
        """How many times the image was restarted: (generation, passes) names the mean."""
        return self._generation

    @property
    def running(self) -> bool:
        """Whether passes are still being rendered."""
        return self._worker is not None and self._worker.is_alive()

    def mean(self) -> np.ndarray | None:
        """The image so far, (H, W, 4) float32 RGBA, top row first (read-only); None before the
        first pass. The worker makes it after each pass, so the main thread only reads it."""
        return self._mean

    def restart(self, scene: durer.Scene, camera, width: int, height: int, passes: int, seed: int = 0,
                **kwargs: Any) -> None:
        """Forget the image and render `passes` passes of `scene` through `camera` (more durer.render
        settings in kwargs)."""
        self.stop()
        with self._lock:
            self._mean, self._passes, self.error = None, 0, None
            self._generation += 1
        self._cancel = threading.Event()
        self._worker = threading.Thread(
            target=self._run, args=(self._cancel, scene, camera, width, height, passes, seed, kwargs),
            name="durer-viewport", daemon=True)
        self._worker.start()

    def stop(self) -> None:
        """Cancel the passes under way and wait for the worker (the core stops within 0.1 s)."""
        self._cancel.set()
        if self._worker is not None:
            self._worker.join()
            self._worker = None

    def wait(self, timeout: float | None = None) -> bool:
        """Wait up to `timeout` seconds for the passes to finish; whether they have."""
        if self._worker is not None:
            self._worker.join(timeout)
        return not self.running

    def _run(self, cancel: threading.Event, scene, camera, width, height, passes, seed, kwargs) -> None:
        result, total = None, None
        for index in range(passes):
            try:
                result = durer.render(scene, camera, width, height, spp=1, seed=seed + index, sampler=PASS_SAMPLER,
                                      passes=("color",), cancel=cancel, out=result, **kwargs)
            except durer.RenderCancelled:
                return
            except Exception as exc:  # noqa: BLE001 - shown by the viewport, never raised in Blender
                self.error = f"{type(exc).__name__}: {exc}"
                return
            if total is None:
                total = result.color.astype(np.float64)
            else:
                total += result.color
            mean = (total / (index + 1)).astype(np.float32)
            mean.flags.writeable = False
            with self._lock:
                if cancel.is_set():
                    return
                self._mean, self._passes = mean, index + 1


class ViewportSession:
    """One Rendered-mode viewport: the scene exported by `update` and the progressive image of the
    view `view` is given, restarted when either changes."""

    def __init__(self) -> None:
        self.image = ProgressiveImage()
        self._kept: tuple | None = None  # (export data, core scene), for build.update_scene
        self._settings: dict = {}
        self._view_key: tuple | None = None
        self._lens = LensData()  # the scene camera's, for the camera view
        #: The GPU texture last drawn, and its `frame` key.
        self.texture = None
        self.texture_key: tuple | None = None
        #: What the view shows instead of an image (an export error), or None.
        self.error: str | None = None

    @property
    def scene(self) -> durer.Scene | None:
        """The core scene the passes render (None before an export, or after one failed)."""
        return None if self._kept is None else self._kept[1]

    def update(self, depsgraph) -> None:
        """Export the depsgraph (Blender's view_update: something in the file changed); the next
        `view` restarts if what Dürer renders or its settings changed (the scene camera aside: the
        view is the camera). A core scene whose spheres alone moved is refitted, not rebuilt."""
        try:
            data = export_depsgraph(depsgraph, with_camera=False)
            self._lens = camera_lens(depsgraph.scene.camera, depsgraph)  # a change restarts the camera view's image
            settings = {"passes": int(depsgraph.scene.durer.samples), "seed": int(depsgraph.scene.durer.seed),
                        "ambient_occlusion": data.ambient_occlusion, **pass_kwargs(depsgraph.scene.durer)}
            if (self._kept is not None and settings == self._settings
                    and build.same_data(replace(self._kept[0], camera=data.camera), data)):
                return  # a selection, or the scene camera seen from another view: the passes go on
            self.image.stop()  # before update_scene moves the spheres of the scene the passes render
            scene, _ = build.update_scene(self._kept, data)
        except Exception as exc:  # noqa: BLE001 - shown by the viewport, never raised in Blender
            self.image.stop()
            self._kept, self.error = None, f"{type(exc).__name__}: {exc}"
            return
        self._kept, self._settings, self.error = (data, scene), settings, None
        self._view_key = None

    def view(self, region_data, width: int, height: int, lens: LensData | None = None) -> bool:
        """Show this view (a RegionView3D drawn at width x height): restart the image if the view's
        matrices or size changed since the last call, or the scene since `update` (in the camera
        view, its camera's depth of field too: `lens`, the scene camera's if None); whether it did."""
        if self._kept is None:
            return False
        if region_data.view_perspective != "CAMERA":
            lens = LensData()
        elif lens is None:
            lens = self._lens
        key = (tuple(map(tuple, region_data.view_matrix)), tuple(map(tuple, region_data.window_matrix)),
               bool(region_data.is_perspective), width, height, lens)
        if key == self._view_key:
            return False
        self._view_key = key
        try:
            camera = region_camera(region_data, width, height, lens)
        except ValueError as exc:  # a view the core cannot take: said in the stats line, never raised in Blender
            self.image.stop()
            self.error = f"{type(exc).__name__}: {exc}"
            return False
        self.error = None
        self.image.restart(self.scene, camera, width, height, **self._settings)
        return True

    def frame(self) -> tuple[tuple, np.ndarray | None]:
        """What the view shows, with a key that changes whenever it does: the image so far, or
        nothing while an export error stands."""
        if self.error is not None:
            return ("error",), None
        return (self.image.generation, self.image.passes), self.image.mean()

    def status(self) -> str:
        """The stats line: passes done of the total, or the error."""
        error = self.error or self.image.error
        if error is not None:
            return f"Dürer | error: {error}"
        total = self._settings.get("passes", 0)
        state = "" if self.image.running else " | done"
        return f"Dürer | viewport | sample {self.image.passes}/{total}{state}"


def session(render_engine) -> ViewportSession:
    """The engine instance's viewport session (made on first use)."""
    found = getattr(render_engine, "durer_viewport", None)
    if found is None:
        found = render_engine.durer_viewport = ViewportSession()
    return found


def view_update(render_engine, depsgraph) -> None:
    """RenderEngine.view_update: the scene changed."""
    session(render_engine).update(depsgraph)


def view_draw(render_engine, context, depsgraph) -> None:
    """RenderEngine.view_draw: draw the image of the current view, and ask for another draw while
    passes are under way (Blender has no other way to hear of them on its main thread). The mean is
    uploaded only when it holds new passes."""
    current = session(render_engine)
    region = context.region
    space = context.space_data  # a 3D view with a Local Camera shows that camera in its camera view
    local = space.camera if getattr(space, "use_local_camera", False) else None
    current.view(context.region_data, region.width, region.height,
                 None if local is None else camera_lens(local, depsgraph))
    render_engine.update_stats("", current.status())
    if current.image.running:
        render_engine.tag_redraw()
    key, pixels = current.frame()
    if key != current.texture_key:
        current.texture = None if pixels is None else texture(pixels)
        current.texture_key = key
    if current.texture is not None:
        draw(render_engine, depsgraph.scene, current.texture)


def texture(pixels_top_first: np.ndarray):
    """A float GPU texture of (H, W, 4) RGBA pixels (Blender's rows bottom first)."""
    h, w = pixels_top_first.shape[:2]
    data = gpu.types.Buffer("FLOAT", w * h * 4, engine._flip(pixels_top_first).ravel())
    return gpu.types.GPUTexture((w, h), format="RGBA16F", data=data)


def draw(render_engine, scene, image_texture) -> None:
    """Draw the texture over the region in the scene's display colour space (Blender's custom render
    engine template)."""
    gpu.state.blend_set("ALPHA_PREMULT")
    render_engine.bind_display_space_shader(scene)
    draw_texture_2d(image_texture, (0, 0), image_texture.width, image_texture.height)
    render_engine.unbind_display_space_shader()
    gpu.state.blend_set("NONE")


def free(render_engine) -> None:
    """The engine is being freed (leaving Rendered mode): stop its passes."""
    try:
        found = getattr(render_engine, "durer_viewport", None)
    except ReferenceError:  # Blender freed the engine's data first: its Python attributes went with it
        return
    if found is not None:
        found.image.stop()
