"""End-to-end render time of a .blend file with Dürer and with Cycles, in the same process.

    python -m durer.blender.bench scenes/showcase.blend [--size 1920x1080] [--samples 1]

Both go through bpy.ops.render.render() (what the Render button runs), so the times include scene
export and Blender's own overhead; Cycles renders on the CPU with the same samples, no denoising.
"""

from __future__ import annotations

import argparse
import json
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
    """{engine: {"seconds": best wall time, ...}} for rendering `path` at width x height."""
    import bpy

    from . import engine as durer_engine
    from . import register

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
        best = float("inf")
        for _ in range(repeats):
            t0 = time.perf_counter()
            bpy.ops.render.render()
            best = min(best, time.perf_counter() - t0)
        entry = {"seconds": best}
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
    p = argparse.ArgumentParser(prog="python -m durer.blender.bench", description=__doc__.split("\n\n")[0])
    p.add_argument("file")
    p.add_argument("--size", default="1920x1080")
    p.add_argument("--samples", type=int, default=1)
    p.add_argument("--repeats", type=int, default=1)
    args = p.parse_args(argv)
    w, h = (int(v) for v in args.size.lower().split("x"))
    print(json.dumps(compare_engines(args.file, w, h, args.samples, repeats=args.repeats), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
