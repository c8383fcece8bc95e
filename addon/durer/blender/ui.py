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


class DURER_PT_render(_DurerPanel, bpy.types.Panel):
    bl_label = "Dürer"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.scene.durer
        col = layout.column()
        col.prop(settings, "samples")
        col.prop(settings, "sampler")
        col.prop(settings, "seed")
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
