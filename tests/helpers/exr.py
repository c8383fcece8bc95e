"""A minimal reader for the uncompressed OpenEXR files Blender writes (tests only).

Blender 5.0 writes multilayer EXRs as *multipart* files (one part per pass).  With
``exr_codec = 'NONE'`` every chunk is one scanline, which makes reading them a few lines
of numpy, so the tests need no OpenEXR dependency and do not depend on how bpy's image
loader exposes (or hides) the passes of a multilayer image.
"""

from __future__ import annotations

import struct

import numpy as np

_DTYPES = {0: np.dtype("<u4"), 1: np.dtype("<f2"), 2: np.dtype("<f4")}


def _cstr(data: bytes, pos: int) -> tuple[str, int]:
    end = data.index(b"\0", pos)
    return data[pos:end].decode(), end + 1


def _read_header(data: bytes, pos: int) -> tuple[dict, int]:
    header: dict = {}
    while data[pos] != 0:
        name, pos = _cstr(data, pos)
        kind, pos = _cstr(data, pos)
        (size,) = struct.unpack_from("<i", data, pos)
        pos += 4
        value = data[pos : pos + size]
        pos += size
        if kind == "chlist":
            channels = []
            q = 0
            while value[q] != 0:
                cname, q = _cstr(value, q)
                ptype = struct.unpack_from("<i", value, q)[0]
                channels.append((cname, ptype))
                q += 16
            header[name] = channels
        elif kind == "box2i":
            header[name] = struct.unpack("<4i", value)
        elif kind == "compression":
            header[name] = value[0]
        elif kind == "int":
            header[name] = struct.unpack("<i", value)[0]
        elif kind == "string":
            header[name] = value.decode(errors="replace")
        else:
            header[name] = value
    return header, pos + 1


def _read_headers(path) -> tuple[bytes, list[dict], int, bool]:
    """The file's bytes, its parts' headers, where the offset tables start and whether it is multipart."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] != b"v/1\x01":
        raise ValueError(f"{path} is not an OpenEXR file")
    flags = struct.unpack_from("<i", data, 4)[0]
    multipart = bool(flags & 0x1000)
    if flags & 0x200:
        raise ValueError("tiled EXR not supported")
    pos = 8
    headers = []
    while True:
        header, pos = _read_header(data, pos)
        headers.append(header)
        if not multipart or data[pos] == 0:
            break
    if multipart:
        pos += 1
    return data, headers, pos, multipart


def read_exr_headers(path) -> list[dict]:
    """Each part's header: {attribute name: value} (strings decoded, e.g. Blender's metadata)."""
    return _read_headers(path)[1]


def read_exr(path) -> dict[str, np.ndarray]:
    """Return {channel name: (H, W) float32 array, top row first} for every channel."""
    data, headers, pos, multipart = _read_headers(path)
    for h in headers:
        if h.get("compression", 0) != 0:
            raise ValueError("only uncompressed EXR (exr_codec='NONE') is supported")
    # Offset tables follow the headers; chunks are self-describing, so walk them instead.
    counts = []
    for h in headers:
        x0, y0, x1, y1 = h["dataWindow"]
        counts.append(h.get("chunkCount", y1 - y0 + 1))
    pos += 8 * sum(counts)
    out: dict[str, np.ndarray] = {}
    arrays = []
    for h in headers:
        x0, y0, x1, y1 = h["dataWindow"]
        w, hh = x1 - x0 + 1, y1 - y0 + 1
        arrays.append({n: np.zeros((hh, w), np.float32) for n, _ in h["channels"]})
    for _ in range(sum(counts)):
        part = 0
        if multipart:
            (part,) = struct.unpack_from("<i", data, pos)
            pos += 4
        y, size = struct.unpack_from("<ii", data, pos)
        pos += 8
        h = headers[part]
        x0, y0, x1, y1 = h["dataWindow"]
        w = x1 - x0 + 1
        q = pos
        for name, ptype in h["channels"]:
            dt = _DTYPES[ptype]
            arrays[part][name][y - y0] = np.frombuffer(data, dt, w, q).astype(np.float32)
            q += w * dt.itemsize
        pos += size
    for a in arrays:
        out.update(a)
    return out
