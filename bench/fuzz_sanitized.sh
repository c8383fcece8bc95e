#!/usr/bin/env bash
# The traversal fuzz under AddressSanitizer + UndefinedBehaviorSanitizer (docs/reliability.md).
#
#   bash bench/fuzz_sanitized.sh [MINUTES]        # default 5; DURER_SANITIZE=address,undefined
#
# Builds the package with -DDURER_SANITIZE (cmake/Sanitize.cmake) into its own virtual environment
# and build directory (build/sanitize/, never .venv), then runs tests/core/test_traversal_fuzz.py,
# tests/core/test_sphere_view.py, the adaptive sampler's (its worker pool), the moved spheres' (the
# parallel refit) and the threads' (cancel, progress) tests, and bench/fuzz_traversal.py for MINUTES
# under it. Python itself is not instrumented, so the ASan runtime is preloaded (it must come first,
# the C++ runtime after it) and leak detection is off (the interpreter's own
# allocations at exit are not leaks of ours). The first sanitizer report aborts the run with its
# stack; the exit status is non-zero then. Set DURER_NATIVE=1 to build one native code path only
# (quicker), CMAKE_CXX_COMPILER_LAUNCHER=ccache to reuse objects, DURER_FUZZ_SEED for a fixed seed.
set -euo pipefail
cd "$(dirname "$0")/.."

minutes=${1:-5}
sanitizers=${DURER_SANITIZE:-address,undefined}
root="$PWD/build/sanitize"
venv=$root/venv
say() { printf '\033[1m[fuzz_sanitized]\033[0m %s\n' "$*" >&2; }

if [ ! -x "$venv/bin/python" ]; then
  say "creating $venv"
  python3.11 -m venv "$venv"
  "$venv/bin/python" -m pip --disable-pip-version-check -q install "scikit-build-core>=0.10" "pybind11>=3" cmake ninja
fi
say "building durer with -fsanitize=$sanitizers (DURER_NATIVE=${DURER_NATIVE:-OFF}) in $root/cmake"
"$venv/bin/python" -m pip --disable-pip-version-check -q install --no-build-isolation \
  -C build-dir="$root/cmake" -C cmake.build-type=RelWithDebInfo \
  -C cmake.define.DURER_SANITIZE="$sanitizers" ".[test]"

preload=""
cxx=${CXX:-c++}
# libstdc++ right after the ASan runtime: ASan finds the C++ runtime's __cxa_throw at start-up, and
# the interpreter does not link it, so without it the first exception (a ValueError raised in C++)
# stops the run with a CHECK failure in ASan's interceptor.
case ",$sanitizers," in *,address,*) preload="$("$cxx" -print-file-name=libasan.so) $("$cxx" -print-file-name=libstdc++.so)" ;; esac
case ",$sanitizers," in *,thread,*) preload=$("$cxx" -print-file-name=libtsan.so) ;; esac
export LD_PRELOAD=$preload
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0:abort_on_error=1:strict_string_checks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
module=$(cd /tmp && "$venv/bin/python" -c 'import durer._core as m; print(m.__file__)')
# grep reads all of ldd's output (-q would stop at the first match, and pipefail would then see ldd's SIGPIPE)
if ! ldd "$module" | grep "san\." > /dev/null; then
  say "$module is not linked with a sanitizer runtime"; exit 1
fi
say "module $module; LD_PRELOAD=$LD_PRELOAD ASAN_OPTIONS=$ASAN_OPTIONS UBSAN_OPTIONS=$UBSAN_OPTIONS"

"$venv/bin/python" -m pytest -q -p no:cacheprovider tests/core/test_traversal_fuzz.py tests/core/test_sphere_view.py \
  tests/core/test_adaptive.py tests/core/test_move_spheres.py tests/core/test_threads.py
seed=()
[ -n "${DURER_FUZZ_SEED:-}" ] && seed=(--seed "$DURER_FUZZ_SEED")
"$venv/bin/python" bench/fuzz_traversal.py --minutes "$minutes" "${seed[@]}"
