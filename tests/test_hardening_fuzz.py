"""The hardening fuzz (issue 18) in the suite: hypothesis drives the three surfaces of
tests/helpers/hardening_fuzz.py — the API, the 6.837 reader, the command lines — through the same
oracle as bench/fuzz_hardening.py (atheris or random bytes, for hours), derandomised so every run
tries the same inputs. DURER_HARDENING_EXAMPLES=N multiplies the default counts by N.

Every input any fuzz run has failed on is kept in tests/fuzz_findings/<surface>/ (the bytes, and
beside them the failure as found) and rerun here: each must now pass, the NaN and inf found at
extreme numbers included (issue 18 item 3: refused with a named ValueError, or rendered finite).
docs/reliability.md has the counts.
"""

from __future__ import annotations

import os
import random
import warnings
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from helpers import ROOT
from helpers.hardening_fuzz import SURFACES, NonFinite, Tally, prepare_folder, random_input, run_case

FINDINGS = ROOT / "tests" / "fuzz_findings"
SCALE = max(1, int(os.environ.get("DURER_HARDENING_EXAMPLES", "1")))
EXAMPLES = {"api": 4000 * SCALE, "reader": 3500 * SCALE, "cli": 2000 * SCALE}


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("fuzz")
    prepare_folder(path)
    return path


@pytest.fixture(autouse=True)
def _quiet() -> Iterator[None]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numpy's warnings on extreme values are not failures
        yield


def fuzz(surface: str, folder: Path, extremes: bool) -> tuple[Tally, list[NonFinite]]:
    """Run the surface's derandomised inputs; any finding but a non-finite pass raises at once."""
    tally = Tally()
    non_finite: list[NonFinite] = []

    @settings(derandomize=True, database=None, deadline=None, max_examples=EXAMPLES[surface],
              phases=[Phase.explicit, Phase.generate], suppress_health_check=list(HealthCheck))
    @given(st.randoms(use_true_random=False))
    def case(rng: random.Random) -> None:
        try:
            run_case(surface, random_input(rng), tally, folder, extremes)
        except NonFinite as finding:
            if not extremes:
                raise
            non_finite.append(finding)

    case()
    return tally, non_finite


#: The inputs reach what they are meant to: the least share of a surface's inputs with each outcome
#: (most API cases render and cast, many are refused, both ways; a tenth of the mutated scenes render).
REACHED = {
    "api": {"api rendered": 0.4, "api cast": 0.4, "api ValueError": 0.3, "api TypeError": 0.2},
    "reader": {"reader rendered": 0.08, "reader SceneFileError": 0.5},
    "cli": {"cli exit 0": 0.1, "cli exit 1": 0.1, "cli exit 2": 0.1},
}


@pytest.mark.slow
@pytest.mark.parametrize("surface", SURFACES)
def test_fuzz(folder, surface):
    """Ordinary numbers: every failure of the oracle fails the test."""
    tally, _ = fuzz(surface, folder, extremes=False)
    n = tally.inputs[surface]
    assert n >= EXAMPLES[surface] * 0.9, str(tally)
    shares = {outcome: tally.outcomes[outcome] / n for outcome in REACHED[surface]}
    assert all(shares[outcome] > least for outcome, least in REACHED[surface].items()), (shares, str(tally))


@pytest.mark.slow
@pytest.mark.parametrize("surface", SURFACES)
def test_fuzz_at_the_extremes(folder, surface):
    """The same with numbers from the extremes of both precisions: no crash, no traceback, no
    undocumented exception, and no NaN or inf in a pass (the commands write images, not passes)."""
    tally, non_finite = fuzz(surface, folder, extremes=True)
    assert tally.inputs[surface] >= EXAMPLES[surface] * 0.9, str(tally)
    if non_finite:
        raise NonFinite(f"{len(non_finite)} of {tally.renders} renders; the first: {non_finite[0]}")


def saved() -> list:
    return [pytest.param(path, id=f"{path.parent.name}/{path.stem}") for path in sorted(FINDINGS.glob("*/*.bin"))]


@pytest.mark.parametrize("path", saved())
def test_saved_findings_are_fixed(folder, path):
    run_case(path.parent.name, path.read_bytes(), Tally(), folder)


def test_every_saved_finding_records_what_failed():
    paths = sorted(FINDINGS.glob("*/*.bin"))
    assert len(paths) >= 2 and {p.parent.name for p in paths} <= {"api", "reader", "cli"}
    for path in paths:
        assert path.with_suffix(".txt").read_text().split(":")[0] in ("Finding", "NonFinite"), path
