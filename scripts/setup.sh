#!/usr/bin/env bash
# TetFlow set-up: install missing Debian packages (only when absent), configure and build in
# Release with all cores. Quick when nothing changed: dpkg check + an incremental build.
#
#   scripts/setup.sh            install + build
#   scripts/setup.sh --run      ... then run the main job on the bundled default input
#   scripts/setup.sh --test     ... then run the whole test suite (CTest); with CI set (as on CI)
#                               or TETFLOW_SANITIZER_SUITE=1, then again under ASan + UBSan
#   scripts/setup.sh --deps-only [PKG...]   install the missing packages (and PKG...) and stop
#
# Environment: BUILD_DIR (default: build), TETFLOW_JOBS (default: nproc).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$here"
BUILD_DIR=${BUILD_DIR:-build}
JOBS=${TETFLOW_JOBS:-$(nproc)}

packages=(
  build-essential cmake pkg-config
  qt6-base-dev libqt6opengl6-dev
  libvtk9-dev libeigen3-dev libboost-dev libboost-program-options-dev
  libtet1.5-dev libgtest-dev libspectra-dev zlib1g-dev libpugixml-dev
  libpetsc-real-dev openmpi-bin
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

if [ ! -f "$BUILD_DIR/CMakeCache.txt" ]; then
  cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release
fi
cmake --build "$BUILD_DIR" -j "$JOBS"

case "${1:-}" in
  --run)
    shift
    exec "$here/scripts/main-job.sh" "$BUILD_DIR" "$@"
    ;;
  --test)
    shift
    (cd "$BUILD_DIR" && ctest --output-on-failure -j "$JOBS" "$@")
    # On CI (CI set) or when asked, the same suite again under ASan + UBSan (README "Reliability"):
    # about 25 minutes more on 2 cores, most of it the build (the heaviest studies are left out there). Without PETSc: OpenMPI and PETSc are
    # not instrumented and keep their allocations until exit, so the PETSc tests run in the normal
    # suite only (here they say they are skipped).
    if [ -n "${CI:-}" ] || [ "${TETFLOW_SANITIZER_SUITE:-0}" = 1 ]; then
      ASAN_DIR=${ASAN_BUILD_DIR:-build-asan}
      if [ ! -f "$ASAN_DIR/CMakeCache.txt" ]; then
        cmake -S . -B "$ASAN_DIR" -DTETFLOW_SANITIZE=address,undefined -DCMAKE_BUILD_TYPE=RelWithDebInfo \
          -DTETFLOW_BUILD_GUI=OFF -DTETFLOW_BUILD_BENCHMARKS=OFF -DTETFLOW_WITH_PETSC=OFF
      fi
      echo "setup: the suite under AddressSanitizer + UndefinedBehaviorSanitizer ($ASAN_DIR)"
      cmake --build "$ASAN_DIR" -j "$JOBS"
      cd "$ASAN_DIR"
      # Left out here, run above in Release: the studies that repeat one pipeline on large meshes
      # (23-107 s each in Release, two to three times that under ASan). What they run is covered
      # under ASan by the smaller tests of the same code (random volumes, Nets.default, the
      # particle and lead-field tests).
      heavy='^(Nets\.(adaptive_particles|adaptive_head|eeg_leadfield|TheHeadNetsPassTheirCertificatesOnALayeredHead|ANetOfDefaultModulesIsAsFaithfulAsTheShippedOnes)'
      heavy+='|Cli\.TheDefaultNetIsDeterministicAcrossThreadCountsAndRuns|EegForward\.FourShellSphereErrorsFallWithTheLattice'
      heavy+='|EegForward\.VenantBeatsPartialIntegrationAtHighEccentricity'
      heavy+='|CliProgress\.OnATerminalALiveLineFollowsTheRunningModuleAndGivesWayToItsSummary' # the other pty tests run the live lines here
      heavy+='|MeshCommand\.EachBackgroundMeshesTheBundledHeadTheSameFromNiftiAndNrrd' # Nets.mesh_labels* run here
      heavy+='|Fidelity\.TheAdaptiveDefaultsKeepEveryComponentOfAFiveLabelSegmentation'
      heavy+='|ExtractSurfacesModule\.TheBemHeadNetsSurfacesPassTheirChecksAndMnes' # Nets.bem_head runs its net here
      heavy+='|CadModulesFixture\.TheSmoothSphereNetMatchesTheAnalyticPotential)$' # Nets.eeg_sphere_cad runs it here
      exec ctest --output-on-failure -j "$JOBS" -E "$heavy" "$@"
    fi
    ;;
  "") ;;
  *) echo "setup: unknown option '$1' (use --run or --test)" >&2; exit 2 ;;
esac
