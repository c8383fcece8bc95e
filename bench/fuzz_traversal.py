"""The differential traversal fuzz of tests/core/test_traversal_fuzz.py, for as long as asked.

    python bench/fuzz_traversal.py --minutes 10 [--seed 1] [--max-primitives 300]

Runs rounds of fresh random cases (hypothesis, seeded by --seed + round when --seed is given, so a
run can be repeated) until the time is up, each round also as many camera views of random sphere
clouds (tests/helpers/view_fuzz.py: a render's camera rays against a cast of the same rays),
printing after each round what it has tried: cases, primitives, rays of the full scenes and their
hits, rays cast in all (the brute force casts each ray once per primitive), view cases. On the first difference from the brute force it stops, prints hypothesis's
shrunk case reduced further and a reproduction script, and exits with status 1.
docs/reliability.md says what the fuzz checks; bench/fuzz_sanitized.sh runs it under ASan/UBSan.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the fuzz lives with the tests

from hypothesis import HealthCheck, settings  # noqa: E402

from helpers import view_fuzz  # noqa: E402
from helpers.traversal_fuzz import Tally, fuzz  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=float, default=1.0, help="how long to run (default 1)")
    parser.add_argument("--seed", type=int, default=None, help="seed of the first round (default: random)")
    parser.add_argument("--max-primitives", type=int, default=300, help="largest count of a kind (default 300)")
    parser.add_argument("--per-round", type=int, default=25, help="cases per round (default 25)")
    args = parser.parse_args(argv)
    cfg = settings(database=None, deadline=None, max_examples=args.per_round,
                   suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
    tally = Tally()
    views = 0
    start = time.monotonic()
    end = start + 60 * args.minutes
    rounds = 0
    while time.monotonic() < end:
        seed = None if args.seed is None else args.seed + rounds
        try:
            fuzz(cfg, tally, args.max_primitives, seed)
            views += view_fuzz.fuzz(cfg, seed)
        except AssertionError as difference:
            print(f"round {rounds + 1} (seed {seed}): DIFFERENCE\n{difference}", flush=True)
            print(f"before it: {tally}; {views} view cases")
            return 1
        rounds += 1
        print(f"{time.monotonic() - start:7.0f} s  round {rounds}: {tally}; {views} view cases", flush=True)
    print(f"no difference in {time.monotonic() - start:.0f} s, {rounds} rounds: {tally}; {views} view cases")
    return 0


if __name__ == "__main__":
    sys.exit(main())
