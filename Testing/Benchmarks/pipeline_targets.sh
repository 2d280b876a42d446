#!/bin/bash
# Whole `tetflow run` pipelines against issue 26's targets, and the scaling table.
#
#   Testing/Benchmarks/pipeline_targets.sh [RESULTS_FILE]            the targets (about 20 minutes)
#   Testing/Benchmarks/pipeline_targets.sh --scaling [RESULTS_FILE]  time and memory against
#                                                                    output tets (about 10 minutes)
#
# Targets, each run 3 times (median wall time of the process, peak resident memory of the
# process from the kernel's rusage, module times from the run's JSON report):
#   organ   the liver-sized organ of fidelity_benchmark (438 x 353 x 165 voxels of 0.8 x 0.8 x 2 mm)
#           through Nets/default.srn's modules on a regular 4.3 mm lattice (quality, certificate,
#           .vtu written)
#   default Nets/default.srn as shipped
#   atlas   a 99-label brain atlas of our own (the layered head's brain at 1 mm, its grey matter split into
#           HarvardOxford's cortical labels, `layered_head --parcels`) through the same modules on
#           a 1.5 mm lattice
#   head    the layered head at 1 mm (182 x 218 x 182, six labels) through Nets/adaptive_head.srn
# The scaling table runs the organ through the same modules at falling cell sizes, once each (the
# head phantom is no such family: its one-voxel CSF is refined to the voxels at every cell size,
# so a 12 mm lattice gives more tets than a 4 mm one).
# Needs build/Interface/tetflow, build/Testing/{fidelity_benchmark,layered_head} (benchmarks on),
# python3, and mricron-data for the heads (scripts/setup.sh installs it).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
BUILD=${BUILD_DIR:-$ROOT/build}
MODE=targets
if [ "${1:-}" = "--scaling" ]; then MODE=scaling; shift; fi
OUT=${1:-$ROOT/Testing/Benchmarks/results/$([ $MODE = scaling ] && echo scaling || echo pipeline_targets).txt}
command -v python3 >/dev/null || { echo "pipeline_targets.sh needs python3 (apt-get install python3)"; exit 1; }
for f in "$BUILD/Interface/tetflow" "$BUILD/Testing/fidelity_benchmark" "$BUILD/Testing/layered_head"; do
  [ -x "$f" ] || { echo "pipeline_targets.sh: $f is missing; build with scripts/setup.sh first"; exit 1; }
done
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
"$BUILD/Testing/fidelity_benchmark" --write-organ "$WORK/organ.nrrd"
if [ $MODE = targets ]; then
  "$BUILD/Testing/layered_head" "$WORK/head1mm.nii.gz" >/dev/null
  "$BUILD/Testing/layered_head" "$WORK/atlas1mm.nii.gz" --parcels
fi
mkdir -p "$(dirname "$OUT")"
python3 - "$MODE" "$ROOT" "$BUILD/Interface/tetflow" "$WORK" "$(nproc)" "$OUT" <<'PY'
import json, os, re, statistics, subprocess, sys, time
mode, root, cli, work, cores, out = sys.argv[1:]
lines = []
def emit(s=""):
    print(s, flush=True)
    lines.append(s)

def read_volume_net(net, path, name):
    """The net with its CreatePhantom m1 replaced by ReadLabelVolume(path)."""
    s = open(net).read()
    a = s.index('    <module id="m1"'); b = s.index('    <module id="m2"')
    s = s[:a] + f'''    <module id="m1" package="TetFlow" category="DataIO" name="ReadLabelVolume" version="1.0">
      <position x="40" y="40"/>
      <var name="filename" val="{{{path}}}" substitute="no"/>
    </module>
''' + s[b:]
    dst = f"{work}/{name}.srn"
    open(dst, "w").write(s)
    return dst

def run(name, net, sets):
    """One process: wall seconds, peak RSS (bytes), report."""
    rep = f"{work}/{name}.json"
    cmd = [cli, "run", net, "--quiet", "--output-dir", f"{work}/out-{name}", "--report", rep]
    for s in sets: cmd += ["--set", s]
    t0 = time.monotonic()
    p = subprocess.Popen(cmd)
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.monotonic() - t0
    r = json.load(open(rep))
    return wall, ru.ru_maxrss * 1024, r, os.waitstatus_to_exitcode(status)

def modules(r):
    return {m["module"]: m for m in r["modules"]}

emit(f"# pipeline_targets.sh {mode} on {cores} cores, {time.strftime('%Y-%m-%d')}; wall = the whole process "
     f"(start-up, reading, every module, writing); peak = the process's peak resident memory")
if mode == "targets":
    default = f"{root}/Nets/default.srn"
    cases = [
        ("organ", read_volume_net(default, f"{work}/organ.nrrd", "organ"), ["m2.cell_size=4.3"], 2.0, 400),
        ("default", default, [], 2.5, None),
        ("atlas", read_volume_net(default, f"{work}/atlas1mm.nii.gz", "atlas"), ["m2.cell_size=1.5"], 12.0, None),
        ("head", read_volume_net(f"{root}/Nets/adaptive_head.srn", f"{work}/head1mm.nii.gz", "head"), [], 10.0, None),
    ]
    emit("# case     tets      wall_s (min-max)      target  peak_MB  B/tet  quality/cleave  status; median module seconds")
    for name, net, sets, target, mem_target in cases:
        runs = [run(name, net, sets) for _ in range(3)]
        walls = sorted(w for w, _, _, _ in runs)
        peak = max(m for _, m, _, _ in runs)
        r = runs[0][2]
        M = modules(r)
        tets = M["CleaveMesh"]["report"].get("tets", 0)
        med = {k: statistics.median(modules(x[2])[k]["seconds"] for x in runs) for k in M}
        share = med.get("EvaluateQuality", 0) / med["CleaveMesh"] if med.get("CleaveMesh") else 0
        bad = [f'{m["id"]} {m["module"]}: {m["status"]}' for m in r["modules"] if m["status"] != "done"]
        q = M.get("EvaluateQuality", {}).get("report", {})
        status = ("ok" if not bad else "; ".join(bad)) + f', cert {q.get("cert_passed", "?")}, angles [{q.get("min_dihedral_deg", 0):.2f}, {q.get("max_dihedral_deg", 0):.2f}]'
        emit(f"{name:8s} {tets:9d}  {statistics.median(walls):6.2f} ({walls[0]:.2f}-{walls[-1]:.2f})  "
             f"<= {target:4.1f}  {peak / 1e6:7.0f}{' (<= %d)' % mem_target if mem_target else ''}  {peak / max(tets, 1):5.0f}  "
             f"{100 * share:5.1f} %  {status}; " + ", ".join(f"{k} {v:.2f}" for k, v in med.items()))
        # A stage that runs more than once in a run (the repair's check and fragments, local
        # rounds) counts with the sum of its runs; then the median over the runs.
        stages = {}
        for i, x in enumerate(runs):
            for m in x[2]["modules"]:
                for st in m.get("stages", []):
                    per = stages.setdefault((m["module"], st["name"]), [0.0] * len(runs))
                    per[i] += st["seconds"]
        emit("    stages (median s, repeats summed): " + ", ".join(f"{mod}/{st} {statistics.median(v):.2f}" for (mod, st), v in stages.items()
                                                  if statistics.median(v) >= 0.05))
else:
    net = read_volume_net(f"{root}/Nets/default.srn", f"{work}/organ.nrrd", "organ")
    emit("# the organ (438 x 353 x 165 voxels of 0.8 x 0.8 x 2 mm, one smooth label) through Nets/default.srn's modules "
         "at falling cell size, one run each")
    emit("# cell_mm  background_tets  tets       wall_s  us/tet  peak_MB  B/tet  CleaveMesh_s  EvaluateQuality_s  WriteMesh_s")
    for cell in [12, 8, 6, 4.3, 3, 2.2, 1.7]:
        wall, peak, r, code = run(f"cell{cell}", net, [f"m2.cell_size={cell}"])
        M = modules(r)
        tets = M["CleaveMesh"]["report"].get("tets", 0)
        emit(f"{cell:7.2f}  {M['GenerateBackgroundMesh']['report'].get('tets', 0):15d}  {tets:9d}  {wall:6.1f}  {1e6 * wall / tets:6.2f}  "
             f"{peak / 1e6:7.0f}  {peak / tets:5.0f}  {M['CleaveMesh']['seconds']:12.1f}  {M['EvaluateQuality']['seconds']:17.1f}  "
             f"{M['WriteMesh']['seconds']:11.1f}" + ("" if code == 0 else f"  exit {code}"))
        for f in os.listdir(f"{work}/out-cell{cell}"): os.remove(f"{work}/out-cell{cell}/{f}")
open(out, "w").write("\n".join(lines) + "\n")
PY
