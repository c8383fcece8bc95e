"""The world: a uniform Background's colour (Dürer's background and ambient light), and whether
and how far the ambient light is occluded."""

from __future__ import annotations

from .materials import surface_shader
from .nodes import linked_value, rgb


def world_colors(world) -> tuple[tuple[float, float, float], str | None]:
    """Linear RGB of a uniform world (Background colour × strength) and a note if the world is
    not uniform (then its viewport colour is used)."""
    if world is None:
        return (0.0, 0.0, 0.0), None
    tree = world.node_tree
    if tree is None:
        return rgb(world.color), None
    node = surface_shader(tree)
    if node is None:
        return (0.0, 0.0, 0.0), None
    if node.bl_idname == "ShaderNodeBackground":
        col, strength = linked_value(node, "Color", "color"), linked_value(node, "Strength", "value")
        if col is not None and strength is not None:
            return tuple(c * float(strength) for c in rgb(col)), None
    return rgb(world.color), f"World '{world.name}' is not a plain colour: Dürer uses its viewport colour"


def ambient_occlusion(scene) -> tuple[int, float] | None:
    """durer.render's ambient_occlusion=(samples, distance) for `scene`, or None (off): as
    scene.durer says, "From Fast GI" meaning on where Cycles' Fast GI Approximation is; the distance
    is the World's AO Distance (world.light_settings.distance, which that panel shows) unless
    scene.durer gives its own. Read from the original scene: an evaluated copy can hold stale
    add-on settings (Cycles' among them)."""
    scene = scene.original
    settings = getattr(scene, "durer", None)
    if settings is None or settings.ambient_occlusion == "OFF":
        return None
    if settings.ambient_occlusion == "AUTO":
        cycles = getattr(scene, "cycles", None)  # absent when the Cycles add-on is disabled
        if not getattr(cycles, "use_fast_gi", False):
            return None
    distance = float(settings.ao_distance)
    if settings.use_world_ao_distance and scene.world is not None:
        distance = float(scene.world.light_settings.distance)
    # The World's distance may be 0, which durer.render refuses: the setting's minimum stands in
    # (practically nothing occludes).
    return int(settings.ao_samples), max(distance, 1e-6)
