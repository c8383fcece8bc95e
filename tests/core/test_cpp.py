"""The C++ unit tests of the geometry kernels (cpp/tests, doctest), built and run through ctest."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BUILD = ROOT / "build" / "cpp-tests"


def _tool(name: str) -> str:
    """The venv's CMake/ctest (installed by .ci/setup), else the system's."""
    local = Path(sys.executable).parent / name
    found = str(local) if local.exists() else shutil.which(name)
    assert found, f"{name} not found: run `bash .ci/setup`"
    return found


@pytest.mark.slow
def test_cpp_unit_tests_pass():
    configure = [
        _tool("cmake"), "-S", str(ROOT), "-B", str(BUILD), "-G", "Ninja", f"-DCMAKE_MAKE_PROGRAM={_tool('ninja')}",
        "-DDURER_BUILD_TESTS=ON", "-DCMAKE_BUILD_TYPE=Release",
    ]
    if shutil.which("ccache"):
        configure.append("-DCMAKE_CXX_COMPILER_LAUNCHER=ccache")
    env = {**os.environ, "CCACHE_BASEDIR": str(ROOT.parent)}
    steps = [
        configure,
        [_tool("cmake"), "--build", str(BUILD), "--target", "durer_cpp_test_binaries"],
        [_tool("ctest"), "--test-dir", str(BUILD), "--output-on-failure"],
    ]
    for step in steps:
        run = subprocess.run(step, cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, f"{' '.join(step)} failed:\n{run.stdout[-4000:]}\n{run.stderr[-4000:]}"
    assert "100% tests passed" in run.stdout
