"""End-to-end render time of a .blend file with Dürer and with Cycles, in the same process.

    python bench/showcase_vs_cycles.py [scenes/showcase.blend] [--size 1920x1080] [--samples 1] [--repeats 5]

Both go through bpy.ops.render.render() (what the Render button runs), so the times include scene
export and Blender's own overhead; Cycles renders on the CPU with the same samples, no denoising.
Each engine's figure is the median of --repeats renders after one warm-up; the machine is printed.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from collections.abc import Sequence
from pathlib import Path


def compare_engines(
    path: str | Path,
    width: int = 1920,
    height: int = 1080,
    samples: int = 1,
    engines: Sequence[str] = ("DURER", "CYCLES"),
    repeats: int = 1,
) -> dict:
    """{engine: {"seconds": median wall time, ...}} for rendering `path` at width x height."""
    import bpy

    from durer.blender import engine as durer_engine
    from durer.blender import register

    register()
    bpy.ops.wm.open_mainfile(filepath=str(Path(path).resolve()), load_ui=False)
    s = bpy.context.scene
    s.render.resolution_x, s.render.resolution_y = width, height
    s.render.resolution_percentage = 100
    s.durer.samples = samples
    out: dict = {"file": str(path), "width": width, "height": height, "samples": samples}
    for name in engines:
        s.render.engine = name
        if name == "CYCLES":
            c = s.cycles
            c.device, c.samples, c.use_denoising, c.use_adaptive_sampling = "CPU", samples, False, False
        bpy.ops.render.render()  # warm-up: first-render set-up (kernels, caches) is not measured
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            bpy.ops.render.render()
            times.append(time.perf_counter() - t0)
        entry = {"seconds": statistics.median(times), "min": min(times), "max": max(times), "runs": repeats}
        if name == "DURER":
            info = durer_engine.last_render
            if info.error:
                raise RuntimeError(info.error)
            entry.update(
                export_seconds=info.export_seconds,
                render_seconds=info.render_seconds,
                mrays_per_s=info.stats.get("mrays_per_s"),
                spheres=info.spheres,
                planes=info.planes,
            )
        out[name.lower()] = entry
    if "durer" in out and "cycles" in out:
        out["speedup"] = out["cycles"]["seconds"] / out["durer"]["seconds"]
    return out


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python bench/showcase_vs_cycles.py", description=__doc__.split("\n\n")[0])
    p.add_argument("file", nargs="?", default=str(Path(__file__).resolve().parents[1] / "scenes" / "showcase.blend"))
    p.add_argument("--size", default="1920x1080")
    p.add_argument("--samples", type=int, default=1)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--json", action="store_true", help="print the raw figures as JSON")
    args = p.parse_args(argv)
    w, h = (int(v) for v in args.size.lower().split("x"))
    out = compare_engines(args.file, w, h, args.samples, repeats=args.repeats)
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    from durer.reports.machine import machine

    print(f"{Path(args.file).name} at {w}x{h}, {args.samples} sample(s); median of {args.repeats} runs; {machine()}, "
          f"{time.strftime('%Y-%m-%d')}")
    d, c = out["durer"], out["cycles"]
    print(f"  Dürer:  {d['seconds']:.3f} s end to end (export {d['export_seconds']:.3f} s, render "
          f"{d['render_seconds']:.3f} s, {d['mrays_per_s']:.1f} Mrays/s; {d['spheres']} spheres, {d['planes']} planes)")
    print(f"  Cycles: {c['seconds']:.3f} s end to end (CPU)")
    print(f"  Cycles / Dürer: {out['speedup']:.1f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
