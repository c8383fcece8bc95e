"""The `python -m durer numerics` sweep: it measures what docs/numerics.md claims."""

from __future__ import annotations

import numpy as np

from durer import numerics


def test_sweep_shows_robust_exact_and_textbook_breaking_down():
    rows = numerics.sweep(ratios=(10.0, 1e5, 1e9))
    by = {(r.method, r.precision, r.ratio): r for r in rows}
    for ratio in (10.0, 1e5, 1e9):
        robust = by["robust", "double", ratio]
        assert robust.false_hits == robust.false_misses == 0
        assert robust.max_error < 4e-15
    for precision in ("float", "double"):
        assert all(by["robust", precision, ratio].false_hits == 0 for ratio in (10.0, 1e5, 1e9))
    # The lecture's formulas lose the sphere far away: wrong hits and misses in double at 1e9 radii.
    for method in ("algebraic", "geometric"):
        textbook = by[method, "double", 1e9]
        assert textbook.false_hits + textbook.false_misses > 10
    # In float a sphere 1e9 radii away cannot be resolved: the robust method reports misses only.
    far = by["robust", "float", 1e9]
    assert far.false_hits == 0 and np.isnan(far.max_error)


def test_update_doc_keeps_the_prose(tmp_path):
    doc = tmp_path / "numerics.md"
    doc.write_text(f"# Title\n\nprose before\n\n{numerics.MARKER_BEGIN}\nold table\n{numerics.MARKER_END}\n\nprose after\n")
    numerics.update_doc(doc, "| new | table |", "plot.png")
    text = doc.read_text()
    assert "prose before" in text and "prose after" in text and "| new | table |" in text
    assert "old table" not in text and "![t error vs distance/radius](plot.png)" in text


def test_command_writes_table_and_plot(tmp_path, capsys):
    doc = tmp_path / "numerics.md"
    assert numerics.main(["--doc", str(doc)]) == 0
    assert (tmp_path / "numerics-sweep.png").stat().st_size > 10_000
    assert "| double | robust |" in doc.read_text()
    assert "Worst relative error of t" in capsys.readouterr().out
