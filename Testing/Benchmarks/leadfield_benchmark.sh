#!/bin/bash
# EEG lead field on a realistic 1 mm head (issue "the simulation at the speed of the mesh"): the
# layered head built from mricron-data's atlases at 1 mm (Testing/Benchmarks/layered_head.cpp;
# 181 x 217 x 181, scalp / skull / CSF / grey / white), meshed by Nets/mesh_labels.srn with 4 mm
# cells (Nets/default.srn's lattice; about 5 M tets), then per solver a run of leadfield_benchmark
# (128 scalp electrodes, 5 000 grey-matter sources; iterative solvers: 9 electrodes, 8 solves)
# under /usr/bin/time for its peak memory. Writes Testing/Benchmarks/results/leadfield.txt (or $1).
#   SOLVERS="cholesky minres" (default: cholesky, then minres with Jacobi)
#   CHECK=K   also compare the lead field's rows 1..K with MINRES + Jacobi at 1e-12 (default 2)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
BUILD=${TETFLOW_BUILD:-$ROOT/build}
OUT=${1:-$ROOT/Testing/Benchmarks/results/leadfield.txt}
SOLVERS=${SOLVERS:-"cholesky minres"}
CHECK=${CHECK:-2}
WORK=${WORK:-$(mktemp -d)}
mkdir -p "$WORK"
if [ ! -f "$WORK/head.vtu" ]; then
  "$BUILD/Testing/layered_head" "$WORK/head1mm.nii.gz" --voxel 1 >/dev/null
  "$BUILD/Interface/tetflow" run "$ROOT/Nets/mesh_labels.srn" --set m1.filename="$WORK/head1mm.nii.gz" \
    --set m2.cell_size=4 --set m5.filename="$WORK/head.vtu" --report "$WORK/mesh.json" --progress none >/dev/null
fi
{
  echo "# leadfield_benchmark.sh on $(nproc) cores, $(date -u +%Y-%m-%d), layered head 1 mm, Nets/mesh_labels.srn with cell_size 4"
  echo "# command: Testing/Benchmarks/leadfield_benchmark.sh; figures: seconds per stage, per solve, peak resident MB"
  for s in $SOLVERS; do
    # MINRES takes ~17 s a solve here: 8 solves (9 electrodes) give its per-solve time, not 127.
    if [ "$s" = cholesky ]; then args=(--check "$CHECK"); else args=(--electrodes "${ITERATIVE_ELECTRODES:-9}"); fi
    line=$(/usr/bin/time -f "%M" -o "$WORK/rss" "$BUILD/Testing/leadfield_benchmark" "$WORK/head.vtu" --solver "$s" "${args[@]}")
    echo "$line peak_rss_MB=$(( $(cat "$WORK/rss") / 1024 ))"
  done
} | tee "$OUT"
