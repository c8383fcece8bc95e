"""The 6.837 pass visualisations and image writing."""

from __future__ import annotations

import errno
import io

from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from . import _checks


def depth_to_gray(depth: ArrayLike, near: float, far: float) -> np.ndarray:
    """Depth (H, W) to grey in [0, 1]: `near` white, `far` black, clamped; misses (inf) black."""
    near, far = _checks.finite_real(near, "near"), _checks.finite_real(far, "far")
    if not near < far:
        raise ValueError(f"near must be < far, got {near} and {far}")
    d = _checks._numeric_array(depth, "depth").astype(np.float32)
    return np.clip((far - d) / np.float32(far - near), 0, 1).astype(np.float32)


def normal_to_rgb(normal: ArrayLike) -> np.ndarray:
    """Normals (H, W, 3) to colours: |n| per component (6.837's normal visualisation)."""
    n = np.asarray(normal, dtype=np.float32)
    if n.ndim < 1 or n.shape[-1] != 3:
        raise ValueError(f"normal must have shape (..., 3), got {n.shape}")
    return np.abs(n)


def linear_to_srgb(linear: ArrayLike) -> np.ndarray:
    """The sRGB transfer function (what Blender's "Standard" view applies when saving 8-bit files)."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0, 1)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def image_path(path: str | Path) -> Path:
    """`path` as a Path if Pillow writes an image such as save_image's in its format; ValueError naming
    the common writable ones if not, so a command can refuse a bad output path before it renders."""
    from PIL import Image

    path = Path(path)
    formats = Image.registered_extensions()
    writable = {ext for ext, fmt in formats.items() if fmt in Image.SAVE}
    shown = ", ".join(sorted(e for e in writable if e in (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp")))
    if path.suffix.lower() not in writable:
        raise ValueError(f"the image path must end in an extension Pillow writes ({shown}, ...), got '{path}'")
    # A format Pillow lists may still refuse an RGBA image (.eps, .pcx) or have no writer installed
    # (.h5, .grib): one pixel written to memory finds out before any render.
    try:
        _pillow_image(np.zeros((1, 1, 4), np.uint8), path).save(io.BytesIO(), format=formats[path.suffix.lower()])
    except (OSError, ValueError) as error:
        raise ValueError(f"the image path's format cannot hold a render ({error}); use one of {shown}, "
                         f"got '{path}'") from None
    return path


def _pillow_image(data: np.ndarray, path: Path):  # noqa: ANN202 - PIL.Image.Image, imported lazily
    """8-bit pixels as the Pillow image save_image writes to `path` (JPEG has no alpha)."""
    from PIL import Image

    image = Image.fromarray(data)
    if path.suffix.lower() in (".jpg", ".jpeg") and image.mode == "RGBA":
        image = image.convert("RGB")
    return image


def make_folder_for(path: Path) -> None:
    """Create `path`'s folder (and its parents); NotADirectoryError, naming it, where a file stands
    in the way (mkdir's own error would say only "File exists")."""
    for folder in path.absolute().parents:  # the nearest existing ancestor must be a folder
        if folder.exists():
            if not folder.is_dir():
                raise NotADirectoryError(errno.ENOTDIR, f"'{folder}' is a file, not a folder")
            break
    path.parent.mkdir(parents=True, exist_ok=True)


def save_image(path: str | Path, pixels: ArrayLike, *, srgb: bool = True) -> Path:
    """Write a top-row-first image ((H, W), (H, W, 3) or (H, W, 4) floats in [0, 1]) as 8-bit PNG
    (or any format Pillow knows by the extension). Colour channels of linear renders are sRGB
    encoded by default; pass srgb=False for data such as depth or normal visualisations."""
    if isinstance(pixels, np.ndarray) and pixels.dtype.kind in "iu":  # bytes were clipped to 1: written 0 or 255
        raise TypeError(f"pixels must be floats in [0, 1], got an array of {pixels.dtype} (bytes: divide by 255)")
    p = _checks._numeric_array(pixels, "pixels").astype(np.float64)  # a copy: the encoding below writes into it
    if p.ndim not in (2, 3) or (p.ndim == 3 and p.shape[2] not in (3, 4)):
        raise ValueError(f"pixels must have shape (H, W), (H, W, 3) or (H, W, 4), got {p.shape}")
    if np.isnan(p).any():  # no byte stands for it (the cast to uint8 would write 0: black)
        bad = tuple(int(i) for i in np.argwhere(np.isnan(p))[0])
        raise ValueError(f"pixels must not be NaN, got NaN at index {bad}")
    if _checks.boolean(srgb, "srgb"):
        if p.ndim == 2:
            p = linear_to_srgb(p)
        else:
            p[..., :3] = linear_to_srgb(p[..., :3])
    data = np.round(np.clip(p, 0, 1) * 255).astype(np.uint8)
    path = image_path(path)
    make_folder_for(path)
    _pillow_image(data, path).save(path)
    return path
