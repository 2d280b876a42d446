#!/bin/bash
# Mesh improvement on the inputs the quality issue names (docs/mesh-improvement.md): the
# default net, the head on regular lattices of 5/3/2 mm, the spheres at 3..0.5 voxels and the
# adaptive head at min_size 4/2/1.5, each line: tets before/after, angles before -> after, tets
# left outside [10, 160], operations, volume change, stage time of CleaveMesh time.
#   Testing/Benchmarks/improvement_targets.sh > Testing/Benchmarks/results/improvement.txt
cd "$(dirname "$0")/../../build"
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
show() { python3 -c "
import json,sys;r=json.load(open('$T/r.json'))
for m in r['modules']:
  R=m['report']
  if 'improve_tets_before' in R:
    st=[s for s in m['stages'] if s['name']=='improve']
    print('$1', R['improve_tets_before'], R['tets'], '%.2f/%.2f -> %.2f/%.2f'%(R['improve_min_dihedral_before'],R['improve_max_dihedral_before'],R['improve_min_dihedral_after'],R['improve_max_dihedral_after']), 'left',R['improve_unfixed_tets'], 'ops s%d e%d i%d f%d c%d n%d'%(R['improve_smoothed'],R['improve_edge_removals'],R['improve_interface_flips'],R['improve_flips23'],R['improve_collapses'],R['improve_insertions']), 'dV%%=%.2g'%R['improve_max_volume_change_percent'], 't=%.3f of %.2f'%(st[0]['seconds'],m['seconds']))"; }
for i in 1 2 3; do ./Interface/tetflow run ../Nets/default.srn --quiet --report $T/r.json --output-dir $T/o; show default; done
for c in 5 3 2; do ./Interface/tetflow run ../Nets/default.srn --quiet --set m2.cell_size=$c --set m4.max_volume_error=0 --report $T/r.json --output-dir $T/o; show head$c; done
for c in 3 2 1.5 1 0.75 0.5; do ./Interface/tetflow run ../Nets/spheres.srn --quiet --set m2.cell_size=$c --report $T/r.json --output-dir $T/o; show spheres$c; done
for s in 4 2 1.5; do ./Interface/tetflow run ../Nets/adaptive_head.srn --quiet --set m6.min_size=$s --report $T/r.json --output-dir $T/o; show adaptive$s; done
