#!/usr/bin/env bash
# TetFlow set-up: install missing Debian packages (only when absent), configure and build in
# Release with all cores. Quick when nothing changed: dpkg check + an incremental build.
#
#   scripts/setup.sh            install + build
#   scripts/setup.sh --run      ... then run the main job on the bundled default input
#   scripts/setup.sh --test     ... then run the unit and integration tests (CTest labels, tiers in
#                               Testing/Tiers.cmake); with CI set (as on CI) or
#                               TETFLOW_SANITIZER_SUITE=1, then build the test programs under ASan +
#                               UBSan and run the unit tests and the integration tests labelled memory
#   scripts/setup.sh --test --all   ... every tier, the studies too (not on CI)
#   scripts/setup.sh --deps-only [PKG...]   install the missing packages (and PKG...) and stop
# Further arguments after --test [--all] go to ctest (e.g. -R Cleaver). --test prints the wall time
# of each phase and the total at the end.
#
# Environment: BUILD_DIR (default: build), TETFLOW_JOBS (default: nproc).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$here"
BUILD_DIR=${BUILD_DIR:-build}
JOBS=${TETFLOW_JOBS:-$(nproc)}

# Wall time of each phase, printed at the end of --test (also when a phase fails).
phase_names=()
phase_seconds=()
phase_begin=$SECONDS
phase() { # phase NAME: the time since the last phase ends here, under NAME
  phase_names+=("$1")
  phase_seconds+=($((SECONDS - phase_begin)))
  phase_begin=$SECONDS
}
print_phases() {
  local status=$? i
  [ ${#phase_names[@]} -gt 0 ] || return 0
  echo "setup: wall time per phase$([ $status -ne 0 ] && echo " (stopped with status $status)")"
  for i in "${!phase_names[@]}"; do
    printf '  %-18s %6d s\n' "${phase_names[$i]}" "${phase_seconds[$i]}"
  done
  printf '  %-18s %6d s (%d min %d s)\n' total "$SECONDS" $((SECONDS / 60)) $((SECONDS % 60))
}
if [ "${1:-}" = "--test" ]; then trap print_phases EXIT; fi

packages=(
  build-essential cmake pkg-config
  qt6-base-dev libqt6opengl6-dev
  libvtk9-dev libeigen3-dev libboost-dev libboost-program-options-dev
  libtet1.5-dev libgtest-dev libspectra-dev zlib1g-dev libpugixml-dev
  libpetsc-real-dev openmpi-bin libsuitesparse-dev libopenblas0-pthread
  libocct-foundation-dev libocct-modeling-data-dev libocct-modeling-algorithms-dev
  libocct-data-exchange-dev libocct-ocaf-dev libocct-visualization-dev
  xvfb xauth libgl1-mesa-dri fonts-dejavu-core mricron-data
  gmsh python3-meshio python3-nibabel python3-mne
)
# --deps-only PKG...: these too (scripts/fuzz.sh passes clang's).
if [ "${1:-}" = "--deps-only" ]; then packages+=("${@:2}"); fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing missing Debian packages: ${missing[*]}"
  sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -qq
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "setup: all Debian packages present"
fi

if [ "${1:-}" = "--deps-only" ]; then exit 0; fi
phase install

if [ ! -f "$BUILD_DIR/CMakeCache.txt" ]; then
  cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release
fi
cmake --build "$BUILD_DIR" -j "$JOBS"
phase "Release build"

case "${1:-}" in
  --run)
    shift
    exec "$here/scripts/main-job.sh" "$BUILD_DIR" "$@"
    ;;
  --test)
    shift
    tiers='^(unit|integration)$'
    if [ "${1:-}" = "--all" ]; then tiers='.'; shift; fi
    # Tests run $JOBS at a time, each with OpenMP on every core: waiting OpenMP threads sleep
    # instead of spinning on a core another test needs (22 % less wall time for a batch of the
    # heaviest tests under ASan, 2026-12-03). Results do not depend on it.
    export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
    (cd "$BUILD_DIR" && ctest --output-on-failure -j "$JOBS" -L "$tiers" "$@")
    phase "Release suite"
    # On CI (CI set) or when asked, again under ASan + UBSan (docs/reliability.md "Sanitizers"): only the
    # programs the tests run (no GUI, benchmarks or tools they do not need), then the unit tests
    # and the integration tests labelled memory (Testing/Tiers.cmake). Without PETSc: OpenMPI and
    # PETSc are not instrumented and keep their allocations until exit, so the PETSc tests run in
    # the Release half only (here they say they are skipped).
    if [ -n "${CI:-}" ] || [ "${TETFLOW_SANITIZER_SUITE:-0}" = 1 ]; then
      ASAN_DIR=${ASAN_BUILD_DIR:-build-asan}
      if [ ! -f "$ASAN_DIR/CMakeCache.txt" ]; then
        cmake -S . -B "$ASAN_DIR" -DTETFLOW_SANITIZE=address,undefined -DCMAKE_BUILD_TYPE=RelWithDebInfo \
          -DTETFLOW_BUILD_GUI=OFF -DTETFLOW_BUILD_BENCHMARKS=OFF -DTETFLOW_WITH_PETSC=OFF
      fi
      echo "setup: the unit and memory tests under AddressSanitizer + UndefinedBehaviorSanitizer ($ASAN_DIR)"
      cmake --build "$ASAN_DIR" -j "$JOBS" --target tetflow_algorithms_tests tetflow_dataflow_tests tetflow fuzz_corpus
      phase "sanitizer build"
      (cd "$ASAN_DIR" && ctest --output-on-failure -j "$JOBS" -L '^(unit|memory)$' "$@")
      phase "sanitizer suite"
    fi
    ;;
  "") ;;
  *) echo "setup: unknown option '$1' (use --run, --test or --test --all)" >&2; exit 2 ;;
esac
