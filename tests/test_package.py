"""The package imports without Blender and ships its typing information."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import durer


def test_import_without_bpy():
    # bpy = None in sys.modules makes any `import bpy` fail, as on a machine without Blender.
    code = "import sys; sys.modules['bpy'] = None; import durer; print(durer.Scene().material_count)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "1"


def test_typing_files_are_shipped():
    package = Path(durer.__file__).parent
    assert (package / "py.typed").exists()
    assert (package / "_core.pyi").exists()


def test_public_api():
    for name in ("Scene", "OrthographicCamera", "PerspectiveCamera", "render", "cast", "RenderResult",
                 "CastResult", "RenderCancelled", "depth_to_gray", "normal_to_rgb", "save_image"):
        assert name in durer.__all__ and getattr(durer, name).__doc__, name


def test_the_library_does_not_import_the_reports():
    # The reports (durer.reports) measure the library; the library, its Blender side and the 6.837
    # reader and raytracer must work without them.
    code = ("import sys, durer, durer.blender, durer.blender.export, durer.blender.build, durer.course.raytracer; "
            "print(sorted(m for m in sys.modules if m == 'durer.reports' or m.startswith('durer.reports.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
    # The check can fail: the gallery (a report generator) does import them.
    code = "import sys, durer.course.gallery; print('durer.reports' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "True"


def test_demo_refuses_bad_output_paths_and_sizes_in_one_line(tmp_path, capsys):
    from durer.__main__ import main

    (tmp_path / "a_file").write_text("")
    assert main(["demo", "--output", str(tmp_path / "a_file" / "x.png"), "--width", "8", "--height", "8"]) == 1
    assert capsys.readouterr().err.endswith(f"cannot write {tmp_path / 'a_file' / 'x.png'}: "
                                            f"'{tmp_path / 'a_file'}' is a file, not a folder\n")
    for args, message in ((["--output", str(tmp_path / "x.xyz")], "must end in an extension Pillow writes"),
                          (["--width", "1000000", "--height", "1000000"], "not enough memory for a 1000000x1000000")):
        with pytest.raises(SystemExit) as exit_info:
            main(["demo", "--output", str(tmp_path / "x.png"), *args] if "--output" not in args else ["demo", *args])
        assert exit_info.value.code == 2 and message in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists() and not (tmp_path / "x.xyz").exists()


@pytest.mark.parametrize("suffix, message", [(".eps", "image mode is not supported"),
                                             (".pcx", "Cannot save RGBA images as PCX"),
                                             (".h5", "HDF5 save handler not installed")])
def test_demo_refuses_a_format_pillow_cannot_write_a_render_in_before_rendering(tmp_path, capsys, monkeypatch,
                                                                                suffix, message):
    # Pillow lists these as writable, but not for an RGBA render (or has no writer here): the output
    # path's check (visualize.image_path) finds out before the render, by writing one pixel to memory.
    from durer.__main__ import main

    monkeypatch.setattr(durer, "render", lambda *args, **kwargs: pytest.fail("rendered before the format check"))
    with pytest.raises(SystemExit) as exit_info:
        main(["demo", "--output", str(tmp_path / f"x{suffix}")])
    assert exit_info.value.code == 2
    path = tmp_path / f"x{suffix}"
    err = capsys.readouterr().err
    assert f"the image path's format cannot hold a render ({message}); use one of .bmp" in err
    assert err.endswith(f"got '{path}'\n")
    assert list(tmp_path.iterdir()) == []
