#!/usr/bin/env bash
# Cancellation latency (docs/reliability.md): runs Nets/default.srn with a 2 mm lattice (about 13 s,
# 5.5 M tets, every stage long enough to be hit; the volume bound is off so that WriteMesh runs
# too: at 2 mm the CSF is 6 % thin), sends SIGINT at a series of moments, and records how long the
# process took to exit after the signal, which module was running, and the exit code (130 wanted).
# Results: Testing/Benchmarks/results/cancel.txt.
#
#   Testing/Benchmarks/cancel_latency.sh [BUILD_DIR]     (default: build)
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${1:-build}
case "$build" in /*) ;; *) build="$here/$build" ;; esac
cli="$build/Interface/tetflow"
net="$here/Nets/default.srn"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
results="$here/Testing/Benchmarks/results/cancel.txt"
now() { date +%s.%N; }
{
  echo "# cancel_latency.sh: SIGINT into 'tetflow run Nets/default.srn --set m2.cell_size=2 --set m4.max_volume_error=0'"
  echo "# $(date -u +%Y-%m-%d) on $(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'))"
  echo "# signal_at_s  exit_after_s  exit_code  running_module"
} > "$results.tmp"
worst=0
for at in $(seq 0.3 0.4 12.3); do
  log="$out/log.txt"
  "$cli" run "$net" --set m2.cell_size=2 --set m4.max_volume_error=0 --output-dir "$out/o" > "$log" 2>&1 &
  pid=$!
  sleep "$at"
  if ! kill -0 "$pid" 2>/dev/null; then
    wait "$pid" || true
    echo "$at  (finished before the signal)" >> "$results.tmp"
    continue
  fi
  # The module running at the signal: the first module without a finished line yet.
  done_ids=$(grep -oE '^m[0-9]+' "$log" | tr '\n' ' ')
  running=$(for m in m1 m2 m3 m4 m5; do case " $done_ids " in *" $m "*) ;; *) echo "$m"; break ;; esac; done)
  t0=$(now)
  kill -INT "$pid"
  code=0
  wait "$pid" || code=$?
  t1=$(now)
  lat=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", b - a }')
  printf '%-11s  %-12.3f  %-9s  %s\n' "$at" "$lat" "$code" "$running" >> "$results.tmp"
  worst=$(awk -v a="$lat" -v b="$worst" 'BEGIN { print (a > b ? a : b) }')
done
printf '# worst: %.3f s\n' "$worst" >> "$results.tmp"
mv "$results.tmp" "$results"
cat "$results"
