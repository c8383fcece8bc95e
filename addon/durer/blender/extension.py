"""Build the Blender extension package: ``dist/durer-<version>-<platform>.zip``.

The zip holds ``blender_manifest.toml`` (from ``durer/blender_manifest.toml``, with the version,
platform and wheel list filled in), a small ``__init__.py`` that hands ``register`` /
``unregister`` to ``durer.blender`` once it has checked that the durer Blender has loaded is the
one this zip bundles, and ``wheels/``: the platform wheel of durer and the wheels of its runtime
dependencies that Blender does not ship (Pillow, tqdm; numpy comes with Blender). Blender's
"Install from Disk" (``bpy.ops.extensions.package_install_files``) unpacks the wheels into its
extension site-packages.

Command line (no Blender needed)::

    python -m durer extension [--wheel dist/durer-0.1.0-cp311-cp311-linux_x86_64.whl] [--dist dist]
                              [--wheelhouse dist/wheels]

Without ``--wheel`` it builds the wheel of the project in the current directory with ``pip wheel``
(in a temporary folder, removed afterwards). The dependencies' wheels come from the wheelhouse
when it has them (no network needed); otherwise ``pip download`` fetches them into it.
"""

from __future__ import annotations

import argparse
import email.parser
import hashlib
import os
import re
import string
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from collections.abc import Sequence
from pathlib import Path

from ..distributed.output import temporary_path, write_atomic

MANIFEST = Path(__file__).resolve().parent.parent / "blender_manifest.toml"

# Distributions Blender's own Python ships, which the zip leaves out. Blender 5.0 ships numpy (and
# requests, zstandard, cython: what the bpy module from PyPI requires), not Pillow or tqdm.
BLENDER_SHIPS = frozenset({"numpy"})

EXTENSION_INIT = string.Template('''"""Dürer render engine for Blender (the code is in the bundled durer wheel)."""

import durer

VERSION = "$version"  # the bundled durer's
BUNDLE_SHA256 = "$sha256"  # of the bundled wheels


def register():
    # Installing another zip while Dürer is loaded makes Blender reload this file but not durer,
    # whose compiled core cannot be reloaded: registering would run the loaded durer with modules
    # of the new one imported later. The first registration notes which bundle durer came from.
    loaded = durer.__dict__.setdefault("_extension_bundle_sha256", BUNDLE_SHA256)
    if durer.__version__ != VERSION or loaded != BUNDLE_SHA256:
        installed = f"Dürer {VERSION}" if durer.__version__ != VERSION else f"Another build of Dürer {VERSION}"
        raise RuntimeError(
            f"{installed} was installed while Dürer {durer.__version__} is loaded: "
            "restart Blender, then enable Dürer in Preferences > Add-ons"
        )
    from durer.blender import register as register_durer

    register_durer()


def unregister():
    from durer.blender import unregister as unregister_durer

    unregister_durer()
''')

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


def extension_init(version: str, wheels: Sequence[Path]) -> str:
    """The zip's ``__init__.py`` for durer `version` bundled with `wheels`."""
    digest = hashlib.sha256()
    for wheel in sorted(wheels, key=lambda w: w.name):
        digest.update(wheel.read_bytes())
    return EXTENSION_INIT.substitute(version=version, sha256=digest.hexdigest())


def canonical_name(name: str) -> str:
    """A distribution's name as pip compares them (PEP 503): "Dask_JobQueue" -> "dask-jobqueue"."""
    return re.sub(r"[-_.]+", "-", name).lower()


def runtime_requirements(durer_wheel: str | Path) -> list[str]:
    """The durer wheel's requirements (pyproject.toml's dependencies, from its METADATA) that
    Blender does not ship; those of extras are left out."""
    with zipfile.ZipFile(durer_wheel) as z:
        metadata = [n for n in z.namelist() if re.fullmatch(r"[^/]+\.dist-info/METADATA", n)]
        if len(metadata) != 1:
            raise ValueError(f"{Path(durer_wheel).name} has no single .dist-info/METADATA")
        headers = email.parser.HeaderParser().parsestr(z.read(metadata[0]).decode("utf-8"))
    return [
        r
        for r in headers.get_all("Requires-Dist") or ()
        if not re.search(r";.*\bextra\s*==", r) and canonical_name(requirement_name(r)) not in BLENDER_SHIPS
    ]


def requirement_name(requirement: str) -> str:
    """The distribution a requirement names: "pillow>=10" -> "pillow"."""
    return re.match(r"\s*([A-Za-z0-9][A-Za-z0-9._-]*)", requirement).group(1)


def _this_platform() -> str:
    return sysconfig.get_platform().replace("-", "_").replace(".", "_")


def _python_and_platform(wheel: Path) -> tuple[str, str]:
    python, _, platform = wheel.name[: -len(".whl")].split("-")[-3:]
    return python, platform


def _pip_target(durer_wheel: Path) -> list[str]:
    """pip download's options that pick wheels for the durer wheel's Python and platform. For
    this machine's platform (where durer's own wheel is built) pip's default takes any manylinux
    wheel this machine's glibc runs, which a plain --platform linux_x86_64 would refuse."""
    python, platform = _python_and_platform(durer_wheel)
    target = ["--only-binary=:all:"]
    if m := re.fullmatch(r"cp(\d)(\d+)", python):
        target += ["--python-version", f"{m[1]}.{m[2]}"]
    if platform != _this_platform():
        target += ["--platform", platform]
    return target


def _pip_download(
    requirements: Sequence[str], target: Sequence[str], wheelhouse: Path, into: str, *, offline: bool
) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "pip", "download", "--disable-pip-version-check", "--progress-bar", "off"]
    command += [*target, "--find-links", str(wheelhouse), "-d", into, *requirements]
    if offline:
        command.append("--no-index")
    return subprocess.run(command, check=False, capture_output=True, text=True)


def _fetch(requirements: Sequence[str], durer_wheel: Path, wheelhouse: Path, into: str) -> None:
    """pip download of `requirements` into `into`: from the wheelhouse alone (no network: pip's
    cache cannot serve a package index offline), else from the index too."""
    target = _pip_target(durer_wheel)
    done = _pip_download(requirements, target, wheelhouse, into, offline=True)
    if done.returncode != 0:
        done = _pip_download(requirements, target, wheelhouse, into, offline=False)
    if done.returncode != 0:
        raise RuntimeError(
            f"cannot get the wheels of {', '.join(requirements)} (durer needs them; Blender does not ship them) for "
            f"{' on '.join(_python_and_platform(durer_wheel))}: pip download failed:\n{done.stderr.strip()}\n"
            f"Once the package index is reachable they are kept in {wheelhouse}; or give them with --wheel."
        )


def dependency_wheels(durer_wheel: str | Path, wheelhouse: str | Path, given: Sequence[str | Path] = ()) -> list[Path]:
    """The wheels of durer's runtime dependencies that Blender does not ship and `given` does not
    hold, with their own dependencies, for the durer wheel's Python and platform. They come from
    `wheelhouse` when it has them, otherwise pip downloads them into it; RuntimeError says what
    could not be had."""
    durer_wheel, wheelhouse = Path(durer_wheel), Path(wheelhouse)
    have = {canonical_name(wheel_tags(w)[0]) for w in given}
    wanted = [r for r in runtime_requirements(durer_wheel) if canonical_name(requirement_name(r)) not in have]
    if not wanted:
        return []
    wheelhouse.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="durer-dependencies-") as chosen:
        _fetch(wanted, durer_wheel, wheelhouse, chosen)
        found = [w for w in Path(chosen).glob("*.whl") if canonical_name(wheel_tags(w)[0]) not in BLENDER_SHIPS | have]
        for wheel in found:
            if not (wheelhouse / wheel.name).exists():
                write_atomic(wheelhouse / wheel.name, wheel.read_bytes())
    return sorted(wheelhouse / w.name for w in found)


def build_zip(wheels: Sequence[str | Path], dist: str | Path = "dist", wheelhouse: str | Path | None = None) -> Path:
    """Write dist/durer-<version>-<platform>.zip from durer's wheel, any extra wheels, and the
    wheels of durer's dependencies the extra ones lack (`dependency_wheels`, kept in `wheelhouse`,
    by default dist/wheels). The zip is written under a temporary name and renamed when complete:
    a failure (a wheel that cannot be read, a full disk) leaves no truncated zip behind, nor
    replaces an earlier one."""
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
    wheels += dependency_wheels(durer_wheels[0], wheelhouse or dist / "wheels", wheels)
    dist.mkdir(parents=True, exist_ok=True)
    out = dist / f"durer-{version}-{suffix}.zip"
    temp = temporary_path(out)
    try:
        with zipfile.ZipFile(temp, "w", compression=zipfile.ZIP_DEFLATED) as z:
            z.writestr("blender_manifest.toml", manifest_text(version, platforms, [w.name for w in wheels]))
            z.writestr("__init__.py", extension_init(version, wheels))
            for w in wheels:
                z.write(w, f"wheels/{w.name}")
        os.replace(temp, out)
    except BaseException:
        temp.unlink(missing_ok=True)
        raise
    return out


def build_wheel(project: str | Path, out_dir: str | Path) -> Path:
    """`pip wheel --no-deps` of the project into `out_dir`; returns the wheel's path."""
    out_dir = Path(out_dir)
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
    p.add_argument("--wheelhouse", help="where the dependencies' wheels are kept (default: DIST/wheels)")
    args = p.parse_args(argv)
    for wheel in args.wheel or ():
        if not os.path.isfile(wheel):
            p.error(f"--wheel {wheel}: no such file")
    try:
        with tempfile.TemporaryDirectory(prefix="durer-wheel-") as built:
            wheels = args.wheel or [build_wheel(args.project, built)]
            print(build_zip(wheels, args.dist, args.wheelhouse))
    except ValueError as error:  # the --wheel options': a name not a wheel's, not one durer wheel, no METADATA
        p.error(str(error))
    except (OSError, RuntimeError, subprocess.CalledProcessError) as error:  # pip's output says why it failed
        print(f"{prog}: error: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
