"""The Dürer render engine (``bl_idname = "DURER"``): what Blender's Render button runs."""

from __future__ import annotations

import json
import threading
import time
from dataclasses import dataclass, field

import bpy
import numpy as np

import durer

from . import build, viewport
from .export.depsgraph import export_depsgraph

#: Name of the float Image datablock that holds the Combined pixels after every render.
IMAGE_NAME = "Dürer Render"
#: How often the engine polls Blender's cancel flag (Esc) while Dürer renders, in seconds.
POLL_SECONDS = 0.02
#: Ctrl-C during a batch (batch.render_file's SIGINT handler sets it): the render stops at its next
#: poll and ends as interrupted, as a KeyboardInterrupt would end it but at no arbitrary point.
interrupt = threading.Event()
#: The image metadata field (an EXR header attribute, a PNG text chunk) that holds the Object ID
#: pass's table: JSON {"id": "object name", ...}, as last_render.object_ids.
OBJECT_IDS_FIELD = "durer.object_ids"


@dataclass
class RenderInfo:
    """What the last render did (``durer.blender.engine.last_render``), for scripts and tests."""

    width: int = 0
    height: int = 0
    samples: int = 0
    stats: dict = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    error: str | None = None
    cancelled: bool = False
    #: Ctrl-C reached the render (a command-line batch): Blender swallows the KeyboardInterrupt, so
    #: the batch reads it here and stops.
    interrupted: bool = False
    export_seconds: float = 0.0
    render_seconds: float = 0.0
    spheres: int = 0  # world-space spheres and ellipsoids
    planes: int = 0
    triangles: int = 0
    #: Whether the last frame's core scene was reused (what moved in it moved, the hierarchy refitted):
    #: with Persistent Data on, when only sphere positions, radii and the camera changed, or nothing.
    reused_scene: bool = False
    #: The last text the engine showed in Blender's stats line.
    stats_line: str = ""
    #: Adaptive sampler: the samples each pixel got, (H, W) int32, top row first (the core's
    #: result.samples over the whole frame); None for the fixed samplers.
    sample_counts: np.ndarray | None = None
    #: The Object ID pass's table (build.object_numbers), the same on every frame of a file: id -> the
    #: object's unique name (`name_full`), for every object numbered, rendered or not; empty
    #: without the pass.
    object_ids: dict[int, str] = field(default_factory=dict)


def stats_line(width: int, height: int, samples: int, stats: dict, cancelled: bool = False,
               reused: bool = False) -> str:
    """Blender's stats line after a render: size, samples and sampler (for Adaptive, the maximum and
    the mean a pixel got, and the RMS error it estimates), the effects Dürer simulated (the core
    derives them from the scene: flat, diffuse, specular, shadows, reflection, refraction, ambient
    occlusion with its samples), speed, and whether the last frame's core scene was reused (what moved
    in it refitted: update_scene)."""
    sampler = stats.get("sampler")
    total = stats.get("samples")
    if sampler == "adaptive":
        spp = f"adaptive ≤ {samples} spp"
        if isinstance(total, int) and width * height > 0:
            spp += f" (mean {total / (width * height):.1f})"
    elif sampler:
        spp = f"{samples} spp {sampler}"
    else:
        spp = f"{samples} spp"
    parts = [f"Dürer | {width}x{height} | {spp}"]
    effects = stats.get("effects")
    if effects is not None:
        occlusion = stats.get("ambient_occlusion")
        named = [f"AO {occlusion[0]}" if e == "ambient_occlusion" and occlusion else e for e in effects]
        parts.append(" + ".join(named) if len(named) else "depth only")
    estimate = stats.get("estimated_rmse")
    if isinstance(estimate, float):
        parts.append(f"est. error {estimate:.1e}" + (" (time limit)" if stats.get("time_limit_reached") else ""))
    mrays = stats.get("mrays_per_s")
    if isinstance(mrays, (int, float)):
        parts.append(f"{mrays:.1f} Mrays/s" if mrays >= 0.1 else f"{mrays:.2g} Mrays/s")  # a big export, a tiny image
    if reused:
        parts.append("last frame's scene reused")
    if cancelled:
        parts.append("cancelled")
    return " | ".join(parts)


last_render = RenderInfo()
#: The last render's exported data and core scene, by Blender scene and view layer names, kept while
#: that scene's Render › Performance › Persistent Data is on (as Cycles keeps its data between
#: renders); each view layer its own (one scene kept for all, every layer rebuilt the other's).
persistent: dict[tuple[str, str], tuple] = {}
#: Callables given the finished fraction while Dürer renders (batch progress bars use this).
progress_hooks: list = []


#: Blender's index passes (Blender 5 names IndexOB and IndexMA "Object Index" and "Material Index",
#: as Cycles writes them) and Dürer's Object ID: (pass name, whether view layer `layer` asks for it,
#: the core pass it is made from, the build.IdTables table that maps the core's ids to it).
INDEX_PASSES = (
    ("Object Index", lambda layer: layer.use_pass_object_index, "object_id", "object_pass_index"),
    ("Material Index", lambda layer: layer.use_pass_material_index, "material_id", "material_pass_index"),
    ("Object ID", lambda layer: layer.durer.use_pass_object_id, "object_id", "object_number"),
)


#: The passes beyond Combined that Dürer writes, by Blender's name: the core pass each is made
#: from, and its channels (RenderEngine.register_pass's layout).
PASS_LAYOUTS = {"Depth": ("depth", 1, "Z", "VALUE"), "Normal": ("normal", 3, "XYZ", "VECTOR")} | {
    name: (core, 1, "X", "VALUE") for name, _, core, _ in INDEX_PASSES}


def layer_passes(layer) -> list[str]:
    """The passes beyond Combined that view layer `layer` asks for, by Blender's names."""
    asked = [name for name, on in (("Depth", layer.use_pass_z), ("Normal", layer.use_pass_normal)) if on]
    return asked + [name for name, wanted, _, _ in INDEX_PASSES if wanted(layer)]


def _wait_through_interrupts(done: threading.Event) -> None:
    """Wait until `done` is set, whatever further Ctrl-Cs come meanwhile."""
    while True:
        try:
            done.wait()
            return
        except KeyboardInterrupt:
            continue


def _flip(rows_top_first: np.ndarray) -> np.ndarray:
    """Dürer images are top row first, Blender's bottom row first."""
    return np.ascontiguousarray(rows_top_first[::-1], dtype=np.float32)


def store_image(pixels_rgba_top_first: np.ndarray, name: str = IMAGE_NAME):
    """Put the pixels in a float, linear Image datablock `name` (created or resized) and return it."""
    h, w = pixels_rgba_top_first.shape[:2]
    image = bpy.data.images.get(name)
    if image is not None and (tuple(image.size) != (w, h) or not image.is_float):
        bpy.data.images.remove(image)
        image = None
    if image is None:
        image = bpy.data.images.new(name, w, h, alpha=True, float_buffer=True)
    try:
        image.colorspace_settings.is_data = False
        image.colorspace_settings.name = "Linear Rec.709"
    except TypeError:  # colour space not in this configuration: keep Blender's float default (linear)
        pass
    image.pixels.foreach_set(_flip(pixels_rgba_top_first).ravel())
    image.update()
    return image


def _float32_decimal(value: float) -> float:
    """The shortest decimal that reads back as this float32 property value (0.01, not 0.0099999998):
    the value the user typed, at any magnitude (rounding to a number of places would turn 1e-7 into 0)."""
    return float(str(np.float32(value)))


def render_kwargs(settings) -> dict:
    """Keyword arguments for durer.render from scene.durer."""
    return {
        "spp": int(settings.samples),
        "seed": int(settings.seed),
        "precision": settings.precision.lower(),
        "sphere_method": settings.sphere_method.lower(),
        "threads": int(settings.threads) or None,
        "sampler": settings.sampler.lower(),
        "target_error": _float32_decimal(settings.target_error),
        "min_spp": int(settings.min_samples),
        "time_limit": _float32_decimal(settings.time_limit) or None,
        "max_bounces": int(settings.max_bounces),
        "min_weight": _float32_decimal(settings.min_weight),
        # On by default: Cycles shades back faces with the flipped normal (and refraction needs the
        # inside faces); off renders 6.837's default (a 6.837 import without -shade_back).
        "shade_back": bool(settings.shade_back),
        "depth": "planar",  # Blender's Depth pass: the distance along the view axis
    }


class DurerEngineMixin:
    """The engine's behaviour, apart from its Blender registration (see DurerRenderEngine), so
    variants can be registered too (Blender confuses subclasses of a registered engine)."""

    def update_render_passes(self, scene=None, renderlayer=None):
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        for name in layer_passes(renderlayer):
            self.register_pass(scene, renderlayer, name, *PASS_LAYOUTS[name][1:])

    def render(self, depsgraph):
        global last_render
        info = last_render = RenderInfo()
        try:
            self._render(depsgraph, info)
        except KeyboardInterrupt:
            info.interrupted = info.cancelled = True
            self.update_stats("", "Dürer | interrupted")
            # An error report keeps Blender from saving the frame: its EXR writer crashed on the
            # empty result an interrupted render leaves.
            self.report({"ERROR"}, "Dürer: interrupted")
        except Exception as exc:  # noqa: BLE001 - never let an exception escape into Blender
            info.error = f"{type(exc).__name__}: {exc}"
            self.report({"ERROR"}, f"Dürer: {exc}")
            self.update_stats("", f"Dürer | error: {exc}")

    def _render(self, depsgraph, info: RenderInfo) -> None:
        scene = depsgraph.scene
        settings = scene.durer
        layer = depsgraph.view_layer
        t0 = time.perf_counter()
        data = export_depsgraph(depsgraph, camera=self.camera_override)
        if data.camera is None:
            raise ValueError("The scene has no camera")
        cam_data = data.camera
        w, h = cam_data.width, cam_data.height
        keep = scene.render.use_persistent_data
        key = (scene.name, layer.name)
        previous = persistent.pop(key, None) if keep else None
        if not keep:
            persistent.clear()
        core_scene, info.reused_scene = build.update_scene(previous, data)
        if keep:
            persistent[key] = (data, core_scene)
        camera = build.make_camera(cam_data)
        info.export_seconds = time.perf_counter() - t0
        info.width, info.height, info.samples = w, h, int(settings.samples)
        info.spheres, info.planes = data.sphere_count + data.ellipsoid_count, len(data.planes)
        info.triangles = data.triangle_count
        info.warnings = data.warnings
        numbers = build.object_numbers(bpy.data.objects, data) if layer.durer.use_pass_object_id else None
        info.object_ids = {} if numbers is None else {number: name for name, number in numbers.items()}
        for message in info.warnings:
            self.report({"WARNING"}, message)

        asked = layer_passes(layer)
        passes = list(dict.fromkeys(["color"] + [PASS_LAYOUTS[name][0] for name in asked]))
        index_passes = [entry for entry in INDEX_PASSES if entry[0] in asked]
        kwargs = render_kwargs(settings)
        kwargs["ambient_occlusion"] = data.ambient_occlusion
        self.update_stats("", f"Dürer | {w}x{h} | {info.samples} spp | rendering")
        result, cancelled = self._run(core_scene, camera, w, h, passes, kwargs)
        info.render_seconds = time.perf_counter() - t0 - info.export_seconds
        info.cancelled = cancelled
        if result is None:
            return
        stats = dict(result.stats)
        info.stats = stats
        info.sample_counts = result.samples

        crop = self._border(scene, w, h)
        rw, rh = crop[1].stop - crop[1].start, crop[0].stop - crop[0].start
        rr = self.begin_result(0, 0, rw, rh, layer=layer.name)
        try:
            rl = rr.layers[0]
            color = np.asarray(result.color, dtype=np.float32)
            rl.passes["Combined"].rect.foreach_set(_flip(color[crop]).ravel())
            if "Depth" in rl.passes and result.depth is not None:
                depth = build.view_depth(result.depth)
                rl.passes["Depth"].rect.foreach_set(_flip(depth[crop]).ravel())
            if "Normal" in rl.passes and result.normal is not None:
                normal = np.asarray(result.normal, np.float32)
                rl.passes["Normal"].rect.foreach_set(_flip(normal[crop]).ravel())
            tables = build.IdTables.of(data, numbers) if index_passes else None
            for name, _, core, table in index_passes:
                if name in rl.passes and getattr(result, core) is not None:
                    ids = build.IdTables.lookup(getattr(tables, table), getattr(result, core)[crop])
                    rl.passes[name].rect.foreach_set(_flip(ids).ravel())
        finally:
            self.end_result(rr, cancel=False)
        if numbers is not None:  # saved with the image, so that its ids can be read without this session
            # The whole result's metadata: a tile's is dropped. JSON escapes non-ASCII: a PNG's text is Latin-1.
            self.get_result().stamp_data_add_field(OBJECT_IDS_FIELD, json.dumps(info.object_ids))
        if scene.render.use_crop_to_border or crop == (slice(0, h), slice(0, w)):
            color = color[crop]
        else:  # the region in the whole frame, transparent around it, as Blender's result shows it
            framed = np.zeros_like(color)
            framed[crop] = color[crop]
            color = framed
        if threading.current_thread() is threading.main_thread():
            store_image(color)
        else:  # Blender's UI renders in a job thread: create datablocks on the main thread
            bpy.app.timers.register(lambda c=color: (store_image(c), None)[1], first_interval=0.0)
        info.stats_line = stats_line(w, h, info.samples, stats, cancelled, info.reused_scene)
        self.update_stats("", info.stats_line)

    def view_update(self, context, depsgraph):
        viewport.view_update(self, depsgraph)

    def view_draw(self, context, depsgraph):
        viewport.view_draw(self, context, depsgraph)

    def __del__(self):
        viewport.free(self)
        parent = getattr(super(), "__del__", None)
        if parent is not None:  # the main-branch engine template calls one; 5.0.1 has none
            parent()

    def _border(self, scene, w: int, h: int) -> tuple[slice, slice]:
        """Rows and columns (top row first) of the result Blender expects: the whole image, or
        the Render Region (border) as Blender computes it (float32 border × size, truncated).
        Dürer renders the whole frame and keeps the region."""
        r = scene.render
        if not r.use_border:
            return slice(0, h), slice(0, w)

        def edge(fraction: float, size: int) -> int:
            return min(max(int(np.float32(fraction) * np.float32(size)), 0), size)

        x0, x1 = edge(r.border_min_x, w), edge(r.border_max_x, w)
        y0, y1 = edge(r.border_min_y, h), edge(r.border_max_y, h)  # from the bottom
        if x1 <= x0 or y1 <= y0:
            return slice(0, h), slice(0, w)
        return slice(h - y1, h - y0), slice(x0, x1)

    def break_requested(self) -> bool:
        """Has the user asked to stop (Esc)? (Blender's test_break; a Python method so tests can
        press Esc, which the bpy module has no keyboard for.)"""
        return bool(self.test_break())

    def _run(self, core_scene, camera, w, h, passes, kwargs):
        """Render in a worker thread while this thread polls Esc (test_break) and shows progress,
        so every Blender call happens on the thread Blender called us on."""
        cancel, done = threading.Event(), threading.Event()
        progress = [0.0]
        out: dict = {}

        def work():
            try:
                out["result"] = durer.render(
                    core_scene,
                    camera,
                    w,
                    h,
                    passes=tuple(passes),
                    progress=lambda f: progress.__setitem__(0, float(f)),
                    cancel=cancel,
                    **kwargs,
                )
            except BaseException as exc:  # noqa: BLE001 - handed to the calling thread
                out["error"] = exc
            finally:
                done.set()

        # Waited for on `done`, not by joining: on Python 3.11 a join that Ctrl-C interrupts marks the
        # thread stopped while it still runs, and the core then rendered into freed memory.
        threading.Thread(target=work, name="durer-render", daemon=True).start()
        shown = -1.0
        try:
            while not done.wait(POLL_SECONDS):
                if not cancel.is_set() and (self.break_requested() or interrupt.is_set()):
                    cancel.set()
                if progress[0] != shown:
                    shown = progress[0]
                    self.update_progress(shown)
                    for hook in progress_hooks:
                        hook(shown)
        except KeyboardInterrupt:  # the render thread stops too before the interrupt goes on
            cancel.set()
            _wait_through_interrupts(done)
            raise
        error = out.get("error")
        cancelled = isinstance(error, durer.RenderCancelled)
        if error is not None and not cancelled:
            raise error
        if not cancelled:
            self.update_progress(1.0)
            for hook in progress_hooks:
                hook(1.0)
        if interrupt.is_set():  # Ctrl-C up to the last progress shown: the frame is not kept
            raise KeyboardInterrupt
        return (error.result, True) if cancelled else (out.get("result"), False)


class DurerRenderEngine(DurerEngineMixin, bpy.types.RenderEngine):
    bl_idname = "DURER"
    bl_label = "Dürer"
    bl_use_preview = False
    bl_use_postprocess = True
    bl_use_eevee_viewport = True


#: EEVEE panels that show settings Dürer uses too (light colour and power, material and world surface).
_EEVEE_PANELS_WE_USE = {
    "DATA_PT_EEVEE_light",
    "EEVEE_MATERIAL_PT_context_material",
    "EEVEE_MATERIAL_PT_surface",
    "EEVEE_WORLD_PT_surface",
    "VIEWLAYER_PT_eevee_layer_passes_data",
}
_PANEL_PREFIXES = ("RENDER_PT_", "DATA_PT_", "MATERIAL_PT_", "WORLD_PT_", "VIEWLAYER_PT_", "OBJECT_PT_",
                   "PARTICLE_PT_", "PHYSICS_PT_", "TEXTURE_PT_")
_SKIP_WORDS = (
    "eevee",
    "lightprobe",
    "freestyle",
    "gpencil",
    "grease",
    "stereoscopy",
    "volume",
    "shadow_terminator",
    "motion_blur",
    "hair",
    "data_pt_curves",
    "data_pt_context_curves",
    "custom_props_curves",
    "data_pt_cone",
    "data_pt_distance",
    "aov",
    "cryptomatte",
    "speaker",
)


def _compatible_panels():
    """Blender's own panels that apply to any engine (format, output, camera, light, passes, ...)
    and the EEVEE ones showing settings Dürer reads: like Cycles, we add our id to COMPAT_ENGINES."""
    for name in dir(bpy.types):
        if name in _EEVEE_PANELS_WE_USE:
            pass
        elif not name.startswith(_PANEL_PREFIXES) or any(w in name.lower() for w in _SKIP_WORDS):
            continue
        panel = getattr(bpy.types, name, None)
        engines = getattr(panel, "COMPAT_ENGINES", None)
        if isinstance(engines, set) and ("BLENDER_EEVEE" in engines or DurerRenderEngine.bl_idname in engines):
            yield panel


@bpy.app.handlers.persistent
def _forget_persistent(*_args) -> None:
    """Another file is loading (or the factory settings): the scenes kept were the last file's."""
    persistent.clear()


def register() -> None:
    bpy.utils.register_class(DurerRenderEngine)
    for panel in _compatible_panels():
        panel.COMPAT_ENGINES.add(DurerRenderEngine.bl_idname)
    if _forget_persistent not in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.append(_forget_persistent)


def unregister() -> None:
    for panel in _compatible_panels():
        panel.COMPAT_ENGINES.discard(DurerRenderEngine.bl_idname)
    bpy.utils.unregister_class(DurerRenderEngine)
    if _forget_persistent in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.remove(_forget_persistent)
    persistent.clear()
