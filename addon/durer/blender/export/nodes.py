"""Reading shader node sockets: an unlinked socket's value, or a fallback where a texture is linked."""

from __future__ import annotations


def socket_value(node, name: str):
    sock = node.inputs.get(name)
    if sock is None:
        return None, False
    return sock.default_value, sock.is_linked


def rgb(value) -> tuple[float, float, float]:
    return (float(value[0]), float(value[1]), float(value[2]))


def color_input(node, name: str, fallback) -> tuple[float, float, float]:
    """An unlinked colour socket's value; `fallback` when linked (a texture) or absent."""
    value, linked = socket_value(node, name)
    return rgb(fallback) if value is None or linked else rgb(value)


def scalar_input(node, name: str, fallback: float) -> float:
    """An unlinked value socket's value; `fallback` when linked or absent."""
    value, linked = socket_value(node, name)
    return float(fallback) if value is None or linked else float(value)
