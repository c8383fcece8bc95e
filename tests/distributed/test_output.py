"""Atomic output files and the completeness check a resumed run trusts."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from durer.distributed.output import TEMP_SUFFIX, is_complete, write_atomic


def png_bytes(tmp_path, seed=0) -> bytes:
    path = tmp_path / "source.png"
    Image.fromarray(np.random.default_rng(seed).integers(0, 255, (24, 32, 4), np.uint8)).save(path)
    data = path.read_bytes()
    path.unlink()
    return data


def test_write_atomic_replaces_whole_files_and_leaves_no_temporary_file(tmp_path):
    target = tmp_path / "deep" / "f_0001.png"
    first, second = png_bytes(tmp_path, 1), png_bytes(tmp_path, 2)
    write_atomic(target, first)
    write_atomic(target, second)
    assert target.read_bytes() == second and is_complete(target)
    assert [p.name for p in target.parent.iterdir()] == ["f_0001.png"]


def test_a_failed_write_keeps_the_old_file_and_removes_the_temporary_one(tmp_path):
    target = tmp_path / "f_0001.png"
    old = png_bytes(tmp_path)
    write_atomic(target, old)

    with pytest.raises(TypeError):  # the write fails once the temporary file is open
        write_atomic(target, "not bytes")  # type: ignore[arg-type]
    assert target.read_bytes() == old
    assert not list(tmp_path.glob(f"*{TEMP_SUFFIX}"))


def test_is_complete_rejects_missing_empty_truncated_and_foreign_files(tmp_path):
    data = png_bytes(tmp_path)
    cases = {"whole.png": data, "empty.png": b"", "truncated.png": data[: len(data) // 2],
             "corrupt.png": data[:-20] + bytes(20), "text.png": b"not an image"}
    for name, content in cases.items():
        (tmp_path / name).write_bytes(content)
    assert [name for name in cases if is_complete(tmp_path / name)] == ["whole.png"]
    assert not is_complete(tmp_path / "missing.png")
    (tmp_path / "a.exr").write_bytes(b"\x76\x2f\x31\x01" + bytes(100))
    (tmp_path / "b.exr").write_bytes(b"\x89PNG" + bytes(100))
    assert is_complete(tmp_path / "a.exr") and not is_complete(tmp_path / "b.exr")
