#!/bin/bash
# Solver scaling table (issue "the simulation at the speed of the mesh", README "Solvers: which
# one and when"): one family of meshes, the layered head of layered_head.cpp at 2 mm and 1 mm
# voxels meshed by Nets/mesh_labels.srn at several cell sizes (0.1 M to 2 M unknowns), and per
# mesh, as leadfield_benchmark runs a lead field (128 scalp electrodes, 5 000 grey sources):
#   cholesky     16 solves: analysis + numeric factorisation, seconds per right-hand side
#   minres       MINRES + Jacobi, 2 solves: seconds and iterations per solve
#   hypre        solver_backend petsc, CG + BoomerAMG on one rank, 4 solves: set-up, per solve
#   auto         what solver = auto picks for 1 and for 127 right-hand sides (--choose)
# each under /usr/bin/time for its peak resident memory. Writes results/solver_scaling.txt (or $1).
#   MESHES="2:4 1:6 1:4 ..."  voxel:cell_size pairs (default below)   METHODS="cholesky minres hypre auto"
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
BUILD=${TETFLOW_BUILD:-$ROOT/build}
OUT=${1:-$ROOT/Testing/Benchmarks/results/solver_scaling.txt}
MESHES=${MESHES:-"2:6 2:4 2:3 1:4 1:3"}
METHODS=${METHODS:-"cholesky minres hypre auto"}
WORK=${WORK:-$(mktemp -d)}
mkdir -p "$WORK"
bench() { # label, args...: one leadfield_benchmark line with its peak memory
  local label=$1
  shift
  local line
  line=$(/usr/bin/time -f "%M" -o "$WORK/rss" "$BUILD/Testing/leadfield_benchmark" "$@")
  echo "method=$label $line peak_rss_MB=$(( $(cat "$WORK/rss") / 1024 ))"
}
{
  echo "# solver_scaling.sh on $(nproc) cores, $(date -u +%Y-%m-%d), layered head, Nets/mesh_labels.srn; MESHES=\"$MESHES\""
  echo "# command: Testing/Benchmarks/solver_scaling.sh; seconds per stage and per solve, peak resident MB"
  for vc in $MESHES; do
    voxel=${vc%%:*}
    cell=${vc##*:}
    vol="$WORK/head${voxel}mm.nii.gz"
    mesh="$WORK/head_v${voxel}_c${cell}.vtu"
    [ -f "$vol" ] || "$BUILD/Testing/layered_head" "$vol" --voxel "$voxel" >/dev/null
    [ -f "$mesh" ] || "$BUILD/Interface/tetflow" run "$ROOT/Nets/mesh_labels.srn" --set m1.filename="$vol" \
      --set m2.cell_size="$cell" --set m5.filename="$mesh" --progress none >/dev/null
    echo "# mesh voxel=${voxel}mm cell_size=$cell"
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
