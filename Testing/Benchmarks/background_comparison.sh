#!/bin/bash
# Regular vs octree vs particle backgrounds (issue "unstructured adaptive cleaving"): runs
# Nets/adaptive_particles.srn as it is and with its background switched to octree_bcc
# (uniform_interfaces) and to regular_bcc (4 mm), on the head phantom, then the same three on
# Cleaver's spheres (a variant of the net reading Testing/Data/spheres1..4.nrrd, sizing field at
# sampling rate 2, min 0.75 mm, Lipschitz 0.2; unit conductivity, dipole at the box centre).
# Every run has the net's own downstream: CleaveMesh (label repair, calibration, improvement),
# EvaluateQuality and the dipole problem (Jacobi-MINRES, tolerance 1e-8, kappa by Lanczos).
# Writes Testing/Benchmarks/results/backgrounds.txt (or $1). Needs build/Interface/tetflow and python3.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
CLI=${TETFLOW_CLI:-$ROOT/build/Interface/tetflow}
OUT=${1:-$ROOT/Testing/Benchmarks/results/backgrounds.txt}
command -v python3 >/dev/null || { echo "background_comparison.sh needs python3 (apt-get install python3)"; exit 1; }
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
NET=$ROOT/Nets/adaptive_particles.srn
# The spheres variant of the net.
python3 - "$NET" "$ROOT/Testing/Data" "$WORK/spheres_particles.srn" <<'PY'
import re, sys
net, data, out = sys.argv[1:]
s = open(net).read()
a = s.index('    <module id="m1"'); b = s.index('    <module id="m2"')
files = '; '.join(f'{data}/spheres{i}.nrrd' for i in range(1, 5))
s = s[:a] + f'''    <module id="m1" package="TetFlow" category="DataIO" name="ReadIndicatorFunctions" version="1.0">
      <position x="40" y="40"/>
      <var name="filenames" val="{{{files}}}" substitute="no"/>
      <var name="labels" val="{{1; 2; 3; 4}}" substitute="no"/>
    </module>
''' + s[b:]
def setvar(s, mod, name, val):
    a = s.index(f'<module id="{mod}"'); b = s.index('</module>', a)
    blk = re.sub(f'<var name="{name}" val="{{[^}}]*}}"', f'<var name="{name}" val="{{{val}}}"', s[a:b])
    return s[:a] + blk + s[b:]
for k, v in [('sampling_rate', '2'), ('lipschitz', '0.2'), ('min_size', '0.75'), ('max_size', '0')]:
    s = setvar(s, 'm6', k, v)
s = setvar(s, 'm3', 'strip_exterior', 'none')
s = setvar(s, 'm4', 'certificate', 'false')
s = setvar(s, 'm4', 'max_volume_error', '0')
s = setvar(s, 'm4', 'require_components', 'false')
s = setvar(s, 'm4', 'forbid_spurious_contacts', 'false')
s = setvar(s, 'm8', 'conductivities', '')
s = setvar(s, 'm8', 'dipole_position', '13.5 13.5 13.5')
s = re.sub(r'\s*<connection id="c5"[^>]*/>', '', s)
open(out, 'w').write(s)
PY
NOBOUNDS="--set m4.require_min_dihedral=0 --set m4.require_max_dihedral=180 --set m4.max_volume_error=0"
run() { # name net extra-args...
  local name=$1 net=$2; shift 2
  "$CLI" run "$net" --quiet --output-dir "$WORK/$name" --report "$WORK/$name.json" $NOBOUNDS "$@" || true
}
run head-particles "$NET"
run head-octree "$NET" --set m2.kind=octree_bcc --set m2.uniform_interfaces=true
run head-regular4 "$NET" --set m2.kind=regular_bcc --set m2.cell_size=4
run spheres-particles "$WORK/spheres_particles.srn"
run spheres-octree "$WORK/spheres_particles.srn" --set m2.kind=octree_bcc --set m2.uniform_interfaces=true
run spheres-regular1 "$WORK/spheres_particles.srn" --set m2.kind=regular_bcc --set m2.cell_size=1
mkdir -p "$(dirname "$OUT")"
python3 - "$WORK" "$(nproc)" > "$OUT" <<'PY'
import json, sys
work, cores = sys.argv[1], sys.argv[2]
print(f"# background_comparison.sh on {cores} cores; seconds are wall time of the module")
print("# run                 bg_tets  bg_s   out_tets cleave_s  min_deg max_deg  kappa(K) kappa(DKD)  MINRES  volume error per label")
for name in ["head-particles", "head-octree", "head-regular4", "spheres-particles", "spheres-octree", "spheres-regular1"]:
    try:
        r = json.load(open(f"{work}/{name}.json"))
    except Exception as e:
        print(f"{name:20s} no report ({e})"); continue
    M = {m["id"]: m for m in r["modules"]}
    bad = [f'{m["id"]}: {m.get("error", "")}' for m in r["modules"] if m["status"] not in ("done",)]
    g, c, q, f = (M[k].get("report", {}) for k in ("m2", "m3", "m4", "m8"))
    errs = []
    for i in range(1, 5):
        a, b = c.get(f"material_{i}_volume_mm3"), c.get(f"material_{i}_input_mm3")
        if a is not None and b: errs.append(f"{i}:{100 * (a - b) / b:+.2f}%")
    print(f'{name:20s} {g.get("tets", 0):8d} {M["m2"]["seconds"]:5.1f} {c.get("tets", 0):10d} {M["m3"]["seconds"]:7.1f} '
          f'{q.get("min_dihedral_deg", 0):8.2f} {q.get("max_dihedral_deg", 0):7.2f} {f.get("kappa", 0):10.4g} {f.get("kappa_jacobi", 0):10.4g} '
          f'{f.get("iterations", 0):6d}  {" ".join(errs)}' + (f'  FAILED {bad}' if bad else ''))
    if g.get("particles"):
        print(f'    particles {g["particles"]} ({g["particles_interior"]} interior), {g["particle_iterations"]} iterations at '
              f'{g["particle_seconds_per_iteration"]:.3f} s, stop {g["particle_stop"]}; Delaunay '
              f'[{g["delaunay_min_dihedral"]:.2f}, {g["delaunay_max_dihedral"]:.2f}] -> [{g["min_dihedral"]:.2f}, {g["max_dihedral"]:.2f}]; '
              f'spacing / l median {g["spacing_ratio_median"]:.3f} (p05 {g["spacing_ratio_p05"]:.3f}, p95 {g["spacing_ratio_p95"]:.3f}); '
              f'stages ' + ", ".join(f'{s["name"]} {s["seconds"]:.1f}' for s in M["m2"]["stages"]))
    imp = {k: c.get(k) for k in ("improve_min_dihedral_before", "improve_max_dihedral_before", "improve_unfixed_tets")}
    print(f'    cleaved before improvement [{imp["improve_min_dihedral_before"] or 0:.2f}, {imp["improve_max_dihedral_before"] or 0:.2f}], '
          f'{imp["improve_unfixed_tets"]} tet(s) left outside [10, 160]; kappa: {f.get("kappa_method", "?")}; kappa(DKD): {f.get("kappa_jacobi_method", "?")}')
PY
cat "$OUT"
