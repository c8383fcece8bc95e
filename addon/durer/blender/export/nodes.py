"""Reading shader node sockets: a socket's own value or a constant linked into it, or a stand-in
where what is linked varies (a texture)."""

from __future__ import annotations


def rgb(value) -> tuple[float, float, float]:
    return (float(value[0]), float(value[1]), float(value[2]))


class Inputs:
    """A shader node's inputs as a material converter reads them. An input linked to what Dürer
    cannot evaluate (a texture, attributes, a node group) takes the stand-in the converter gives
    (by default the socket's own value) and is named in `varying` for the warning; `exempt` names
    the input whose variation attribute colours follow (its warnings are theirs). With `probe`,
    that input, if it varies, takes another stand-in instead: what it changes tells whether the
    material depends on it at all."""

    def __init__(self, node, exempt: str | None = None, probe: str | None = None) -> None:
        self.node = node
        self.exempt = exempt
        self.probe = probe
        self.varying: list[str] = []

    def color(self, name: str, stand_in=None) -> tuple[float, float, float]:
        """Colour input `name`: its own value or the constant linked into it, else `stand_in`."""
        value = self.linked(name, "color")
        if value is not None:
            return rgb(value)
        stand_in = rgb(self.node.inputs[name].default_value if stand_in is None else stand_in)
        return tuple(_another(c) for c in stand_in) if name == self.probe else stand_in

    def scalar(self, name: str, stand_in: float | None = None) -> float:
        """Value input `name`, as `color`."""
        value = self.linked(name, "value")
        if value is not None:
            return float(value)
        stand_in = float(self.node.inputs[name].default_value if stand_in is None else stand_in)
        return _another(stand_in) if name == self.probe else stand_in

    def linked(self, name: str, kind: str):
        """`linked_value`, noting an input whose value varies."""
        value = linked_value(self.node, name, kind)
        if value is None and name != self.exempt and name not in self.varying and name in self.node.inputs:
            self.varying.append(name)
        return value


def _another(value: float) -> float:
    """A probe's stand-in: a value other than `value`, within [0, 1] (a factor's range)."""
    return 0.25 if value > 0.5 else 0.75


def feeding_link(socket):
    """The link whose value input `socket` takes as Cycles evaluates the graph: past muted nodes,
    through their internal links. None where the socket takes its own value: nothing linked, a
    muted link, an invalid one (Blender marks the link closing a loop so; Cycles skips it), or a
    muted node that passes nothing there (no internal link, or one from an input so fed)."""
    while socket.is_linked:
        link = socket.links[0]
        if link.is_muted or not link.is_valid:
            return None
        if not link.from_node.mute:
            return link
        socket = passed_through(link.from_node, link.from_socket)
        if socket is None:
            return None
    return None


def linked_value(node, name: str, kind: str):
    """Socket `name`'s value, its own (`feeding_link`) or a constant linked into it; None where what
    is linked varies or there is no such socket."""
    socket = node.inputs.get(name)
    if socket is None:
        return None
    if feeding_link(socket) is None:
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
