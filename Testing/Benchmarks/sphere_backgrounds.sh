#!/bin/bash
# Issue 50 item 4: the forward error on the smooth four-shell sphere for each background, with the
# sizes `tetflow mesh` picks on 1 mm voxels (regular lattice 4 mm cells; octree sizing field 4 to
# 16 mm; particles 2 to 16 mm; thin-layer refinement on its defaults). The head phantom at 1 mm
# voxels is meshed by the modules of Nets/adaptive_head.srn with only those sizes and the kind
# changed (sphere_validation_adaptive.sh with SETS), then the 16 dipoles of sphere_validation.sh
# (radial and tangential at z = 20, 40, 60, 70 mm, partial integration and St. Venant) are solved
# and compared with AnalyticSphereEEG at every scalp vertex.
# Writes Testing/Benchmarks/results/sphere_backgrounds.txt (or $1): the rows of
# sphere_validation_adaptive.txt, labelled by background, each group followed by its whole-run
# time and peak memory, and a summary per background (tets, mean RDM and mean |lnMAG| over the
# dipoles at eccentricity <= 0.77, i.e. z <= 60 mm, and the ratios to the regular lattice's).
# BACKGROUNDS (default "regular octree particles octree8 particles8") chooses the groups; the
# last two cap the largest size at 8 mm (--max-size 8): the elements around a dipole decide most
# of its error. Needs build/Interface/tetflow, python3.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${1:-$ROOT/Testing/Benchmarks/results/sphere_backgrounds.txt}
BACKGROUNDS=${BACKGROUNDS:-regular octree particles octree8 particles8}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
sets_of() {
  case $1 in
    regular) echo "m2.kind=regular_bcc m2.cell_size=4" ;;
    octree) echo "m2.kind=octree_bcc m6.min_size=4 m6.max_size=16" ;;
    particles) echo "m2.kind=particles m6.min_size=2 m6.max_size=16" ;;
    octree8) echo "m2.kind=octree_bcc m6.min_size=4 m6.max_size=8" ;;
    particles8) echo "m2.kind=particles m6.min_size=2 m6.max_size=8" ;;
    *) echo "unknown background $1 (regular, octree, particles, octree8, particles8)" >&2; exit 2 ;;
  esac
}
{
  echo "# sphere_backgrounds.sh on $(nproc) cores, $(date -u +%Y-%m-%d), at commit $(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "# the meshing modules of Nets/adaptive_head.srn, CreatePhantom voxel_size 1, per group:"
  for b in $BACKGROUNDS; do echo "#   $b: $(sets_of "$b")"; done
  echo "# columns: background voxel_mm tets dofs source_model dipole z_mm eccentricity RDM MAG lnMAG iterations electrodes mesh_s solve_s"
} > "$WORK/out.txt"
for b in $BACKGROUNDS; do
  VOXELS=1 HOMOGENEOUS=0 SETS="$(sets_of "$b")" bash "$ROOT/Testing/Benchmarks/sphere_validation_adaptive.sh" "$WORK/$b.txt" >/dev/null
  grep -v '^# \(sphere_validation\|at commit\|columns\)' "$WORK/$b.txt" | sed -e "s/^adaptive /$(printf '%-9s' "$b")/" -e "s/^# adaptive,/# $b,/" >> "$WORK/out.txt"
done
python3 - "$WORK/out.txt" > "$WORK/summary.txt" <<'EOF'
import sys
rows = {}
for line in open(sys.argv[1]):
    if line.startswith('#') or not line.strip():
        continue
    f = line.split()
    rows.setdefault(f[0], []).append((int(f[2]), float(f[7]), float(f[8]), abs(float(f[10])), float(f[13])))
print('# summary over the dipoles at eccentricity <= 0.77 (z <= 60 mm), both source models:')
print('# background      tets  mean_RDM  mean_|lnMAG|  RDM/regular  |lnMAG|/regular  tets/regular  mesh_s')
base = None
for b, r in rows.items():
    sel = [x for x in r if x[1] <= 0.77]
    rdm = sum(x[2] for x in sel) / len(sel)
    mag = sum(x[3] for x in sel) / len(sel)
    if b == 'regular':
        base = (r[0][0], rdm, mag)
    ratio = lambda v, i: f'{v / base[i]:.2f}' if base else '-'
    print(f'# {b:10s} {r[0][0]:9d}  {rdm:.4f}    {mag:.4f}        {ratio(rdm, 1):>5s}        {ratio(mag, 2):>5s}'
          f'          {ratio(r[0][0], 0):>5s}  {r[0][4]:6.1f}')
EOF
cat "$WORK/summary.txt" >> "$WORK/out.txt"
mkdir -p "$(dirname "$OUT")"
mv "$WORK/out.txt" "$OUT"
cat "$OUT"
