"""The Blender extension package (`python -m durer extension`): its manifest, the wheels it bundles,
and the zip installed into a fresh Blender user directory as "Install from Disk" does, enabled,
disabled, installed again and upgraded while loaded."""

from __future__ import annotations

import importlib.metadata
import os
import re
import subprocess
import sys
import sysconfig
import textwrap
import tomllib
import zipfile
from pathlib import Path

import pytest

from helpers.blender_import import blender_module

bpy = blender_module("bpy")

import durer
from durer.blender import extension

pytestmark = pytest.mark.blender

ROOT = Path(__file__).resolve().parents[2]
ADDON = "bl_ext.user_default.durer"

# Runs first in each Blender process: `durer` and the dependencies the zip bundles come only from the
# extension's site-packages in the user directory, as in Blender's own Python, which has neither
# (this venv has both, and a compiled durer/_core left in its site-packages).
EXTENSION_ONLY = """
import importlib.machinery, sys

class ExtensionOnly:
    def find_spec(self, name, path=None, target=None):
        if name not in ("durer", "PIL", "tqdm"):
            return None
        paths = [p for p in sys.path if p.startswith({user!r})]
        spec = importlib.machinery.PathFinder.find_spec(name, paths)
        if spec is None:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
        return spec

sys.meta_path.insert(0, ExtensionOnly())
import bpy
"""


def wheel_of_installed_durer(directory: Path, version: str | None = None, build: str = "") -> Path:
    """A wheel of the durer package this test runs (compiled core included), with the metadata pip
    would write, without compiling again. `version` replaces durer.__version__; `build` marks
    another build of the same version."""
    version = version or durer.__version__
    tag = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    py = f"cp{sys.version_info.major}{sys.version_info.minor}"
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"durer-{version}-{py}-{py}-{tag}.whl"
    info = f"durer-{version}.dist-info"
    root = Path(durer.__file__).parent
    with zipfile.ZipFile(path, "w") as z:
        written = set()
        for folder, dirs, files in os.walk(root, followlinks=True):
            dirs[:] = [d for d in dirs if d != "__pycache__"]
            for name in sorted(files):
                f = Path(folder) / name
                arcname = "durer/" + f.relative_to(root).as_posix()
                data = f.resolve().read_bytes()
                if arcname == "durer/__init__.py":
                    data = re.sub(rb'__version__ = "[^"]*"', f'__version__ = "{version}"'.encode(), data)
                    data += f"# build {build}\n".encode()
                z.writestr(arcname, data)
                written.add(arcname)
        core = Path(durer._core.__file__)  # an editable install keeps it in site-packages or the build tree
        if f"durer/{core.name}" not in written:
            z.write(core, f"durer/{core.name}")
        requires = "".join(f"Requires-Dist: {r}\n" for r in importlib.metadata.requires("durer"))
        z.writestr(f"{info}/METADATA", f"Metadata-Version: 2.1\nName: durer\nVersion: {version}\n{requires}")
        z.writestr(
            f"{info}/WHEEL", f"Wheel-Version: 1.0\nGenerator: test\nRoot-Is-Purelib: false\nTag: {py}-{py}-{tag}\n"
        )
        z.writestr(f"{info}/RECORD", "")
    return path


def run_blender(script: str, user: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    """`script` in a fresh Python with bpy, Blender's user directory `user`; fails the test if it fails."""
    code = EXTENSION_ONLY.format(user=str(user)) + textwrap.dedent(script)
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(user))
    done = subprocess.run(
        [sys.executable, "-c", code], check=False, capture_output=True, text=True, timeout=timeout, env=env
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return done


@pytest.fixture(scope="module")
def wheelhouse(tmp_path_factory) -> Path:
    """One wheelhouse for the module's zips: pip fetches Pillow's and tqdm's wheels once."""
    return tmp_path_factory.mktemp("wheelhouse")


def offline(monkeypatch) -> None:
    """pip without a package index, nor the machine's configured find-links and indexes."""
    monkeypatch.setenv("PIP_CONFIG_FILE", os.devnull)
    monkeypatch.setenv("PIP_NO_INDEX", "1")
    for name in ("PIP_FIND_LINKS", "PIP_INDEX_URL", "PIP_EXTRA_INDEX_URL"):
        monkeypatch.delenv(name, raising=False)


def test_manifest_needs_the_blender_the_tests_run():
    manifest = tomllib.loads(extension.MANIFEST.read_text(encoding="utf-8"))
    minimum = tuple(int(part) for part in manifest["blender_version_min"].split("."))
    assert minimum == (*bpy.app.version[:2], 0), "the minimum is the Blender series the tests run"
    stated = re.search(r"It needs Blender (\d+)\.(\d+) or newer", (ROOT / "docs/blender.md").read_text())
    assert stated and tuple(map(int, stated.groups())) == minimum[:2]


def test_the_wheels_version_is_durers():
    # The zip's __init__.py compares the loaded durer.__version__ with its wheel's version, which
    # comes from pyproject.toml: were they to differ, it would refuse to register.
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert pyproject["project"]["version"] == durer.__version__


def test_bundled_requirements_are_durers_less_what_blender_ships(tmp_path):
    def name(requirement: str) -> str:
        return extension.canonical_name(extension.requirement_name(requirement))

    declared = [r for r in importlib.metadata.requires("durer") if "extra ==" not in r]
    blender_has = {name(r) for r in importlib.metadata.requires("bpy")}
    assert extension.BLENDER_SHIPS <= blender_has  # bpy from PyPI requires them: Blender's Python ships them
    bundled = extension.runtime_requirements(wheel_of_installed_durer(tmp_path))
    assert bundled == [r for r in declared if name(r) not in blender_has]
    assert {name(r) for r in bundled} == {"pillow", "tqdm"}


def test_dependency_wheels_come_from_the_wheelhouse_offline_or_fail_clearly(tmp_path, wheelhouse, monkeypatch, capsys):
    wheel = wheel_of_installed_durer(tmp_path)
    fetched = extension.dependency_wheels(wheel, wheelhouse)  # the package index (or this machine's copy of it)
    offline(monkeypatch)
    again = extension.dependency_wheels(wheel, wheelhouse)
    assert again == fetched and [extension.wheel_tags(w)[0] for w in again] == ["pillow", "tqdm"]
    assert extension.dependency_wheels(wheel, wheelhouse, given=[wheel, fetched[0]]) == fetched[1:]
    # Nothing kept and no index: the command says what it could not get, and writes no zip.
    dist = tmp_path / "dist"
    assert extension.main(["--wheel", str(wheel), "--dist", str(dist)]) == 1
    error = capsys.readouterr().err
    wanted = ", ".join(extension.runtime_requirements(wheel))
    py = f"cp{sys.version_info.major}{sys.version_info.minor}"
    assert f"error: cannot get the wheels of {wanted} (durer needs them; Blender does not ship them) " \
           f"for {py} on {extension.wheel_tags(wheel)[2]}: pip download failed" in error
    assert f"they are kept in {dist / 'wheels'}; or give them with --wheel" in error
    assert not list(dist.glob("*.zip"))


def test_extension_refuses_bad_wheels_in_one_line_and_leaves_no_partial_zip(tmp_path, wheelhouse, capsys):
    wheel = wheel_of_installed_durer(tmp_path)
    (tmp_path / "foo.txt").write_text("")
    missing = tmp_path / "missing.whl"
    for bad, message in ((missing, f"--wheel {missing}: no such file"),
                         (tmp_path / "foo.txt", "not a wheel file name: foo.txt")):
        with pytest.raises(SystemExit) as exit_info:
            extension.main(["--wheel", str(bad), "--dist", str(tmp_path / "dist")])
        assert exit_info.value.code == 2 and capsys.readouterr().err.endswith(f"error: {message}\n")
    # An extra wheel that vanishes while the zip is written: no truncated zip is left behind.
    with pytest.raises(FileNotFoundError):
        extension.build_zip([wheel, tmp_path / "gone-1.0-py3-none-any.whl"], tmp_path / "dist", wheelhouse)
    assert list((tmp_path / "dist").iterdir()) == []


def test_extension_command_removes_the_wheel_it_built(tmp_path):
    """Without --wheel the command builds durer's wheel with pip wheel: in a temporary folder it
    removes (here a stand-in project with an in-tree build backend, built in a second)."""
    project = tmp_path / "project"
    project.mkdir()
    (project / "pyproject.toml").write_text(
        '[build-system]\nrequires = []\nbuild-backend = "backend"\nbackend-path = ["."]\n'
    )
    (project / "backend.py").write_text(textwrap.dedent('''
        import zipfile

        def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
            name = "durer-0.1.0-py3-none-any.whl"
            with zipfile.ZipFile(f"{wheel_directory}/{name}", "w") as z:
                z.writestr("durer/__init__.py", "")
                info = "durer-0.1.0.dist-info/"
                z.writestr(info + "METADATA", "Metadata-Version: 2.1\\nName: durer\\nVersion: 0.1.0\\n")
                z.writestr(info + "WHEEL", "Wheel-Version: 1.0\\nRoot-Is-Purelib: true\\nTag: py3-none-any\\n")
                z.writestr(info + "RECORD", "")
            return name
        '''))
    temp = tmp_path / "tmp"
    temp.mkdir()
    done = subprocess.run(
        [sys.executable, "-m", "durer", "extension", "--project", str(project), "--dist", str(tmp_path / "dist")],
        check=False, capture_output=True, text=True, timeout=300, env=dict(os.environ, TMPDIR=str(temp)),
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == str(tmp_path / "dist" / "durer-0.1.0-any.zip")  # after pip's lines
    assert list(temp.iterdir()) == []


def test_extension_zip_installs_enables_again_and_renders(tmp_path, wheelhouse):
    wheel = wheel_of_installed_durer(tmp_path)
    assert extension.main(["--wheel", str(wheel), "--dist", str(tmp_path / "dist"),
                           "--wheelhouse", str(wheelhouse)]) == 0
    zip_path = next((tmp_path / "dist").glob("durer-*.zip"))
    platform = extension.blender_platforms(extension.wheel_tags(wheel)[2])[0]
    assert zip_path.name == f"durer-{durer.__version__}-{platform.replace('-', '_')}.zip"
    bundled = [wheel.name] + [w.name for w in extension.dependency_wheels(wheel, wheelhouse)]
    assert [extension.wheel_tags(w)[0] for w in bundled] == ["durer", "pillow", "tqdm"]
    with zipfile.ZipFile(zip_path) as z:
        assert set(z.namelist()) == {"blender_manifest.toml", "__init__.py", *(f"wheels/{w}" for w in bundled)}
        manifest = tomllib.loads(z.read("blender_manifest.toml").decode())
    assert manifest["platforms"] == [platform] and manifest["wheels"] == [f"./wheels/{w}" for w in bundled]
    # A fresh Blender (own user directory) installs it like "Install from Disk", renders, saves an
    # image with the bundled Pillow; disabled, enabled, installed again and scripts reloaded, it
    # still renders.
    user = tmp_path / "blender-user"
    run_blender(f"""
        def install():
            assert bpy.ops.extensions.package_install_files(
                filepath={str(zip_path)!r}, repo="user_default", enable_on_install=True) == {{"FINISHED"}}

        def render(name):
            s = bpy.context.scene
            s.render.engine = "DURER"
            s.render.resolution_x, s.render.resolution_y = 32, 24
            s.render.filepath = {str(tmp_path)!r} + "/" + name
            bpy.ops.render.render(write_still=True)
            import durer.blender.engine as e
            assert e.last_render.error is None, e.last_render.error

        install()
        assert {ADDON!r} in bpy.context.preferences.addons
        render("ext.png")
        import durer, PIL
        for module in (durer, PIL):
            assert module.__file__.startswith({str(user)!r}), module.__file__
        durer.save_image({str(tmp_path / "api.png")!r}, durer.render(*durer.showcase_scene(), 16, 12).color)
        bpy.ops.preferences.addon_disable(module={ADDON!r})
        assert not hasattr(bpy.types.Scene, "durer")
        bpy.ops.preferences.addon_enable(module={ADDON!r})
        render("again.png")
        install()
        bpy.ops.script.reload()
        render("reinstalled.png")
        """, user)
    assert all((tmp_path / name).is_file() for name in ("ext.png", "api.png", "again.png", "reinstalled.png"))


def test_installing_another_build_while_loaded_asks_for_a_restart(tmp_path, wheelhouse):
    """Blender reloads the extension's __init__.py but keeps the durer it imported: the new zip
    refuses to register over it, saying why; after a restart the new one runs."""
    zips = {}
    for name, version, build in (("first", "0.1.0", ""), ("rebuilt", "0.1.0", "2"), ("newer", "0.1.1", "")):
        wheel = wheel_of_installed_durer(tmp_path / name, version, build)
        zips[name] = str(extension.build_zip([wheel], tmp_path / name, wheelhouse))
    user = tmp_path / "blender-user"
    refusals = {
        name: f"Error: {installed} was installed while Dürer 0.1.0 is loaded: "
        "restart Blender, then enable Dürer in Preferences > Add-ons\n"
        for name, installed in (("rebuilt", "Another build of Dürer 0.1.0"), ("newer", "Dürer 0.1.1"))
    }
    run_blender(f"""
        import addon_utils

        def install(name):
            bpy.ops.extensions.package_install_files(filepath={zips!r}[name], repo="user_default",
                                                     enable_on_install=True)

        install("first")
        assert addon_utils.check({ADDON!r})[1] and hasattr(bpy.types.Scene, "durer")
        for name, refusal in {refusals!r}.items():
            try:
                install(name)
            except RuntimeError as error:
                assert str(error) == refusal, repr(str(error))
            else:
                raise AssertionError(name + " registered over the durer loaded")
            assert not addon_utils.check({ADDON!r})[1] and not hasattr(bpy.types.Scene, "durer")
        """, user)
    # The restart: the newer Dürer, enabled, runs.
    run_blender(f"""
        bpy.ops.preferences.addon_enable(module={ADDON!r})
        import durer
        assert durer.__version__ == "0.1.1" and durer.__file__.startswith({str(user)!r}), durer.__file__
        s = bpy.context.scene
        s.render.engine = "DURER"
        s.render.resolution_x, s.render.resolution_y = 32, 24
        bpy.ops.render.render()
        import durer.blender.engine as e
        assert e.last_render.error is None, e.last_render.error
        """, user)
