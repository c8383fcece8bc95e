"""The hardening fuzz of tests/test_hardening_fuzz.py for as long as asked, crashes and hangs included.

    python bench/fuzz_hardening.py --surface reader --seconds 3600 [--engine atheris] [--out fuzz-out]
        [--seed N] [--timeout 60] [--ordinary]

Surfaces: api (durer.Scene, render, cast), reader (mutated 6.837 scenes), cli (`python -m durer`),
or all (case by case in turn); tests/helpers/hardening_fuzz.py holds them and the oracle. The cases
run in a child process that this one watches: a case that kills it (a signal) or runs longer than
--timeout seconds is saved as OUT/<surface>/crash-<hash>.bin or hang-<hash>.bin and the child is
started again; an oracle failure (a traceback, an undocumented exception, NaN or inf in a pass) is
saved by the child as finding-<hash>.bin with finding-<hash>.txt saying what failed (at most three
inputs per distinct failure). Every minute and at the end it prints the inputs per surface and what
became of them; the exit status is 1 if anything was found. A NaN or inf in a pass of a case that drew
a number beyond 1e-6..1e6 in magnitude is counted apart (NonFinite): a finding at the extremes.

--engine random (default) draws the bytes from Python's random (--seed to repeat a run); --engine
atheris lets atheris (pip install -e ".[fuzz]") mutate them, guided by the coverage of the durer
package's Python code. `--replay FILE...` reruns saved inputs and prints what each does now.
docs/reliability.md says what the fuzz checks and what it found.
"""

from __future__ import annotations

import argparse
import faulthandler
import hashlib
import json
import os
import random
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the fuzz lives with the tests
SURFACES = ("api", "reader", "cli")
CURRENT = ".current"  # the input being run, where the watcher finds it if the child dies
PER_FAILURE = 3  # inputs saved per distinct failure


def parse_arguments(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--surface", choices=(*SURFACES, "all"), default="all")
    parser.add_argument("--seconds", type=float, default=60.0, help="how long to run (default 60)")
    parser.add_argument("--engine", choices=("random", "atheris"), default="random")
    parser.add_argument("--seed", type=int, default=None, help="seed of the random engine (default: random)")
    parser.add_argument("--ordinary", action="store_true",
                        help="numbers within 1e-6..1e6 in magnitude only (the extremes left out)")
    parser.add_argument("--timeout", type=float, default=60.0, help="a case running longer is a hang (default 60 s)")
    parser.add_argument("--out", type=Path, default=Path("fuzz-out"), help="where inputs are saved (default fuzz-out)")
    parser.add_argument("--replay", type=Path, nargs="+", metavar="FILE", help="rerun saved inputs and stop")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.seconds <= 0 or args.timeout <= 0:
        parser.error("--seconds and --timeout must be > 0")
    return args


# --- the child: runs cases until its time is up ---------------------------------------------------

class Child:
    """Runs cases of the chosen surfaces, saving each input to OUT/.current first and every oracle
    failure as a finding; prints its tally as a JSON line every few seconds and at the end."""

    def __init__(self, args: argparse.Namespace, fuzz) -> None:  # noqa: ANN001 - the helpers module
        self.fuzz = fuzz
        self.args = args
        self.surfaces = SURFACES if args.surface == "all" else (args.surface,)
        self.tally = fuzz.Tally()
        self.findings: Counter = Counter()  # per surface and distinct failure
        self.folder = Path(tempfile.mkdtemp(prefix="durer-fuzz-"))
        fuzz.prepare_folder(self.folder)
        args.out.mkdir(parents=True, exist_ok=True)
        self.current = os.open(args.out / CURRENT, os.O_WRONLY | os.O_CREAT, 0o644)
        self.last_report = time.monotonic()
        self.count = 0

    def one(self, data: bytes) -> None:
        surface = self.surfaces[data[0] % len(self.surfaces)] if data and len(self.surfaces) > 1 else self.surfaces[0]
        os.ftruncate(self.current, 0)
        os.pwrite(self.current, surface.encode() + b"\n" + data, 0)
        faulthandler.dump_traceback_later(self.args.timeout, exit=True)
        try:
            self.fuzz.run_case(surface, data, self.tally, self.folder, not self.args.ordinary)
        except self.fuzz.Finding as finding:
            self.save(surface, data, f"{type(finding).__name__}: {finding}")
        finally:
            faulthandler.cancel_dump_traceback_later()
        self.count += 1
        if time.monotonic() - self.last_report > 5:
            self.report()

    def save(self, surface: str, data: bytes, message: str) -> None:
        key = f"{surface}: {message.split(chr(10))[0][:120]}"
        self.findings[key] += 1
        if self.findings[key] <= PER_FAILURE:
            name = f"finding-{hashlib.sha1(data).hexdigest()[:16]}"
            folder = self.args.out / surface
            folder.mkdir(parents=True, exist_ok=True)
            (folder / f"{name}.bin").write_bytes(data)
            (folder / f"{name}.txt").write_text(message + "\n")

    def report(self) -> None:
        self.last_report = time.monotonic()
        line = {"inputs": dict(self.tally.inputs), "outcomes": dict(self.tally.outcomes), "renders": self.tally.renders,
                "pixels": self.tally.pixels, "findings": dict(self.findings)}
        print(json.dumps(line), flush=True)


def run_child(args: argparse.Namespace) -> int:
    import warnings

    warnings.simplefilter("ignore")  # numpy's warnings on extreme values are not failures
    if args.engine == "atheris":
        import atheris

        with atheris.instrument_imports(include=["durer"]):
            from helpers import hardening_fuzz
        child = Child(args, hardening_fuzz)
        atheris.Setup([sys.argv[0], f"-max_total_time={max(1, int(args.seconds))}", "-rss_limit_mb=4096",
                       f"-timeout={int(args.timeout) + 5}", f"-artifact_prefix={args.out}/"], child.one)
        try:
            atheris.Fuzz()
        finally:
            child.report()
        return 0
    from helpers import hardening_fuzz

    child = Child(args, hardening_fuzz)
    rng = random.Random(args.seed)
    end = time.monotonic() + args.seconds
    while time.monotonic() < end:
        child.one(hardening_fuzz.random_input(rng))
    child.report()
    return 0


# --- the watcher: restarts the child after a crash or a hang ---------------------------------------

def watch(args: argparse.Namespace) -> int:
    start = time.monotonic()
    totals: dict[str, Counter] = {"inputs": Counter(), "outcomes": Counter(), "findings": Counter()}
    renders = pixels = 0
    crashes: Counter = Counter()
    runs = 0
    next_print = start + 60
    while (left := args.seconds - (time.monotonic() - start)) > 1:
        command = [sys.executable, __file__, "--child", "--surface", args.surface, "--seconds", f"{left:.0f}",
                   "--engine", args.engine, "--timeout", str(args.timeout), "--out", str(args.out)]
        command += ["--ordinary"] if args.ordinary else []
        if args.seed is not None:
            command += ["--seed", str(args.seed + runs)]
        runs += 1
        last: dict = {}
        with tempfile.TemporaryFile("w+") as errors:  # a file: a full pipe would stall the child
            child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=errors, text=True)
            for line in child.stdout:
                if line.startswith("{"):
                    last = json.loads(line)
                    if time.monotonic() > next_print:
                        next_print += 60
                        print(f"{time.monotonic() - start:6.0f} s  {summary(totals, last, crashes)}", flush=True)
            child.wait()
            errors.seek(0)
            stderr = errors.read()
        for name in totals:
            totals[name].update(last.get(name, {}))
        renders, pixels = renders + last.get("renders", 0), pixels + last.get("pixels", 0)
        if child.returncode != 0:
            kind = "hang" if "Timeout (" in stderr else "crash"
            saved = keep_current(args.out, kind)
            crashes[kind] += 1
            print(f"{kind} (exit status {child.returncode}), input saved as {saved}:\n{stderr[-3000:]}", flush=True)
    print(f"done in {time.monotonic() - start:.0f} s, {runs} child run(s): {summary(totals, {}, crashes)}; "
          f"{renders} renders, {pixels} pixels checked")
    for name, count in totals["findings"].most_common():
        print(f"  {count:6} x {name}")
    found = sum(totals["findings"].values()) + sum(crashes.values())
    print(f"outcomes: {dict(totals['outcomes'].most_common())}")
    return 1 if found else 0


def summary(totals: dict[str, Counter], running: dict, crashes: Counter) -> str:
    inputs = totals["inputs"] + Counter(running.get("inputs", {}))
    findings = totals["findings"] + Counter(running.get("findings", {}))
    extreme = sum(n for key, n in findings.items() if ": NonFinite: " in key)
    return (f"inputs {sum(inputs.values())} {dict(inputs)}; findings {sum(findings.values()) - extreme}, "
            f"crashes {crashes['crash']}, hangs {crashes['hang']}; NaN/inf from extreme numbers {extreme}")


def keep_current(out: Path, kind: str) -> Path:
    surface, _, data = (out / CURRENT).read_bytes().partition(b"\n")
    folder = out / surface.decode()
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{kind}-{hashlib.sha1(data).hexdigest()[:16]}.bin"
    path.write_bytes(data)
    return path


def replay(paths: list[Path]) -> int:
    import warnings

    from helpers import hardening_fuzz

    warnings.simplefilter("ignore")
    folder = Path(tempfile.mkdtemp(prefix="durer-fuzz-"))
    hardening_fuzz.prepare_folder(folder)
    failed = 0
    for path in paths:
        surface = path.parent.name
        try:
            hardening_fuzz.run_case(surface, path.read_bytes(), hardening_fuzz.Tally(), folder)
            print(f"{path}: passes")
        except hardening_fuzz.Finding as finding:
            failed += 1
            print(f"{path}: {finding}")
    return 1 if failed else 0


def main(argv: list[str] | None = None) -> int:
    args = parse_arguments(argv)
    if args.replay:
        return replay(args.replay)
    return run_child(args) if args.child else watch(args)


if __name__ == "__main__":
    sys.exit(main())
