"""bench/fuzz_hardening.py: the long run of the hardening fuzz, in a child process it watches."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from helpers import ROOT


@pytest.fixture
def bench(import_bench):
    return import_bench("fuzz_hardening")


@pytest.mark.slow
def test_a_short_run_counts_its_inputs_and_finds_nothing_at_ordinary_numbers(tmp_path):
    run = subprocess.run([sys.executable, str(ROOT / "bench" / "fuzz_hardening.py"), "--ordinary", "--seconds", "4",
                          "--seed", "1", "--out", str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr
    summary = re.search(r"done in \d+ s, 1 child run\(s\): inputs (\d+) \{'(\w+)': (\d+), '(\w+)': (\d+), '(\w+)': (\d+)\}; "
                        r"findings 0, crashes 0, hangs 0; NaN/inf from extreme numbers 0", run.stdout)
    assert summary, run.stdout
    assert int(summary[1]) > 100 and {summary[2], summary[4], summary[6]} == {"api", "reader", "cli"}
    assert sorted(p.name for p in tmp_path.iterdir()) == [".current"]  # nothing saved but the last input


def test_the_input_that_killed_the_child_is_kept(bench, tmp_path):
    (tmp_path / ".current").write_bytes(b"reader\n\x00\x01\nbytes")
    path = bench.keep_current(tmp_path, "crash")
    assert path.parent == tmp_path / "reader" and path.name.startswith("crash-") and path.suffix == ".bin"
    assert path.read_bytes() == b"\x00\x01\nbytes"


def test_bad_options_are_usage_errors(bench, capsys):
    for argv in (["--seconds", "0"], ["--timeout", "-1"], ["--surface", "gui"]):
        with pytest.raises(SystemExit) as exit_:
            bench.parse_arguments(argv)
        assert exit_.value.code == 2
    assert "error:" in capsys.readouterr().err
