#!/bin/bash
# The peer benchmark against CGAL's Mesh_3 (issue 26 item 3), as one command: installs Debian's
# libcgal-dev when it is absent (apt-get, as root), configures the build directory so that CMake
# finds CGAL, builds peer_cgal_benchmark only and runs it, writing
# Testing/Benchmarks/results/peer_cgal.txt (or $RESULTS). What it measures and how: the comment at
# the top of Testing/Benchmarks/peer_cgal_benchmark.cpp. Arguments are passed to the benchmark
# (e.g. --quick, --no-fidelity, --inputs phantom,spheres).
#   BUILD_DIR  build directory (default: build in the clone; configured as Release when new)
#   JOBS       parallel build jobs (default 2)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
BUILD_DIR=${BUILD_DIR:-$ROOT/build}
JOBS=${JOBS:-2}
RESULTS=${RESULTS:-$ROOT/Testing/Benchmarks/results/peer_cgal.txt}

if ! dpkg -s libcgal-dev >/dev/null 2>&1; then
  echo "peer_cgal.sh: installing libcgal-dev (CGAL, header-only; pulls GMP, MPFR, Boost headers)"
  apt-get install -y libcgal-dev || {
    echo "peer_cgal.sh: apt-get install libcgal-dev failed (run as root, or install it first)" >&2
    exit 1
  }
fi

if [ -f "$BUILD_DIR/CMakeCache.txt" ]; then
  cmake -S "$ROOT" -B "$BUILD_DIR" -DTETFLOW_BUILD_BENCHMARKS=ON >/dev/null
else
  cmake -S "$ROOT" -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release -DTETFLOW_BUILD_BENCHMARKS=ON >/dev/null
fi
grep -q '^CGAL_DIR:PATH=.*-NOTFOUND' "$BUILD_DIR/CMakeCache.txt" && {
  echo "peer_cgal.sh: CMake did not find CGAL in $BUILD_DIR (see its configure output)" >&2
  exit 1
}
cmake --build "$BUILD_DIR" --target peer_cgal_benchmark -j"$JOBS"

mkdir -p "$(dirname "$RESULTS")"
"$BUILD_DIR/Testing/peer_cgal_benchmark" "$RESULTS" "$@"
echo "peer_cgal.sh: wrote $RESULTS"
