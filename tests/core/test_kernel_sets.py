"""The hot kernels are compiled once per instruction set (CMakeLists.txt, render/Kernels.h): each set
must keep its inline and template code to itself, or an x86-64-v2 machine could run a copy compiled
for AVX2, or an AVX2 machine one compiled for AVX-512. Checked on the objects the installed module was
linked from, with binutils."""

from __future__ import annotations

import platform
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from durer import _core

ROOT = Path(__file__).resolve().parents[2]
ENTRY_POINTS = {"renderFloat", "renderDouble", "castFloat", "castDouble"}
# An instruction that only AVX machines run: a VEX-encoded mnemonic (v...) or a 256-bit register.
AVX_INSTRUCTION = re.compile(r"^\s*[0-9a-f]+:\s+(v[a-z0-9]+\s|.*%ymm)", re.MULTILINE)
# A register only AVX-512 has: a 512-bit one, a mask register, or one of xmm/ymm 16-31.
AVX512_REGISTER = re.compile(r"%zmm|%k[0-7]\b|%[xy]mm(1[6-9]|2[0-9]|3[01])\b")


def _kernel_objects() -> dict[str, Path]:
    found = {p.stem.removeprefix("durer_kernels_"): p for p in ROOT.glob("build/cp*/durer_kernels_*.o")}
    assert found, "no kernel set objects under build/: run `bash .ci/setup`"
    return found


def _tool(name: str) -> str:
    path = shutil.which(name)
    assert path, f"{name} (binutils) not found"
    return path


def _defined_globals(obj: Path) -> list[str]:
    out = subprocess.run([_tool("nm"), "--defined-only", "--extern-only", "-C", str(obj)], capture_output=True,
                         text=True, check=True).stdout
    return [line.split(" ", 2)[2] for line in out.splitlines() if line.strip()]


def test_each_kernel_set_exports_its_entry_points_and_nothing_else():
    for name, obj in _kernel_objects().items():
        symbols = _defined_globals(obj)
        assert {s.split("(")[0].split("::")[-1] for s in symbols} == ENTRY_POINTS, (name, symbols)
        assert all(s.startswith(f"durer::{name}::") for s in symbols), (name, symbols)


@pytest.mark.skipif(platform.machine() != "x86_64", reason="x86-64 builds three kernel sets; others build one")
def test_each_x86_set_uses_its_instructions_and_none_beyond():
    objects = _kernel_objects()
    if "native" in objects:
        pytest.skip("a DURER_NATIVE build has one kernel set, for the build machine")
    assert set(objects) == {"x86_64_v2", "x86_64_v3", "x86_64_v4"}
    disassembly = {
        name: subprocess.run([_tool("objdump"), "-d", "--no-show-raw-insn", str(obj)], capture_output=True, text=True,
                             check=True).stdout
        for name, obj in objects.items()
    }
    assert AVX_INSTRUCTION.search(disassembly["x86_64_v2"]) is None
    assert "%ymm" in disassembly["x86_64_v3"]
    assert AVX512_REGISTER.search(disassembly["x86_64_v3"]) is None
    assert AVX512_REGISTER.search(disassembly["x86_64_v4"]) is not None


def test_the_module_runs_the_best_set_this_cpu_supports():
    objects = _kernel_objects()
    if "native" in objects:
        assert _core.KERNEL_SET == "native"
        return
    flags = set()
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        flags = set(re.search(r"^flags\s*:(.*)$", cpuinfo.read_text(), re.MULTILINE).group(1).split())
    v3 = {"avx2", "fma", "bmi1", "bmi2", "f16c", "abm", "movbe"} <= flags
    v4 = v3 and {"avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl"} <= flags
    assert _core.KERNEL_SET == ("x86-64-v4" if v4 else "x86-64-v3" if v3 else "x86-64-v2")


def _sphere_methods_compiled(obj: Path) -> set[str]:
    """The sphere methods whose searches an object instantiates (Group::intersect<m> and below)."""
    out = subprocess.run([_tool("nm"), "-C", str(obj)], capture_output=True, text=True, check=True).stdout
    methods = {int(m) for m in re.findall(r"\(durer::SphereMethod\)(\d)", out)}
    return {_core.SPHERE_METHODS[m] for m in methods}


def test_only_the_baseline_set_compiles_the_lecture_sphere_methods():
    # The lecture's methods are there to compare accuracy: their searches are compiled once, in the
    # baseline set that every render and cast of theirs runs (Kernels.cpp), not in every set.
    objects = _kernel_objects()
    baseline = next(name for name in ("native", "generic", "x86_64_v2") if name in objects)
    assert _core.SPHERE_METHODS == ("algebraic", "geometric", "robust")  # the enum's order, which nm prints
    for name, obj in objects.items():
        expected = {"algebraic", "geometric", "robust"} if name == baseline else {"robust"}
        assert _sphere_methods_compiled(obj) == expected, name
