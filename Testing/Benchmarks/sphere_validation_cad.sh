#!/bin/bash
# FEM dipole potentials on the smooth four-shell sphere against the analytic solution (issue 28
# item 1): Nets/four_shell_sphere.brep (four concentric OpenCASCADE spheres of radii 78 / 80 / 86 /
# 92 mm sharing their faces: brain, CSF, skull, scalp; sigma 0.33 / 1.79 / 0.0042 / 0.33 S/m) meshed
# by MeshCADSurface at uniform sizes h (min_size = max_size = h on the surfaces, TetGen's
# max_tet_volume h³/(6·2^½), the volume of a regular tet of edge h; -q1.414/10 and the improvement
# as shipped), then per mesh radial and tangential dipoles (0.01 mA mm) at z = 20, 40,
# 60, 70, 74 mm (eccentricity 0.26, 0.51, 0.77, 0.90, 0.95), each with the partial-integration, the St.
# Venant and the subtraction source model (AssembleFEMPoisson source_model; MODELS picks them), Jacobi-MINRES to 1e-8, and
# AnalyticSphereEEG at every scalp surface vertex: RDM and MAG (average reference).
# Rows "contrast20" repeat one size with a skull of 0.0165 S/m (brain:skull 20:1), "homogeneous"
# with every sigma 0.33, to separate the layers' error from the rest.
# The dipoles lie on the rays DIRS from the centre (default "0 0 1;0.8 0.5 0.33": dir 0 toward a
# pole of the spheres' parameterisation, where the surface mesh is least regular, dir 1 oblique),
# the tangential moment perpendicular to the ray. SIZES (default "8 6 4 3 2.5") picks the sizes; CONTRAST_SIZE (default 4) the size of the extra rows.
# Writes Testing/Benchmarks/results/sphere_validation_cad.txt (or $1). Needs build/Interface/tetflow,
# python3.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
CLI=${TETFLOW_CLI:-$ROOT/build/Interface/tetflow}
OUT=${1:-$ROOT/Testing/Benchmarks/results/sphere_validation_cad.txt}
SIZES=${SIZES:-8 6 4 3 2.5}
CONTRAST_SIZE=${CONTRAST_SIZE:-4}
ZS=${ZS:-20 40 60 70 74}
command -v python3 >/dev/null || { echo "sphere_validation_cad.sh needs python3"; exit 1; }
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
cp "$ROOT/Nets/four_shell_sphere.brep" "$WORK/"

make_net() { # size sigma_fem sigma_analytic out
  python3 - "$@" <<'PY'
import os, sys
size, sig, sphere, out = sys.argv[1:]
zs = [int(z) for z in os.environ['ZS'].split()]
def unit(v):
    n = sum(x * x for x in v) ** 0.5
    return [x / n for x in v]
vec = lambda v, s: ' '.join(f'{s * x:.9g}' for x in v)
mods, conns = [], []
def module(i, name, vars):
    v = ''.join(f'      <var name="{k}" val="{{{x}}}" substitute="no"/>\n' for k, x in vars)
    mods.append(f'    <module id="{i}" package="TetFlow" name="{name}" version="1.0">\n{v}    </module>\n')
def connect(a, b, port=0):
    conns.append(f'    <connection id="c{len(conns) + 1}" from="{a}" fromport="0" to="{b}" toport="{port}"/>\n')
module('cad', 'ReadCADModel', [('filename', 'four_shell_sphere.brep')])
# Tets no larger than a regular one of edge h inside too (TetGen's -a), so the brain is as fine
# as its surface.
module('me', 'MeshCADSurface', [('min_size', size), ('max_size', size),
       ('max_tet_volume', f'{float(size) ** 3 * 2 ** 0.5 / 12:.6g}')])
connect('cad', 'me')
for di, dtext in enumerate(os.environ['DIRS'].split(';')):
  d = unit([float(x) for x in dtext.split()])
  axis = [1, 0, 0] if abs(d[0]) < 0.9 else [0, 1, 0]  # any axis not along d, for a tangential moment
  t = unit([d[1] * axis[2] - d[2] * axis[1], d[2] * axis[0] - d[0] * axis[2], d[0] * axis[1] - d[1] * axis[0]])
  for z in zs:
    for kind, m in (('radial', vec(d, 0.01)), ('tangential', vec(t, 0.01))):
      for model in os.environ['MODELS'].split():
        f, a = f'fem_{model}_{kind}_{z}_{di}', f'an_{model}_{kind}_{z}_{di}'
        module(f, 'AssembleFEMPoisson', [('conductivities', sig), ('boundary_condition', 'dipole'),
               ('dipole_position', vec(d, z)), ('dipole_moment', m), ('condition_numbers', 'false'),
               ('conductivity_by_name', 'false'), ('source_model', model)])
        module(a, 'AnalyticSphereEEG', [('dipole_position', vec(d, z)), ('dipole_moment', m),
               ('sphere_conductivities', sphere)])
        connect('me', f); connect(f, a)
open(out, 'w').write('<?xml version="1.0" encoding="UTF-8"?>\n<network version="tetflow-1">\n  <modules>\n'
    + ''.join(mods) + '  </modules>\n  <connections>\n' + ''.join(conns) + '  </connections>\n</network>\n')
PY
}

{
  echo "# sphere_validation_cad.sh on $(nproc) cores, $(date -u +%Y-%m-%d)"
  echo "# columns: label size_mm tets dofs mesh_s source_model dipole dir r_mm eccentricity RDM MAG lnMAG iterations solve_s electrodes"
} > "$WORK/out.txt"
run() { # label size sigma sphere
  make_net "$2" "$3" "$4" "$WORK/$1_$2.srn"
  (cd "$WORK" && "$CLI" run "$1_$2.srn" --quiet --output-dir "o_$1_$2" --report "$1_$2.json" >/dev/null)
  python3 - "$WORK/$1_$2.json" "$1" "$2" >> "$WORK/out.txt" <<'PY'
import json, os, sys
r = json.load(open(sys.argv[1])); label, size = sys.argv[2], sys.argv[3]
mods = {m['id']: m for m in r['modules']}
me = mods['me']
for di, dtext in enumerate(os.environ['DIRS'].split(';')):
 for z in [int(z) for z in os.environ['ZS'].split()]:
  for kind in ('radial', 'tangential'):
    for model in os.environ['MODELS'].split():
        f, a = mods[f'fem_{model}_{kind}_{z}_{di}'], mods[f'an_{model}_{kind}_{z}_{di}']
        fr, ar = f['report'], a['report']
        print(f"{label:12s} {size:>4s} {me['report']['tets']:8d} {fr['dofs']:8d} {me.get('seconds', 0):7.1f} "
              f"{model:19s} {kind:10s} {di:3d} {z:3d} {z/78:.2f} {ar['rdm']:.4f} {ar['mag']:.4f} {ar['ln_mag']:+.4f} "
              f"{fr['iterations']:5d} {f.get('seconds', 0):6.1f} {ar['electrodes']:6d}")
PY
}
export MODELS=${MODELS:-partial_integration venant subtraction} ZS DIRS=${DIRS:-0 0 1;0.8 0.5 0.33}
LAYERS="1:0.33; 2:0.0042; 3:1.79; 4:0.33" # labels: solid order of the file (1 scalp, 2 skull, 3 CSF, 4 brain)
for h in $SIZES; do run "layers" "$h" "$LAYERS" "0.33 1.79 0.0042 0.33"; done
if [ "${EXTRA:-1}" = 1 ]; then
  run "contrast20" "$CONTRAST_SIZE" "1:0.33; 2:0.0165; 3:1.79; 4:0.33" "0.33 1.79 0.0165 0.33"
  run "homogeneous" "$CONTRAST_SIZE" "1:0.33; 2:0.33; 3:0.33; 4:0.33" "0.33 0.33 0.33 0.33"
fi
mkdir -p "$(dirname "$OUT")"
mv "$WORK/out.txt" "$OUT"
cat "$OUT"
