#!/usr/bin/env bash
# Fuzzing (docs/reliability.md): installs clang's libFuzzer and sanitizer runtimes when missing,
# builds the fuzz targets of Testing/Fuzz with -fsanitize=fuzzer,address,undefined in build-fuzz,
# and runs each for SECONDS (default 30) as the CTest tests labelled `fuzz`. Findings are written
# to build-fuzz/fuzz-findings/NAME/ (crash-*, leak-*, timeout-*, oom-*); new coverage to
# build-fuzz/fuzz-corpus/NAME/. The repository's seeds (Testing/Fuzz/corpus) are only read.
#
#   scripts/fuzz.sh            every target, 30 s each
#   scripts/fuzz.sh 600        every target, 10 minutes each
#   scripts/fuzz.sh 60 nrrd    one target (a CTest regex on Fuzz.NAME)
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$here"
seconds=${1:-30}
only=${2:-}
BUILD_DIR=${FUZZ_BUILD_DIR:-build-fuzz}
JOBS=${TETFLOW_JOBS:-$(nproc)}
case "$seconds" in ''|*[!0-9]*) echo "fuzz: SECONDS must be a whole number, got '$seconds'" >&2; exit 2 ;; esac

# The normal build's packages and clang's (only those missing).
"$here/scripts/setup.sh" --deps-only clang-14 libclang-rt-14-dev libomp-14-dev

if [ ! -f "$BUILD_DIR/CMakeCache.txt" ]; then
  CC=clang-14 CXX=clang++-14 cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTETFLOW_FUZZ=ON -DTETFLOW_WITH_PETSC=OFF
fi
cmake -S . -B "$BUILD_DIR" -DTETFLOW_FUZZ_SECONDS="$seconds" >/dev/null
cmake --build "$BUILD_DIR" -j "$JOBS"
cd "$BUILD_DIR"
# One target at a time: each libFuzzer process uses one core, and the per-target time stays what
# was asked for.
exec ctest -L fuzz --output-on-failure ${only:+-R "Fuzz\\.($only)"}
