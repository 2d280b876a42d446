#!/bin/bash
# Issue 28 item 3: the voxel path at 1 mm voxels through the shipped adaptive net, measured as in
# sphere_validation.sh. The meshing modules of Nets/adaptive_head.srn (CreatePhantom ->
# ComputeSizingField -> GenerateBackgroundMesh octree_bcc -> CleaveMesh) are read from the file at
# run time with the values it ships, the writers and EvaluateQuality dropped, and only
# CreatePhantom's voxel_size set: 1 mm, and 2 mm (the net as shipped) for comparison. Then the
# dipoles of sphere_validation.sh (radial and tangential at z = 20, 40, 60, 70 mm, partial
# integration and St. Venant) with sigma scalp 0.33, skull 0.0042, CSF 1.79, brain 0.33 S/m
# (CreatePhantom head: 1 scalp, 2 skull, 3 CSF, 4 brain) against AnalyticSphereEEG on the
# phantom's radii at every scalp surface vertex.
# Writes Testing/Benchmarks/results/sphere_validation_adaptive.txt (or $1): the columns of
# sphere_validation.txt (the second is the voxel size) plus mesh_s (all meshing modules) and
# solve_s (AssembleFEMPoisson's solve stage; two dipoles are solved at a time on two workers).
# A homogeneous group (every sigma 0.33, first voxel size; HOMOGENEOUS=0: none) separates the
# layers' error from the rest. VOXELS (default "1 2") chooses the voxel sizes; SETS="ID.PARAM=V ..."
# changes the net further (for experiments, not the shipped net); KEEP_REPORTS=DIR keeps each net
# and its report. Needs build/Interface/tetflow, python3.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
CLI=${TETFLOW_CLI:-$ROOT/build/Interface/tetflow}
PY=$ROOT/Testing/Benchmarks/sphere_validation.py # net writer and report parser, shared
NET=$ROOT/Nets/adaptive_head.srn
OUT=${1:-$ROOT/Testing/Benchmarks/results/sphere_validation_adaptive.txt}
VOXELS=${VOXELS:-1 2}
SETS=${SETS:-}
[ -z "$SETS" ] || [ $# -ge 1 ] || { echo "with SETS give an output file: the results file is the net as shipped"; exit 2; }
command -v python3 >/dev/null || { echo "sphere_validation_adaptive.sh needs python3"; exit 1; }
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
PHANTOM=$(python3 -c 'import sys; sys.path.insert(0, sys.argv[1]); import sphere_validation as s
print(next(i for i, n, _ in s.srn_modules(sys.argv[2])[0] if n == "CreatePhantom"))' "$ROOT/Testing/Benchmarks" "$NET")
TIME=()
[ -x /usr/bin/time ] && TIME=(/usr/bin/time -f "%e %M" -o "$WORK/time.txt")

{
  echo "# sphere_validation_adaptive.sh on $(nproc) cores, $(date -u +%Y-%m-%d), the meshing modules of ${NET#"$ROOT"/}"
  echo "# at commit $(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo unknown), $PHANTOM.voxel_size set per group${SETS:+, also $SETS}"
  echo "# columns: label voxel_mm tets dofs source_model dipole z_mm eccentricity RDM MAG lnMAG iterations electrodes mesh_s solve_s"
} > "$WORK/out.txt"
run() { # label voxel sigma sphere
  local n=$1_$2 sets=(--set "$PHANTOM.voxel_size=$2") x
  for x in $SETS; do sets+=(--set "$x"); done
  python3 "$PY" net "$WORK/$n.srn" --srn "$NET" "${sets[@]}" --sigma "$3" --sphere "$4"
  "${TIME[@]}" "$CLI" run "$WORK/$n.srn" --quiet --output-dir "$WORK/o_$n" --report "$WORK/$n.json" >/dev/null
  python3 "$PY" rows "$WORK/$n.srn" "$WORK/$n.json" "$1" "$2" --times >> "$WORK/out.txt"
  if [ -s "$WORK/time.txt" ]; then
    read -r wall rss < "$WORK/time.txt"
    echo "# $1, voxel $2 mm: whole run ${wall} s wall, peak RSS $((rss / 1024)) MB" >> "$WORK/out.txt"
  fi
  [ -z "${KEEP_REPORTS:-}" ] || { mkdir -p "$KEEP_REPORTS"; cp "$WORK/$n.srn" "$WORK/$n.json" "$KEEP_REPORTS/"; }
}
for voxel in $VOXELS; do run adaptive "$voxel" "1:0.33; 2:0.0042; 3:1.79; 4:0.33" "0.33 1.79 0.0042 0.33"; done
# Every sigma 0.33 on the first voxel size's mesh: what is left without the layers.
if [ "${HOMOGENEOUS:-1}" = 1 ]; then
  run homogeneous "${VOXELS%% *}" "1:0.33; 2:0.33; 3:0.33; 4:0.33" "0.33 0.33 0.33 0.33"
fi
mkdir -p "$(dirname "$OUT")"
mv "$WORK/out.txt" "$OUT"
cat "$OUT"
