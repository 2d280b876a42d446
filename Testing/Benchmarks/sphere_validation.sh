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
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
CLI=${TETFLOW_CLI:-$ROOT/build/Interface/tetflow}
OUT=${1:-$ROOT/Testing/Benchmarks/results/sphere_validation.txt}
LATTICES=${LATTICES:-4 3 2}
command -v python3 >/dev/null || { echo "sphere_validation.sh needs python3"; exit 1; }
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

make_net() { # cell sigma_fem sigma_analytic out
  python3 - "$@" <<'PY'
import sys
cell, sig, sphere, out = sys.argv[1:]
mods, conns = [], []
def module(i, name, vars):
    v = ''.join(f'      <var name="{k}" val="{{{x}}}" substitute="no"/>\n' for k, x in vars)
    mods.append(f'    <module id="{i}" package="TetFlow" name="{name}" version="1.0">\n{v}    </module>\n')
def connect(a, b, port=0):
    conns.append(f'    <connection id="c{len(conns) + 1}" from="{a}" fromport="0" to="{b}" toport="{port}"/>\n')
module('ph', 'CreatePhantom', [('kind', 'head'), ('voxel_size', '2')])
module('bg', 'GenerateBackgroundMesh', [('kind', 'regular_bcc'), ('cell_size', cell)])
module('cl', 'CleaveMesh', [('blend_sigma', '1'), ('strip_exterior', '0')])
connect('ph', 'bg'); connect('ph', 'cl'); connect('bg', 'cl', 1)
for z in (20, 40, 60, 70):
  for kind, m in (('radial', '0 0 0.01'), ('tangential', '0.01 0 0')):
    for model in ('partial_integration', 'venant'):
        f, a = f'fem_{model}_{kind}_{z}', f'an_{model}_{kind}_{z}'
        module(f, 'AssembleFEMPoisson', [('conductivities', sig), ('boundary_condition', 'dipole'),
               ('dipole_position', f'0 0 {z}'), ('dipole_moment', m), ('condition_numbers', 'false'),
               ('source_model', model)])
        module(a, 'AnalyticSphereEEG', [('dipole_position', f'0 0 {z}'), ('dipole_moment', m),
               ('sphere_conductivities', sphere)])
        connect('cl', f); connect(f, a)
open(out, 'w').write('<?xml version="1.0" encoding="UTF-8"?>\n<network version="tetflow-1">\n  <modules>\n'
    + ''.join(mods) + '  </modules>\n  <connections>\n' + ''.join(conns) + '  </connections>\n</network>\n')
PY
}

{
  echo "# sphere_validation.sh on $(nproc) cores, $(date -u +%Y-%m-%d)"
  echo "# columns: label lattice_mm tets dofs source_model dipole z_mm eccentricity RDM MAG lnMAG iterations electrodes"
} > "$WORK/out.txt"
run() { # label cell sigma sphere
  make_net "$2" "$3" "$4" "$WORK/$1.srn"
  "$CLI" run "$WORK/$1.srn" --quiet --output-dir "$WORK/o_$1" --report "$WORK/$1.json" >/dev/null
  python3 - "$WORK/$1.json" "$1" "$2" >> "$WORK/out.txt" <<'PY'
import json, math, sys
r = json.load(open(sys.argv[1])); label, cell = sys.argv[2], sys.argv[3]
mods = {m['id']: m.get('report', {}) for m in r['modules']}
cl = mods['cl']
for z in (20, 40, 60, 70):
  for kind in ('radial', 'tangential'):
    for model in ('partial_integration', 'venant'):
        f, a = mods[f'fem_{model}_{kind}_{z}'], mods[f'an_{model}_{kind}_{z}']
        print(f"{label:12s} {cell:>4s} {cl['tets']:9d} {f['dofs']:8d} {model:19s} {kind:10s} {z:3d} {z/78:.2f} "
              f"{a['rdm']:.4f} {a['mag']:.4f} {a['ln_mag']:+.4f} {f['iterations']:5d} {a['electrodes']:6d}")
PY
}
for cell in $LATTICES; do run "layers" "$cell" "1:0.33; 2:0.0042; 3:1.79; 4:0.33" "0.33 1.79 0.0042 0.33"; done
if [ "${HOMOGENEOUS:-1}" = 1 ]; then run "homogeneous" 3 "1:0.33; 2:0.33; 3:0.33; 4:0.33" "0.33 0.33 0.33 0.33"; fi
mkdir -p "$(dirname "$OUT")"
mv "$WORK/out.txt" "$OUT"
cat "$OUT"
