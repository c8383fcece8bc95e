"""Command line: `python -m durer demo | render | extension` (also installed as `durer`)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence


def demo(argv: Sequence[str]) -> int:
    """Render the built-in showcase scene with the core (no Blender needed)."""
    import durer
    from durer.render import PRECISIONS
    from durer.visualize import image_path

    parser = argparse.ArgumentParser(prog="python -m durer demo", description=demo.__doc__)
    parser.add_argument("--output", default="out/demo.png", help="image file (PNG, JPEG, ...); default %(default)s")
    parser.add_argument("--width", type=int, default=960)
    parser.add_argument("--height", type=int, default=540)
    parser.add_argument("--spp", type=int, default=16, help="samples per pixel (default %(default)s)")
    parser.add_argument("--precision", choices=PRECISIONS, default="double")
    args = parser.parse_args(argv)
    scene, camera = durer.showcase_scene()
    try:
        image_path(args.output)
        result = durer.render(scene, camera, args.width, args.height, spp=args.spp, precision=args.precision)
    except (TypeError, ValueError) as error:
        parser.error(str(error))
    except MemoryError:
        parser.error(f"not enough memory for a {args.width}x{args.height} image")
    try:
        path = durer.save_image(args.output, result.color).resolve()
    except OSError as error:
        print(f"python -m durer demo: error: cannot write {args.output}: {error.strerror or error}", file=sys.stderr)
        return 1
    stats = result.stats
    print(f"rendered {args.width}x{args.height}, {args.spp} spp, {stats['rays'] / 1e6:.1f} Mrays in "
          f"{stats['milliseconds']:.0f} ms ({stats['mrays_per_s']:.1f} Mrays/s, {stats['threads']} threads)")
    print(f"image written to {path}")
    return 0


def render(argv: Sequence[str]) -> int:
    """Render a .blend file with Dürer through Blender (needs the bpy module)."""
    from durer.blender import batch

    return batch.main(argv)


def extension(argv: Sequence[str]) -> int:
    """Build the Blender extension zip (dist/durer-<version>-<platform>.zip)."""
    from durer.blender import extension as ext

    return ext.main(argv)


def numerics(argv: Sequence[str]) -> int:
    """Sweep t's error by sphere method and precision as distance/radius grows (docs/numerics.md)."""
    from durer.reports import numerics as sweep

    return sweep.main(argv)


def accuracy(argv: Sequence[str]) -> int:
    """Measure what accuracy costs in time: samplers, precision, sphere methods, effects (docs/accuracy.md)."""
    from durer.reports.accuracy import cli

    return cli.main(argv)


def raytracer(argv: Sequence[str]) -> int:
    """Render an MIT 6.837 scene file with the course's options (-input, -size, -output, ...; docs/6837.md)."""
    from durer.course import raytracer as command

    return command.main(argv)


def gallery(argv: Sequence[str]) -> int:
    """Render the 6.837 corpus with its official command lines into docs/gallery.md."""
    from durer.course import gallery as report

    return report.main(argv)


COMMANDS = {"demo": demo, "render": render, "extension": extension, "numerics": numerics, "accuracy": accuracy,
            "raytracer": raytracer, "gallery": gallery}


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in COMMANDS:
        lines = [f"  {name:10} {command.__doc__}" for name, command in COMMANDS.items()]
        print("usage: python -m durer COMMAND [options]   (COMMAND --help for its options)\n\ncommands:")
        print("\n".join(lines))
        return 0 if argv and argv[0] in ("-h", "--help") else 2
    return COMMANDS[argv[0]](argv[1:])


if __name__ == "__main__":
    sys.exit(main())
