"""Build the Blender extension package: ``dist/durer-<version>-<platform>.zip``.

The zip holds ``blender_manifest.toml`` (from ``durer/blender_manifest.toml``, with the version,
platform and wheel list filled in), a two-line ``__init__.py`` that hands ``register`` /
``unregister`` to ``durer.blender``, and ``wheels/`` with the platform wheel of durer. Blender's
"Install from Disk" (``bpy.ops.extensions.package_install_files``) unpacks the wheel into its
extension site-packages; numpy comes with Blender.

Command line (no Blender needed)::

    python -m durer extension [--wheel dist/durer-0.1.0-cp311-cp311-linux_x86_64.whl] [--dist dist]

Without ``--wheel`` it builds the wheel of the project in the current directory with ``pip wheel``.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Sequence
from pathlib import Path

from ..distributed.output import temporary_path

MANIFEST = Path(__file__).resolve().parent.parent / "blender_manifest.toml"

EXTENSION_INIT = '''"""Dürer render engine for Blender (the code is in the bundled durer wheel)."""

from durer.blender import register, unregister  # noqa: F401
'''

_SYSTEMS = {"macosx": "macos", "manylinux": "linux", "musllinux": "linux", "linux": "linux", "win": "windows"}
_MACHINES = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64", "arm64": "arm64"}


def wheel_tags(wheel: str | Path) -> tuple[str, str, str]:
    """(distribution, version, platform tag) of a wheel file name."""
    parts = Path(wheel).name[: -len(".whl")].split("-")
    if not Path(wheel).name.endswith(".whl") or not 5 <= len(parts) <= 6:
        raise ValueError(f"not a wheel file name: {Path(wheel).name}")
    return parts[0], parts[1], parts[-1]


def blender_platforms(wheel_platform: str) -> list[str]:
    """Blender's platform names for a wheel platform tag (as Blender's own extension tool maps
    them): linux_x86_64 / manylinux_2_28_x86_64 -> linux-x64, win_amd64 -> windows-x64,
    macosx_11_0_arm64 -> macos-arm64, macosx_10_9_universal2 -> both macOS; "any" -> []."""
    if wheel_platform == "any":
        return []
    head, _, tail = wheel_platform.partition("_")
    system = next(
        (v for k, v in _SYSTEMS.items() if head == k or (head.startswith(k) and head[len(k) :].isdigit())), head
    )
    if tail == "universal2" or tail.endswith("_universal2"):
        return [f"{system}-x64", f"{system}-arm64"]
    machine = next((v for k, v in _MACHINES.items() if tail == k or tail.endswith("_" + k)), tail.rpartition("_")[2])
    return [f"{system}-{machine}"]


def manifest_text(version: str, platforms: Sequence[str], wheels: Sequence[str], template: Path = MANIFEST) -> str:
    """The manifest with `version`, `platforms` and `wheels` set (keys go before the first table)."""
    text = template.read_text(encoding="utf-8")
    text, n = re.subn(r'(?m)^version\s*=\s*"[^"]*"', f'version = "{version}"', text)
    if n != 1:
        raise ValueError(f"{template} needs exactly one top-level version line")
    text = re.sub(r"(?m)^(platforms|wheels)\s*=.*\n", "", text)
    extra = ""
    if platforms:
        extra += "platforms = [" + ", ".join(f'"{p}"' for p in platforms) + "]\n"
    extra += "wheels = [" + ", ".join(f'"./wheels/{Path(w).name}"' for w in wheels) + "]\n"
    m = re.search(r"(?m)^\[", text)
    cut = m.start() if m else len(text)
    return text[:cut] + extra + "\n" + text[cut:]


def build_zip(wheels: Sequence[str | Path], dist: str | Path = "dist") -> Path:
    """Write dist/durer-<version>-<platform>.zip from durer's wheel (plus any extra wheels). The zip
    is written under a temporary name and renamed when complete: a failure (a wheel that cannot be
    read, a full disk) leaves no truncated zip behind, nor replaces an earlier one."""
    wheels = [Path(w) for w in wheels]
    for wheel in wheels:
        wheel_tags(wheel)  # every name is a wheel's, before anything is written
    durer_wheels = [w for w in wheels if wheel_tags(w)[0] == "durer"]
    if len(durer_wheels) != 1:
        raise ValueError("give exactly one durer wheel")
    _, version, platform_tag = wheel_tags(durer_wheels[0])
    platforms = blender_platforms(platform_tag)
    suffix = "-".join(p.replace("-", "_") for p in platforms) or "any"
    dist = Path(dist)
    dist.mkdir(parents=True, exist_ok=True)
    out = dist / f"durer-{version}-{suffix}.zip"
    temp = temporary_path(out)
    try:
        with zipfile.ZipFile(temp, "w", compression=zipfile.ZIP_DEFLATED) as z:
            z.writestr("blender_manifest.toml", manifest_text(version, platforms, [w.name for w in wheels]))
            z.writestr("__init__.py", EXTENSION_INIT)
            for w in wheels:
                z.write(w, f"wheels/{w.name}")
        os.replace(temp, out)
    except BaseException:
        temp.unlink(missing_ok=True)
        raise
    return out


def build_wheel(project: str | Path = ".", out_dir: str | Path | None = None) -> Path:
    """`pip wheel --no-deps` of the project; returns the wheel's path."""
    out_dir = Path(out_dir or tempfile.mkdtemp(prefix="durer-wheel-"))
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-w", str(out_dir), str(project)],
        check=True,
    )
    found = sorted(out_dir.glob("durer-*.whl"))
    if not found:
        raise RuntimeError(f"pip wheel wrote no durer wheel into {out_dir}")
    return found[-1]


def main(argv: Sequence[str] | None = None, prog: str = "python -m durer extension") -> int:
    p = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    p.add_argument("--wheel", action="append", help="wheel(s) to bundle (default: build durer's wheel with pip)")
    p.add_argument("--project", default=".", help="project directory for pip wheel (default: .)")
    p.add_argument("--dist", default="dist", help="output directory (default: dist)")
    args = p.parse_args(argv)
    for wheel in args.wheel or ():
        if not os.path.isfile(wheel):
            p.error(f"--wheel {wheel}: no such file")
    try:
        wheels = args.wheel or [build_wheel(args.project)]
        print(build_zip(wheels, args.dist))
    except ValueError as error:  # the --wheel options': a name not a wheel's, or not exactly one durer wheel
        p.error(str(error))
    except (OSError, RuntimeError, subprocess.CalledProcessError) as error:  # pip's output says why it failed
        print(f"{prog}: error: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
