"""Dürer's panels: Render Properties (scene.durer) and Object Properties (object.durer)."""

from __future__ import annotations

import bpy


class _DurerPanel:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    COMPAT_ENGINES = {"DURER"}  # noqa: RUF012 - Blender reads this set

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


def sampling_rows(settings) -> list[tuple[str, str, bool]]:
    """The sampling part of the Render panel as (property, label, active) rows: Preset, Samples
    ("Max Samples" for Adaptive), Sampler, Target Error (Adaptive only), Seed (inactive for Center,
    which has no randomness)."""
    adaptive = settings.sampler == "ADAPTIVE"
    rows = [
        ("preset", "Preset", True),
        ("samples", "Max Samples" if adaptive else "Samples", True),
        ("sampler", "Sampler", True),
    ]
    if adaptive:
        rows.append(("target_error", "Target Error", True))
    rows.append(("seed", "Seed", settings.sampler != "CENTER"))
    return rows


class DURER_PT_render(_DurerPanel, bpy.types.Panel):
    bl_label = "Dürer"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.scene.durer
        col = layout.column()
        for name, label, active in sampling_rows(settings):
            row = col.row()
            row.active = active
            row.prop(settings, name, text=label)
        col = layout.column()
        col.prop(settings, "precision")
        col.prop(settings, "sphere_method")
        col.prop(settings, "threads")
        col = layout.column(heading="Light Paths")
        col.prop(settings, "max_bounces")
        col.prop(settings, "min_weight")
        layout.prop(settings, "use_world_lighting")


class DURER_PT_object(_DurerPanel, bpy.types.Panel):
    bl_label = "Dürer"
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.object is not None

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.object.durer
        layout.prop(settings, "primitive")
        row = layout.row()
        row.active = settings.primitive in {"AUTO", "PLANE"}
        row.prop(settings, "infinite_plane")


CLASSES = (DURER_PT_render, DURER_PT_object)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister() -> None:
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
