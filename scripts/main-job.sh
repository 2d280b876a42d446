#!/usr/bin/env bash
# The main job on the bundled default input: the four-layer head phantom, written in every
# volume format, read back and summarised (dims, spacing, origin, labels, voxel counts).
set -euo pipefail
build=${1:-build}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out="$here/out"
mkdir -p "$out"
tool="$here/$build/Interface/tetflow-volume"
[ -x "$tool" ] || tool="$build/Interface/tetflow-volume"
"$tool" phantom head "$out/head.nrrd"
for ext in nii.gz mha inr.gz vti; do
  "$tool" convert "$out/head.nrrd" "$out/head.$ext"
done
"$tool" info "$out/head.nrrd" "$out/head.nii.gz" "$out/head.mha" "$out/head.inr.gz" "$out/head.vti"
