"""Atomic output files and the completeness check a resumed run trusts."""

from __future__ import annotations

import struct

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
    (tmp_path / "b.exr").write_bytes(b"\x89PNG" + bytes(100))
    assert not is_complete(tmp_path / "b.exr")


def scanline_exr(rows: int, multipart: bool = False) -> bytes:
    """An uncompressed scanline OpenEXR of `rows` one-pixel rows of one float channel, as far as
    is_complete reads one: headers, offset tables, chunks."""
    def attribute(name, kind, value):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value

    header = (attribute("compression", "compression", b"\0") + attribute("dataWindow", "box2i",
                                                                     struct.pack("<4i", 0, 0, 0, rows - 1)))
    if multipart:
        header += attribute("chunkCount", "int", struct.pack("<i", rows)) + attribute("type", "string", b"scanlineimage")
    headers = b"\x76\x2f\x31\x01" + struct.pack("<i", 2 | (0x1000 if multipart else 0)) + header + b"\0"
    headers += b"\0" if multipart else b""  # the empty header that ends a multipart file's
    chunk = (4 if multipart else 0) + 8 + 4  # part number, scanline, size, one float
    start = len(headers) + 8 * rows
    offsets = struct.pack(f"<{rows}Q", *(start + chunk * y for y in range(rows)))
    chunks = b"".join((struct.pack("<i", 0) if multipart else b"") + struct.pack("<ii", y, 4) + struct.pack("<f", 0.5)
                      for y in range(rows))
    return headers + offsets + chunks


@pytest.mark.parametrize("multipart", [False, True], ids=["single part", "multipart (Blender's multilayer)"])
def test_an_exr_cut_short_is_not_complete(tmp_path, multipart):
    """A write stopped by a full disk leaves an EXR with its offsets unset (zeros) or its last chunks
    missing: not complete, so that --resume renders it again (a file with the format's first bytes
    was taken as complete; Blender reports "Saved" for such a file)."""
    data = scanline_exr(5, multipart)
    (tmp_path / "whole.exr").write_bytes(data)
    assert is_complete(tmp_path / "whole.exr")
    table = data.index(struct.pack("<Q", len(data) - 5 * ((4 if multipart else 0) + 12)))
    unset = data[:table] + bytes(8 * 5) + data[table + 8 * 5:]
    for name, content in {"cut.exr": data[:-3], "half.exr": data[: len(data) // 2], "unset.exr": unset,
                          "headers.exr": data[:table], "magic.exr": data[:4] + bytes(100)}.items():
        (tmp_path / name).write_bytes(content)
        assert not is_complete(tmp_path / name), name
