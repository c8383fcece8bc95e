"""Output files written atomically, and the check that lets a resumed run skip finished ones."""

from __future__ import annotations

import os
from pathlib import Path

#: Prefix and suffix of the temporary file an image is written to before it is renamed into place.
TEMP_PREFIX, TEMP_SUFFIX = ".", ".part"

# First bytes of the formats Pillow cannot decode fully (OpenEXR, Radiance HDR): such a file is
# complete when its header is there, since it only ever appears under its name by a rename.
_MAGIC = {".exr": b"\x76\x2f\x31\x01", ".hdr": b"#?"}


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


def is_complete(path: Path) -> bool:
    """Whether `path` is a whole image: it exists and decodes (PNG, JPEG, TIFF, BMP, WebP through
    Pillow, which checks PNG's chunk checksums), or for EXR and HDR starts with the format's magic."""
    try:
        if not path.is_file() or path.stat().st_size == 0:
            return False
        magic = _MAGIC.get(path.suffix.lower())
        if magic is not None:
            with open(path, "rb") as file:
                return file.read(len(magic)) == magic
        from PIL import Image

        with Image.open(path) as image:
            image.load()
        return True
    except (OSError, SyntaxError, ValueError):
        return False
