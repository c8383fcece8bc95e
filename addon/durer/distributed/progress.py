"""One progress bar over all the tasks of a batch, and its summary line."""

from __future__ import annotations

import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, TextIO


@dataclass
class Tally:
    """What a batch did: tasks done by each worker, failures, and the wall time."""

    unit: str
    total: int
    skipped: int = 0
    done_by: Counter = field(default_factory=Counter)
    failed: dict[Any, str] = field(default_factory=dict)  # task (frame number, index) -> error
    started: float = field(default_factory=time.perf_counter)

    @property
    def done(self) -> int:
        return sum(self.done_by.values())

    def summary(self) -> str:
        """'12 frames: 10 rendered, 1 skipped (complete), 1 failed in 8.1 s (1.2 frames/s); per worker: ...'"""
        seconds = time.perf_counter() - self.started
        rate = self.done / seconds if seconds > 0 else float("inf")
        parts = [f"{self.done} rendered"]
        if self.skipped:
            parts.append(f"{self.skipped} skipped (complete)")
        parts.append(f"{len(self.failed)} failed")
        workers = ", ".join(f"{name} {count}" for name, count in sorted(self.done_by.items()))
        return (f"{self.total} {self.unit}s: {', '.join(parts)} in {seconds:.1f} s ({rate:.2f} {self.unit}s/s)"
                + (f"; per worker: {workers}" if workers else ""))


def progress_bar(enabled: bool, total: int, unit: str, file: TextIO | None = None) -> Any:
    """A tqdm bar over `total` tasks (rate in unit/s and an ETA), or None when not `enabled`."""
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit=unit, desc=f"{unit}s", file=file or sys.stderr, dynamic_ncols=True,
                smoothing=0.1)
