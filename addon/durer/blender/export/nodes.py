"""Reading shader node sockets: a socket's own value or a constant linked into it, or a fallback
where what is linked varies (a texture)."""

from __future__ import annotations


def rgb(value) -> tuple[float, float, float]:
    return (float(value[0]), float(value[1]), float(value[2]))


def color_input(node, name: str, fallback) -> tuple[float, float, float]:
    """A colour socket's value: its own, or a constant linked into it (an RGB node, maths on
    constants); `fallback` when what is linked varies (a texture, attributes) or it is absent."""
    value = linked_value(node, name, "color")
    return rgb(fallback) if value is None else rgb(value)


def scalar_input(node, name: str, fallback: float) -> float:
    """A value socket's value, as `color_input`."""
    value = linked_value(node, name, "value")
    return float(fallback) if value is None else float(value)


def linked_value(node, name: str, kind: str):
    """Socket `name`'s value, its own or a constant linked into it; None where what is linked
    varies or there is no such socket."""
    socket = node.inputs.get(name)
    if socket is None:
        return None
    if not socket.is_linked:
        return socket.default_value
    from .attribute_colors import constant_input  # it reads materials, which read this module

    return constant_input(socket, kind)
