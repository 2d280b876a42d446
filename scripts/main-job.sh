#!/usr/bin/env bash
# The main job on the bundled default input: run Nets/default.srn headless (the four-layer head
# phantom and what the network does with it), outputs and the JSON report under out/.
set -euo pipefail
build=${1:-build}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
case "$build" in /*) ;; *) build="$here/$build" ;; esac
mkdir -p "$here/out"
exec "$build/Interface/tetflow" run "$here/Nets/default.srn" --output-dir "$here/out" \
  --report "$here/out/default-report.json"
