#!/bin/bash
# Solver scaling table (issue "the simulation at the speed of the mesh", docs/fem.md "Solvers: which
# one and when"): one family of meshes, the 1 mm layered head of layered_head.cpp meshed by
# Nets/mesh_labels.srn's regular lattice at cell sizes 6 to 2 mm without thin-layer refinement
# (refine_thin_layers none: the unknowns then follow the cell size, 0.1 M to 1.9 M), and per mesh,
# as leadfield_benchmark runs a lead field (128 scalp electrodes, 5 000 grey sources):
#   cholesky     16 solves: analysis + numeric factorisation, seconds per right-hand side
#   minres       MINRES + Jacobi, 2 solves: seconds and iterations per solve
#   hypre        solver_backend petsc, CG + BoomerAMG on one rank, 4 solves: set-up, per solve
#   auto         what solver = auto picks for 1 and for 127 right-hand sides (--choose)
# each under /usr/bin/time for its peak resident memory. Writes results/solver_scaling.txt (or $1).
#   MESHES="6 4 ..."  cell sizes (mm; default below); REFINE=none|separating; VOXEL=1|2
#   METHODS="cholesky minres hypre auto"
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
BUILD=${TETFLOW_BUILD:-$ROOT/build}
OUT=${1:-$ROOT/Testing/Benchmarks/results/solver_scaling.txt}
MESHES=${MESHES:-"6 4 3 2.5 2"}
REFINE=${REFINE:-none}
VOXEL=${VOXEL:-1}
METHODS=${METHODS:-"cholesky minres hypre auto"}
WORK=${WORK:-$(mktemp -d)}
mkdir -p "$WORK"
bench() { # label, args...: one leadfield_benchmark line with its peak memory
  local label=$1
  shift
  local line
  if line=$(/usr/bin/time -f "%M" -o "$WORK/rss" "$BUILD/Testing/leadfield_benchmark" "$@" 2>"$WORK/err"); then
    echo "method=$label $line peak_rss_MB=$(( $(tail -1 "$WORK/rss") / 1024 ))"
  else # a refusal (memory) is a result too: its message, and the run goes on
    echo "method=$label failed=\"$(grep -v '^Command exited' "$WORK/err" | tr '\n' ' ')\" peak_rss_MB=$(( $(tail -1 "$WORK/rss") / 1024 ))"
  fi
}
{
  echo "# solver_scaling.sh on $(nproc) cores, $(date -u +%Y-%m-%d), layered head ${VOXEL} mm, Nets/mesh_labels.srn, refine_thin_layers $REFINE, cell sizes $MESHES"
  echo "# command: Testing/Benchmarks/solver_scaling.sh; seconds per stage and per solve, peak resident MB"
  vol="$WORK/head${VOXEL}mm.nii.gz"
  [ -f "$vol" ] || "$BUILD/Testing/layered_head" "$vol" --voxel "$VOXEL" >/dev/null
  for cell in $MESHES; do
    mesh="$WORK/head_v${VOXEL}_c${cell}_$REFINE.vtu"
    [ -f "$mesh" ] || "$BUILD/Interface/tetflow" run "$ROOT/Nets/mesh_labels.srn" --set m1.filename="$vol" \
      --set m2.cell_size="$cell" --set m2.refine_thin_layers="$REFINE" --set m5.filename="$mesh" \
      --progress none >/dev/null
    echo "# mesh cell_size=$cell"
    for m in $METHODS; do
      case $m in
      cholesky) bench cholesky "$mesh" --solver cholesky --electrodes 17 ;;
      minres) bench minres "$mesh" --solver minres --electrodes 3 ;;
      hypre) bench hypre "$mesh" --solver cg --preconditioner hypre --backend petsc --electrodes 5 ;;
      auto)
        bench auto_1 "$mesh" --choose 1
        bench auto_127 "$mesh" --choose 127 ;;
      esac
    done
  done
} | tee "$OUT"
