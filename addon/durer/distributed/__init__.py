"""Batch rendering, locally or on a Dask cluster: many cameras or scenes (`render_many`), the tiles
of one large image (`render_tiles`) and the frames of a .blend file (`durer.distributed.frames`,
behind ``python -m durer render --workers N`` / ``--scheduler ADDRESS``).

Dask is the optional extra ``durer[distributed]``: without a client everything renders in this
process and Dask is not imported. See docs/distributed.md.
"""

from __future__ import annotations

from .batch import render_many
from .client import cluster
from .tiles import render_tiles, tile_regions

__all__ = ["cluster", "render_many", "render_tiles", "tile_regions"]
