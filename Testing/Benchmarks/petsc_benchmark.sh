#!/bin/bash
# Eigen vs PETSc on a >= 2 M-unknown head problem (issue "validated bioelectric forward problem"):
# the head phantom (2 mm voxels) cleaved on a regular BCC lattice of $CELL mm (default 1.5:
# about 2.2 M vertices), written once as VTU; then per configuration a net ReadMesh ->
# AssembleFEMPoisson (dipole 0 0 40 mm radial, tolerance 1e-8, condition_numbers false):
#   eigen  MINRES + Jacobi, one process (OpenMP, both cores)
#   petsc  MINRES + PCJACOBI, CG + PCGAMG, CG + PCHYPRE (BoomerAMG), on 1 and 2 MPI ranks
#          (mpirun --oversubscribe --bind-to none; OMP_NUM_THREADS=1 on 2 ranks)
# Figures: iterations, solve seconds (PETSc: distributing the matrix, KSPSetUp with the AMG
# hierarchy, the iterations and gathering the solution), peak resident memory of each rank (MB,
# /usr/bin/time; rank 0 holds the mesh, the assembled matrix and the pipeline).
# Writes Testing/Benchmarks/results/petsc.txt (or $1). Needs a PETSc build (TETFLOW_WITH_PETSC),
# mpirun, /usr/bin/time and python3.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
CLI=${TETFLOW_CLI:-$ROOT/build/Interface/tetflow}
OUT=${1:-$ROOT/Testing/Benchmarks/results/petsc.txt}
CELL=${CELL:-1.5}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
cat > "$WORK/mesh.srn" <<NET
<?xml version="1.0" encoding="UTF-8"?>
<network version="tetflow-1">
  <modules>
    <module id="ph" name="CreatePhantom"><var name="kind" val="{head}"/><var name="voxel_size" val="{2}"/></module>
    <module id="bg" name="GenerateBackgroundMesh"><var name="kind" val="{regular_bcc}"/><var name="cell_size" val="{$CELL}"/></module>
    <module id="cl" name="CleaveMesh"><var name="blend_sigma" val="{1}"/><var name="strip_exterior" val="{0}"/></module>
    <module id="w" name="WriteMesh"><var name="filename" val="{$WORK/head.vtu}"/></module>
  </modules>
  <connections>
    <connection id="c1" from="ph" fromport="0" to="bg" toport="0"/>
    <connection id="c2" from="ph" fromport="0" to="cl" toport="0"/>
    <connection id="c3" from="bg" fromport="0" to="cl" toport="1"/>
    <connection id="c4" from="cl" fromport="0" to="w" toport="0"/>
  </connections>
</network>
NET
"$CLI" run "$WORK/mesh.srn" --quiet
solve_net() { # backend solver preconditioner out
  cat > "$4" <<NET
<?xml version="1.0" encoding="UTF-8"?>
<network version="tetflow-1">
  <modules>
    <module id="r" name="ReadMesh"><var name="filename" val="{$WORK/head.vtu}"/></module>
    <module id="fem" name="AssembleFEMPoisson">
      <var name="conductivities" val="{1:0.33; 2:0.0042; 3:1.79; 4:0.33}"/>
      <var name="boundary_condition" val="{dipole}"/><var name="dipole_position" val="{0 0 40}"/>
      <var name="dipole_moment" val="{0 0 0.01}"/><var name="condition_numbers" val="{false}"/>
      <var name="solver_backend" val="{$1}"/><var name="solver" val="{$2}"/><var name="preconditioner" val="{$3}"/>
    </module>
  </modules>
  <connections><connection id="c1" from="r" fromport="0" to="fem" toport="0"/></connections>
</network>
NET
}
{
  echo "# petsc_benchmark.sh on $(nproc) cores, $(date -u +%Y-%m-%d), head phantom, lattice $CELL mm"
  echo "# columns: backend ranks solver preconditioner dofs iterations solve_s converged rss_rank0_MB rss_rank1_MB"
} > "$WORK/out.txt"
run() { # backend ranks solver pc
  local tag="$1_$2_$3_$4"
  solve_net "$1" "$3" "$4" "$WORK/$tag.srn"
  rm -f "$WORK"/mem_*
  if [ "$1" = eigen ]; then
    /usr/bin/time -f "%M" -o "$WORK/mem_0" "$CLI" run "$WORK/$tag.srn" --quiet --report "$WORK/$tag.json"
  else
    local omp=1
    [ "$2" = 1 ] && omp=$(nproc)
    OMP_NUM_THREADS=$omp mpirun -n "$2" --oversubscribe --bind-to none \
      sh -c "/usr/bin/time -f %M -o $WORK/mem_\$OMPI_COMM_WORLD_RANK $CLI run $WORK/$tag.srn --quiet --report $WORK/$tag.json"
  fi
  python3 - "$WORK/$tag.json" "$1" "$2" "$3" "$4" "$WORK" >> "$WORK/out.txt" <<'PY'
import json, os, sys
path, backend, ranks, solver, pc, work = sys.argv[1:]
f = {m['id']: m.get('report', {}) for m in json.load(open(path))['modules']}['fem']
mem = [int(open(os.path.join(work, f'mem_{r}')).read().split()[-1]) // 1024 for r in range(int(ranks))]
mem += [0] * (2 - len(mem))
print(f"{backend:6s} {ranks:>2s} {solver:7s} {pc:7s} {f['dofs']:8d} {f['iterations']:6d} {f['solve_seconds']:8.2f} "
      f"{str(f['converged']).lower():5s} {mem[0]:7d} {mem[1]:7d}")
PY
}
run eigen 1 minres jacobi
for ranks in 1 2; do
  run petsc "$ranks" minres jacobi
  run petsc "$ranks" cg gamg
  run petsc "$ranks" cg hypre
done
mkdir -p "$(dirname "$OUT")"
mv "$WORK/out.txt" "$OUT"
cat "$OUT"
