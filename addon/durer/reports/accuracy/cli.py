"""`python -m durer accuracy`: measure, write the page and its plots, print a summary."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from .. import check_writable, numerics
from . import __doc__ as package_doc
from .markdown import markdown, summary
from .measure import Config, Report, measure
from .plots import plot_adaptive, plot_antialiasing, plot_presets


def write_report(report: Report, output: Path) -> list[Path]:
    """The page and its plots (accuracy-*.png next to it); returns the files written."""
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    stem = output.stem
    written, plots = [], {}
    for aa in report.antialiasing:
        path = output.parent / f"{stem}-aa-{aa.scene}.png"
        plot_antialiasing(aa, path)
        plots[aa.scene] = path.name
        written.append(path)
        point = aa.heatmap_point(report.config.baselines)
        if point is not None:
            path = output.parent / f"{stem}-adaptive-{aa.scene}.png"
            plot_adaptive(point, aa.scene, path)
            plots[f"adaptive-{aa.scene}"] = path.name
            written.append(path)
    if report.sweep:
        path = output.parent / f"{stem}-sphere-methods.png"
        numerics.plot(report.sweep, path)
        plots["sphere-methods"] = path.name
        written.append(path)
    if report.presets:
        path = output.parent / f"{stem}-presets.png"
        plot_presets(report.presets, next((a for a in report.antialiasing if a.scene == "showcase"), None), path)
        plots["presets"] = path.name
        written.append(path)
    output.write_text(markdown(report, plots))
    return [output, *written]


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(prog="python -m durer accuracy", description=package_doc.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="80x45 images, spp 1, 4, 16 against a 256-spp reference, single timings (seconds)")
    parser.add_argument("--output", default="docs/accuracy.md",
                        help="Markdown page to write; plots go next to it (default %(default)s)")
    args = parser.parse_args(argv)
    try:  # before the measurement, which takes minutes
        check_writable(args.output, "--output")
    except ValueError as error:
        parser.error(str(error))
    config = Config.quick_config() if args.quick else Config.full()
    command = " ".join(["python -m durer accuracy", *argv])
    report = measure(config, command)
    print(summary(report))
    try:
        written = write_report(report, Path(args.output))
    except OSError as error:  # the disk filled up, say: the summary is printed above
        print(f"{parser.prog}: error: cannot write {args.output}: {error}", file=sys.stderr)
        return 1
    print(f"\nwrote {', '.join(str(p) for p in written)} in {report.seconds:.1f} s")
    return 0
