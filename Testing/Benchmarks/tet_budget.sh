#!/bin/bash
# Lean meshes (issue 50): `tetflow mesh` on realistic 1 mm heads with its defaults and with the
# options a user turns, against the certificate.
#
#   Testing/Benchmarks/tet_budget.sh [RESULTS_FILE]     (about 10 minutes on 2 cores)
#
# Inputs: the layered heads 0, 1 and 2 at 1 mm (182 x 218 x 182; scalp, skull, CSF, grey, white,
# air; Testing/Fixtures/LayeredHead.h, from mricron-data's HarvardOxford and JHU atlases, none of
# the held-out volumes). Per run, once: the whole process's wall time and peak resident memory
# (wait4's rusage), the mesh's tets and GenerateBackgroundMesh's prediction of them, and from
# EvaluateQuality's certificate (--certify: every label within 1.5 %, every component kept, no
# spurious contact, angles in [10, 160] deg) whether it passed, the worst volume error over the
# tissues of >= 1000 voxels, the CSF's voxel agreement and the dihedral range.
# Needs build/Interface/tetflow and build/Testing/layered_head (benchmarks on), python3 and
# mricron-data (scripts/setup.sh installs it).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
BUILD=${BUILD_DIR:-$ROOT/build}
OUT=${1:-$ROOT/Testing/Benchmarks/results/tet_budget.txt}
command -v python3 >/dev/null || { echo "tet_budget.sh needs python3 (apt-get install python3)"; exit 1; }
for f in "$BUILD/Interface/tetflow" "$BUILD/Testing/layered_head"; do
  [ -x "$f" ] || { echo "tet_budget.sh: $f is missing; build with scripts/setup.sh first"; exit 1; }
done
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
for v in 0 1 2; do "$BUILD/Testing/layered_head" "$WORK/head$v.nii.gz" --variant $v >/dev/null; done
mkdir -p "$(dirname "$OUT")"
python3 - "$BUILD/Interface/tetflow" "$WORK" "$(nproc)" "$OUT" "$(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo unknown)" <<'PY'
import json, os, subprocess, sys, time
cli, work, cores, out, commit = sys.argv[1:]
lines = []
def emit(s=""):
    print(s, flush=True)
    lines.append(s)

RUNS = [  # (name, options, heads)
    ("regular, default (cell 4 x voxel)", [], (0, 1, 2)),
    ("regular, --cell-size 2", ["--cell-size", "2"], (0,)),
    ("regular, --cell-size 6 (-> 8 mm cells)", ["--cell-size", "6"], (0,)),
    ("regular, default, thin_layer_ratio 1", ["--set", "m2.thin_layer_ratio=1"], (0,)),
    ("--adaptive (octree, 4 to 16 x voxel)", ["--adaptive"], (0, 1, 2)),
    ("--adaptive --max-tets 1000000", ["--adaptive", "--max-tets", "1000000"], (0, 1, 2)),
    ("regular --max-tets 1000000", ["--max-tets", "1000000"], (0,)),
    ("--background particles (2 to 16 x voxel)", ["--background", "particles"], (0,)),
]

def run(head, opts, tag):
    rep = f"{work}/{tag}.json"
    cmd = [cli, "mesh", f"{work}/{head}.nii.gz", "-o", f"{work}/{tag}.vtu", "--certify", "--quiet", "--report", rep] + opts
    t0 = time.monotonic()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.monotonic() - t0
    text = p.stdout.read().decode(errors="replace")
    code = os.waitstatus_to_exitcode(status)
    if not os.path.exists(rep):
        return dict(code=code, wall=wall, rss=ru.ru_maxrss * 1024, text=text)
    mods = {m["id"]: m for m in json.load(open(rep))["modules"]}
    g, c, q = (mods.get(k, {}).get("report", {}) for k in ("m2", "m3", "m4"))
    tets = c.get("tets", 0)
    worst, wl = 0.0, "-"
    for k, v in q.items():
        if k.startswith("cert_label_") and k.endswith("_volume_rel_error"):
            L = k.split("_")[2]
            if q.get(f"cert_label_{L}_voxel_volume_mm3", 0) >= 1000 and abs(v) > abs(worst):
                worst, wl = v, L
    return dict(code=code, wall=wall, rss=ru.ru_maxrss * 1024, tets=tets, pred=g.get("predicted_tets", 0),
                scale=g.get("budget_scale", 1.0), worst=worst, wl=wl, csf=q.get("cert_label_3_voxel_agreement", 0.0),
                agree=q.get("cert_voxel_agreement", 0.0), lo=q.get("min_dihedral_deg", 0.0), hi=q.get("max_dihedral_deg", 0.0),
                passed=q.get("cert_passed", False), text=text)

emit(f"# tet_budget.sh at {commit}, {time.strftime('%Y-%m-%d')}, {cores} hardware threads; `tetflow mesh HEAD --certify [options]`")
emit("# wall_s and peak RSS of the whole process (read, sizing, background, cleave, quality, certificate, write .vtu);")
emit("# pred = GenerateBackgroundMesh's predicted_tets; worst = worst volume error over tissues of >= 1000 voxels;")
emit("# csf_agree = the CSF voxels whose centres lie in CSF tets; B/tet = peak RSS / tets; cert = exit 0 of --certify")
for v in (0, 1, 2):
    emit(f"layered head variant {v}, 1 mm, 182 x 218 x 182 (air outside stripped):")
    emit(f"  {'run':46s} {'tets':>9s} {'pred':>9s} {'scale':>5s} {'wall_s':>6s} {'RSS_MB':>6s} {'B/tet':>5s} {'worst':>12s} {'agree':>5s} {'csf':>5s} {'dihedral':>14s} cert")
    for i, (name, opts, heads) in enumerate(RUNS):
        if v not in heads:
            continue
        r = run(f"head{v}", opts, f"h{v}_{i}")
        if "tets" not in r or not r["tets"]:
            why = [l.strip() for l in r["text"].splitlines() if " error " in l]
            emit(f"  {name:46s} refused (exit {r['code']}) in {r['wall']:.1f} s: {why[0][:300] if why else ''}")
            continue
        bpt = r["rss"] / max(r["tets"], 1)
        emit(f"  {name:46s} {r['tets']:9d} {r['pred']:9d} {r['scale']:5.2f} {r['wall']:6.1f} {r['rss']/2**20:6.0f} {bpt:5.0f} "
             f"{100*r['worst']:+7.2f}% (L{r['wl']}) {r['agree']:5.3f} {r['csf']:5.3f} [{r['lo']:5.1f}, {r['hi']:5.1f}] "
             f"{'passed' if r['code'] == 0 and r['passed'] else 'FAILED (exit %d)' % r['code']}")
        if r["code"] != 0:
            for l in r["text"].splitlines():
                if "error" in l or "fails" in l:
                    emit(f"      {l.strip()[:300]}")
                    break
open(out + ".tmp", "w").write("\n".join(lines) + "\n")
os.replace(out + ".tmp", out)
PY
