"""The world: a uniform Background's colour (Dürer's background and ambient light)."""

from __future__ import annotations

from .nodes import rgb, socket_value


def world_colors(world) -> tuple[tuple[float, float, float], str | None]:
    """Linear RGB of a uniform world (Background colour × strength) and a note if the world is
    not uniform (then its viewport colour is used)."""
    if world is None:
        return (0.0, 0.0, 0.0), None
    tree = world.node_tree
    if tree is None:
        return rgb(world.color), None
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if output is None or not output.inputs["Surface"].is_linked:
        return (0.0, 0.0, 0.0), None
    node = output.inputs["Surface"].links[0].from_node
    if node.bl_idname == "ShaderNodeBackground":
        col, linked = socket_value(node, "Color")
        strength, slinked = socket_value(node, "Strength")
        if not linked and not slinked:
            return tuple(c * float(strength) for c in rgb(col)), None
    return rgb(world.color), f"World '{world.name}' is not a plain colour: Dürer uses its viewport colour"
