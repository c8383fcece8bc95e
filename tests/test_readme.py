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
