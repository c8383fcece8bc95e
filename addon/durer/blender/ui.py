"""Dürer's panels: Render Properties (scene.durer), Object Properties (object.durer), Material
Properties (material.durer, the 6.837 material override), Light Properties (light.durer) and
View Layer › Passes › Indexes (Blender's index passes and view_layer.durer's Object ID)."""

from __future__ import annotations

import bpy

from durer.material import COURSE_FIELDS


class _DurerPanel:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    COMPAT_ENGINES = {"DURER"}  # noqa: RUF012 - Blender reads this set

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def split_layout(self):
        """The panel's layout with labels in a column of their own, as Blender's property panels."""
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        return layout


def sampling_rows(settings) -> list[tuple[str, str, bool]]:
    """The sampling part of the Render panel as (property, label, active) rows: Preset, Samples
    ("Max Samples" for Adaptive), Sampler, Min Samples, Target Error and Time Limit (Adaptive only),
    Seed (inactive for Center, which has no randomness)."""
    adaptive = settings.sampler == "ADAPTIVE"
    rows = [
        ("preset", "Preset", True),
        ("samples", "Max Samples" if adaptive else "Samples", True),
        ("sampler", "Sampler", True),
    ]
    if adaptive:
        rows += [("min_samples", "Min Samples", True), ("target_error", "Target Error", True),
                 ("time_limit", "Time Limit", True)]
    rows.append(("seed", "Seed", settings.sampler != "CENTER"))
    return rows


class DURER_PT_render(_DurerPanel, bpy.types.Panel):
    bl_label = "Dürer"
    bl_context = "render"

    def draw(self, context):
        layout = self.split_layout()
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
        layout.prop(settings, "shade_back")
        col = layout.column(heading="Lights")
        col.prop(settings, "soft_shadows")
        col.prop(settings, "light_samples")
        # Blender's own settings Dürer reads, whose panels (EEVEE's, Cycles') are not shown for it.
        render = context.scene.render
        layout.prop(render, "film_transparent", text="Transparent Film")
        layout.prop(render, "use_persistent_data", text="Persistent Data")
        col = layout.column(heading="Ambient")
        row = col.row()
        row.active = not settings.use_custom_ambient
        row.prop(settings, "use_world_lighting")
        col.prop(settings, "use_custom_ambient")
        row = col.row()
        row.active = settings.use_custom_ambient
        row.prop(settings, "ambient")
        layout.prop(settings, "ambient_occlusion")
        col = layout.column()
        col.active = settings.ambient_occlusion != "OFF"
        col.prop(settings, "ao_samples")
        col.prop(settings, "use_world_ao_distance")
        row = col.row()
        row.active = not settings.use_world_ao_distance
        row.prop(settings, "ao_distance")
        world = context.scene.world
        if world is not None:
            row = col.row()
            row.active = settings.use_world_ao_distance
            row.prop(world.light_settings, "distance", text="World AO Distance")


class DURER_PT_object(_DurerPanel, bpy.types.Panel):
    bl_label = "Dürer"
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.object is not None

    def draw(self, context):
        layout = self.split_layout()
        settings = context.object.durer
        layout.prop(settings, "primitive")
        row = layout.row()
        row.active = settings.primitive in {"AUTO", "PLANE"}
        row.prop(settings, "infinite_plane")


class DURER_PT_material(_DurerPanel, bpy.types.Panel):
    bl_label = "Dürer"
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and getattr(context, "material", None) is not None

    def draw_header(self, context):
        self.layout.prop(context.material.durer, "use_override", text="")

    def draw(self, context):
        layout = self.split_layout()
        settings = context.material.durer
        col = layout.column()
        col.active = settings.use_override
        for field in COURSE_FIELDS:
            col.prop(settings, field.name)


class DURER_PT_light(_DurerPanel, bpy.types.Panel):
    bl_label = "Dürer"
    bl_context = "data"

    @classmethod
    def poll(cls, context):
        light = getattr(context, "light", None)
        return super().poll(context) and light is not None and light.type in {"SUN", "POINT", "SPOT", "AREA"}

    def draw(self, context):
        layout = self.split_layout()
        light = context.light
        layout.prop(light, "use_shadow", text="Cast Shadows")  # shown by EEVEE's shadow panel only
        if light.type in {"SUN", "AREA"}:  # no falloff to choose
            return
        settings = light.durer
        layout.prop(settings, "use_attenuation")
        row = layout.row()
        row.active = settings.use_attenuation
        row.prop(settings, "attenuation")


class DURER_PT_index_passes(_DurerPanel, bpy.types.Panel):
    """Blender's index passes (as Cycles shows them) and Dürer's Object ID, under View Layer › Passes."""

    bl_label = "Indexes"
    bl_context = "view_layer"
    bl_parent_id = "VIEWLAYER_PT_layer_passes"

    def draw(self, context):
        layout = self.split_layout()
        layer = context.view_layer
        col = layout.column(heading="Indexes", align=True)
        col.prop(layer, "use_pass_object_index")
        col.prop(layer, "use_pass_material_index")
        col.prop(layer.durer, "use_pass_object_id")


CLASSES = (DURER_PT_render, DURER_PT_object, DURER_PT_material, DURER_PT_light, DURER_PT_index_passes)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister() -> None:
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
