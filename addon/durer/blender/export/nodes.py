"""Reading shader node sockets: a socket's own value or a constant linked into it, or a stand-in
where what is linked varies (a texture)."""

from __future__ import annotations


def rgb(value) -> tuple[float, float, float]:
    return (float(value[0]), float(value[1]), float(value[2]))


class Inputs:
    """A shader node's inputs as a material converter reads them. An input linked to what varies
    over the surface (a texture, attributes) takes the stand-in the converter gives, and is named
    in `varying` for the warning; `exempt` names the input whose variation attribute colours
    follow (its warnings are theirs)."""

    def __init__(self, node, exempt: str | None = None) -> None:
        self.node = node
        self.exempt = exempt
        self.varying: list[str] = []

    def color(self, name: str, stand_in) -> tuple[float, float, float]:
        """Colour input `name`: its own value or the constant linked into it, else `stand_in`."""
        value = self.linked(name, "color")
        return rgb(stand_in) if value is None else rgb(value)

    def scalar(self, name: str, stand_in: float) -> float:
        """Value input `name`, as `color`."""
        value = self.linked(name, "value")
        return float(stand_in) if value is None else float(value)

    def linked(self, name: str, kind: str):
        """`linked_value`, noting an input whose value varies."""
        value = linked_value(self.node, name, kind)
        if value is None and name != self.exempt and name not in self.varying and name in self.node.inputs:
            self.varying.append(name)
        return value


def linked_value(node, name: str, kind: str):
    """Socket `name`'s value, its own or a constant linked into it (a muted link counts as none,
    as in Cycles); None where what is linked varies or there is no such socket."""
    socket = node.inputs.get(name)
    if socket is None:
        return None
    if not socket.is_linked or socket.links[0].is_muted:
        return socket.default_value
    from .attribute_colors import constant_input  # it reads materials, which read this module

    return constant_input(socket, kind)


def passed_through(node, output):
    """The input socket a muted `node` passes to its `output` (its internal link, as Cycles and
    Blender's evaluation follow it), or None where it passes nothing there."""
    for link in node.internal_links:
        if link.to_socket.identifier == output.identifier:
            return link.from_socket
    return None
