#!/usr/bin/env bash
# ThreadSanitizer suite (docs/reliability.md): installs clang and LLVM's OpenMP when missing,
# builds TetFlow with -fsanitize=thread in build-tsan (clang 14, LLVM's libomp: GCC's libgomp is
# not instrumented, so every OpenMP barrier would look like a race), and runs the suite with
# LLVM's Archer tool so that OpenMP's barriers, reductions and atomics are seen. The GUI and the
# benchmarks are not built. Suppressions, each with its reason: Testing/Sanitizers/SanitizerDefaults.cpp.
#
#   scripts/tsan.sh            the whole suite (about 25 min to build, 20 to run, on 2 cores)
#   scripts/tsan.sh REGEX      only the CTest tests matching REGEX, e.g. 'Cleaver|Executor|Cli'
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$here"
only=${1:-}
BUILD_DIR=${TSAN_BUILD_DIR:-build-tsan}
JOBS=${TETFLOW_JOBS:-$(nproc)}

"$here/scripts/setup.sh" --deps-only clang-14 libclang-rt-14-dev libomp-14-dev

if [ ! -f "$BUILD_DIR/CMakeCache.txt" ]; then
  CC=clang-14 CXX=clang++-14 cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DTETFLOW_SANITIZE=thread -DTETFLOW_BUILD_GUI=OFF -DTETFLOW_BUILD_BENCHMARKS=OFF -DTETFLOW_WITH_PETSC=OFF
fi
cmake --build "$BUILD_DIR" -j "$JOBS"
archer=/usr/lib/llvm-14/lib/libarcher.so
[ -f "$archer" ] || { echo "tsan: $archer is missing (package libomp-14-dev)" >&2; exit 1; }
export OMP_TOOL_LIBRARIES="$archer"
# Archer's own advice: reports from libomp's uninstrumented code are false positives.
export TSAN_OPTIONS="ignore_noninstrumented_modules=1 ${TSAN_OPTIONS:-}"
cd "$BUILD_DIR"
exec ctest -j "$JOBS" --output-on-failure --timeout 1500 ${only:+-R "$only"}
