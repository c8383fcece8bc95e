"""The README's Python example runs as written."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_python_example_runs(tmp_path, monkeypatch):
    blocks = [b for b in re.findall(r"```python\n(.*?)```", README.read_text(), re.S) if "durer.Scene()" in b]
    assert blocks, "the README has a Python example of the core API"
    monkeypatch.chdir(tmp_path)  # it writes into out/
    namespace: dict = {}
    exec(compile(blocks[0].replace("progress=print", "progress=None"), "README.md", "exec"), namespace)
    result = namespace["result"]
    assert result.color.shape == (480, 640, 4) and result.stats["shadow_rays"] > 0
    assert sorted(os.listdir(tmp_path / "out")) == ["depth.png", "image.png", "normal.png"]
    assert namespace["hits"].t.shape == (640 * 480,)
    lit = namespace["lit"]
    assert lit.dtype == bool and lit.shape == (int(np.isfinite(namespace["hits"].t).sum()),) and 0 < lit.sum() < lit.size


def test_readme_dask_example_runs_on_a_local_cluster(tmp_path, monkeypatch):
    """The README's Dask example as written but for its sizes: 2 workers, 6 cameras, small images."""
    block = next(b for b in re.findall(r"```python\n(.*?)```", README.read_text(), re.S) if "cluster(" in b)
    small = (block.replace("workers=4", "workers=2").replace("240, endpoint", "6, endpoint")
             .replace("640, 480", "32, 24").replace("16384, 9216", "64, 36"))
    assert small.count("workers=2") == small.count("6, endpoint") == small.count("32, 24") == small.count("64, 36") == 1
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__main__"}
    exec(compile(small, "README.md", "exec"), namespace)
    assert sorted(os.listdir(tmp_path)) == [f"depth_{i:05d}.npy" for i in range(6)]
    depths = [np.load(tmp_path / f"depth_{i:05d}.npy") for i in range(6)]
    assert all(d.shape == (24, 32) and np.isfinite(d).mean() > 0.2 for d in depths)  # the turntable sees the scene
    assert namespace["poster"].color.shape == (36, 64, 4)
