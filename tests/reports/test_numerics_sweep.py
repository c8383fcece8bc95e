"""The `python -m durer numerics` sweep: it measures what docs/numerics.md claims."""

from __future__ import annotations

import pytest

from durer.reports import numerics


def test_sweep_shows_robust_exact_and_textbook_breaking_down():
    rows = numerics.sweep(ratios=(10.0, 1e5, 1e9))
    by = {(r.method, r.precision, r.ratio): r for r in rows}
    # The robust method is right about every ray and within about one rounding of t, at any distance.
    for precision, bound in (("double", 4e-16), ("float", 2.4e-7)):
        for ratio in (10.0, 1e5, 1e9):
            robust = by["robust", precision, ratio]
            assert robust.false_hits == robust.false_misses == 0
            assert robust.max_error < bound
    # The lecture's formulas lose the sphere far away: wrong hits and misses in double at 1e9 radii.
    for method in ("algebraic", "geometric"):
        textbook = by[method, "double", 1e9]
        assert textbook.false_hits + textbook.false_misses > 10
    for method in ("algebraic", "geometric"):
        textbook = by[method, "float", 1e5]
        assert textbook.false_hits + textbook.false_misses > 10


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


def test_a_page_the_sweep_could_not_be_written_to_is_refused_before_the_sweep(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(numerics, "sweep", lambda: pytest.fail("swept before the --doc check"))
    (tmp_path / "a_file").write_text("")
    (tmp_path / "no_end.md").write_text(f"# Numerics\n{numerics.MARKER_BEGIN}\nold table\n")
    for doc, message in ((tmp_path / "a_file" / "n.md", f"'{tmp_path / 'a_file'}' is a file, not a folder"),
                         (tmp_path, "a folder, not a file"),
                         (tmp_path / "no_end.md", f"the generated block has no end marker ({numerics.MARKER_END})")):
        with pytest.raises(SystemExit) as info:
            numerics.main(["--doc", str(doc)])
        assert info.value.code == 2 and capsys.readouterr().err.endswith(f"{message}\n")
