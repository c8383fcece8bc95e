"""Output files written atomically, and the check that lets a resumed run skip finished ones."""

from __future__ import annotations

import os
import struct
from pathlib import Path
from typing import BinaryIO

#: Prefix and suffix of the temporary file an image is written to before it is renamed into place.
TEMP_PREFIX, TEMP_SUFFIX = ".", ".part"

# First bytes of the formats Pillow cannot decode fully (OpenEXR, Radiance HDR). An EXR is checked
# further (`_exr_complete`); an HDR is taken as complete once its header is there.
_MAGIC = {".exr": b"\x76\x2f\x31\x01", ".hdr": b"#?"}
#: Scanlines per chunk of an EXR by its compression (OpenEXR's NONE, RLE, ZIPS, ZIP, PIZ, PXR24,
#: B44, B44A, DWAA, DWAB).
_EXR_LINES = (1, 1, 1, 16, 32, 16, 32, 32, 32, 256)


def temporary_path(path: Path) -> Path:
    """Where `path` is written before the rename: a hidden file beside it (same file system)."""
    return path.with_name(f"{TEMP_PREFIX}{path.name}.{os.getpid()}{TEMP_SUFFIX}")


def write_atomic(path: Path, data: bytes) -> None:
    """Write `data` to `path` so that `path` holds either its old content or all of `data`, never
    part of it (a temporary file beside it, flushed to disk, then renamed over it); the temporary
    file is removed if writing fails or is interrupted."""
    path.parent.mkdir(parents=True, exist_ok=True)
    temp = temporary_path(path)
    try:
        with open(temp, "wb") as file:
            file.write(data)
            file.flush()
            os.fsync(file.fileno())
        os.replace(temp, path)
    except BaseException:
        temp.unlink(missing_ok=True)
        raise


def is_complete(path: Path, suffix: str | None = None) -> bool:
    """Whether `path` is a whole image: it exists and decodes (PNG, JPEG, TIFF, BMP, WebP through
    Pillow, which checks PNG's chunk checksums), an EXR whose every chunk lies within the file (a
    write cut short by a full disk leaves offsets past its end, or none), an HDR that starts with its
    format's magic. `suffix`: the format's extension where the name has another (a temporary file)."""
    suffix = (suffix or path.suffix).lower()
    try:
        size = path.stat().st_size if path.is_file() else 0
        if size == 0:
            return False
        magic = _MAGIC.get(suffix)
        if magic is not None:
            with open(path, "rb") as file:
                if file.read(len(magic)) != magic:
                    return False
                return _exr_complete(file, size) if suffix == ".exr" else True
        from PIL import Image

        with Image.open(path) as image:
            image.load()
        return True
    except (OSError, SyntaxError, ValueError, KeyError, struct.error):  # KeyError, struct.error: a malformed EXR
        return False


def _exr_complete(file: BinaryIO, size: int) -> bool:
    """Whether the OpenEXR file open at `file` (after its magic), `size` bytes long, holds every chunk
    its offset tables name: each offset set, and the chunk at the last ending within the file.
    Scanline images, single-part or multipart (Blender's multilayer files); a tiled or deep image
    without a chunk count is taken as complete once its headers are there."""
    (version,) = struct.unpack("<i", file.read(4))
    multipart, tiled = bool(version & 0x1000), bool(version & 0x200)
    parts = []
    while True:
        header = _exr_header(file)
        if not header:
            break
        parts.append(header)
        if not multipart:
            break
    if not parts:
        return False
    counts = []
    for header in parts:
        if "chunkCount" in header:
            counts.append(struct.unpack("<i", header["chunkCount"])[0])
            continue
        if tiled or header.get("type", b"scanlineimage") != b"scanlineimage":
            return True
        compression = header["compression"][0]
        if compression >= len(_EXR_LINES):
            return True
        _, y0, _, y1 = struct.unpack("<4i", header["dataWindow"])
        counts.append(-(-(y1 - y0 + 1) // _EXR_LINES[compression]))
    for part, count in enumerate(counts):
        offsets = struct.unpack(f"<{count}Q", file.read(8 * count))
        if not offsets or min(offsets) == 0 or max(offsets) >= size:
            return False
        chunk_type = parts[part].get("type", b"tiledimage" if tiled else b"scanlineimage")
        if chunk_type != b"scanlineimage":
            continue
        here, last = file.tell(), max(offsets) + (4 if multipart else 0)  # after the part number
        file.seek(last + 4)  # after the chunk's first scanline: its length
        (length,) = struct.unpack("<i", file.read(4))
        if last + 8 + length > size:
            return False
        file.seek(here)
    return True


def _exr_header(file: BinaryIO) -> dict[str, bytes]:
    """One header's attributes (name -> raw value) from `file`, up to its closing null byte ({} for the
    empty header that ends a multipart file's headers)."""
    def name() -> str:
        out = bytearray()
        while (byte := file.read(1)) not in (b"\0", b""):
            out += byte
        return out.decode("latin-1")

    header = {}
    while attribute := name():
        kind = name()
        (length,) = struct.unpack("<i", file.read(4))
        value = file.read(length)
        header[attribute] = value.rstrip(b"\0") if kind == "string" else value
    return header
