"""Report generators: the measured pages in docs/ (`python -m durer accuracy`, `numerics`, `gallery`),
the machine description they print and the scenes they and bench/ measure.

The library (`durer`, `durer.blender`, `durer.course`'s reader and raytracer) never imports this
package: it needs the report extras (matplotlib, mpmath) and exists only to measure the library.
"""

from __future__ import annotations

import os
from pathlib import Path


def check_writable(path: str | os.PathLike, option: str) -> None:
    """ValueError naming `option` unless the file `path` (and files beside it: the plots) can be
    written: checked before a long measurement, whose writing would otherwise fail only at its end.
    `path` must not be a folder, and its nearest existing ancestor must be a folder this user may
    write into (the missing ones are created when writing)."""
    path = Path(path).absolute()
    try:
        folder = next(p for p in path.parents if p.exists())  # the root always exists
        if path.is_dir():
            raise ValueError(f"{option} {path}: a folder, not a file")
    except OSError as error:  # a name the system cannot look up (too long, ...)
        raise ValueError(f"{option} {path}: {error.strerror}") from None
    if not folder.is_dir():
        raise ValueError(f"{option} {path}: '{folder}' is a file, not a folder")
    if not os.access(folder, os.W_OK | os.X_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise ValueError(f"{option} {path}: permission denied")
