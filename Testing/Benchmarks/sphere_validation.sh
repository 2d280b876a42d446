#!/bin/bash
# FEM dipole potentials against the analytic four-shell sphere (issue "validated bioelectric forward
# problem"): the head phantom (radii 78/80/86/92 mm, 2 mm voxels; sigma brain 0.33, CSF 1.79,
# skull 0.0042, scalp 0.33 S/m) meshed by lattice cleaving at regular BCC lattices of 4, 3 and 2 mm
# (CleaveMesh with blend_sigma 1, label repair and improvement, air stripped), then per lattice
# radial and tangential dipoles (0.01 mA mm) at z = 20, 40, 60, 70 mm (eccentricity 0.26, 0.51,
# 0.77, 0.90 of the brain radius), each with the partial-integration and the St. Venant source
# model (AssembleFEMPoisson source_model), Jacobi-MINRES to 1e-8, and
# AnalyticSphereEEG at every scalp surface vertex: RDM and MAG (average reference).
# A homogeneous run (every sigma 0.33, 3 mm) separates the layers' error from the rest.
# Writes Testing/Benchmarks/results/sphere_validation.txt (or $1). Needs build/Interface/tetflow, python3.
# The nets and the rows come from sphere_validation.py (shared with sphere_validation_adaptive.sh).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
CLI=${TETFLOW_CLI:-$ROOT/build/Interface/tetflow}
PY=$ROOT/Testing/Benchmarks/sphere_validation.py # net writer and report parser, shared
OUT=${1:-$ROOT/Testing/Benchmarks/results/sphere_validation.txt}
LATTICES=${LATTICES:-4 3 2}
command -v python3 >/dev/null || { echo "sphere_validation.sh needs python3"; exit 1; }
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

{
  echo "# sphere_validation.sh on $(nproc) cores, $(date -u +%Y-%m-%d)"
  echo "# columns: label lattice_mm tets dofs source_model dipole z_mm eccentricity RDM MAG lnMAG iterations electrodes"
} > "$WORK/out.txt"
run() { # label cell sigma sphere
  python3 "$PY" net "$WORK/$1.srn" --lattice "$2" --sigma "$3" --sphere "$4"
  "$CLI" run "$WORK/$1.srn" --quiet --output-dir "$WORK/o_$1" --report "$WORK/$1.json" >/dev/null
  python3 "$PY" rows "$WORK/$1.srn" "$WORK/$1.json" "$1" "$2" >> "$WORK/out.txt"
}
for cell in $LATTICES; do run "layers" "$cell" "1:0.33; 2:0.0042; 3:1.79; 4:0.33" "0.33 1.79 0.0042 0.33"; done
if [ "${HOMOGENEOUS:-1}" = 1 ]; then run "homogeneous" 3 "1:0.33; 2:0.33; 3:0.33; 4:0.33" "0.33 0.33 0.33 0.33"; fi
mkdir -p "$(dirname "$OUT")"
mv "$WORK/out.txt" "$OUT"
cat "$OUT"
