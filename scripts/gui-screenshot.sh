#!/usr/bin/env bash
# Screenshots of tetflow-gui for the manual (docs/), taken by the application itself under Xvfb:
# it opens a net, executes it, selects a module, sets up the 3D view and grabs its own window.
#
#   scripts/gui-screenshot.sh [BUILD_DIR]      (default: build) -> docs/tetflow-gui-*.png
#
# Outputs of the nets (WriteMesh files) go to BUILD_DIR/gui-screenshot-out, not into Nets/.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-build}
case "$build" in /*) ;; *) build="$here/$build" ;; esac
gui="$build/Interface/tetflow-gui"
out="$build/gui-screenshot-out"
mkdir -p "$here/docs" "$out"
shot() {
  xvfb-run -a -s '-screen 0 1280x800x24' "$gui" --output-dir "$out" --size 1280x800 "$@"
}
# Head phantom: the cleaved mesh, clipped at y = 0 to show scalp, skull, CSF and brain.
shot "$here/Nets/default.srn" --select m3 --clip y:0.5 --screenshot "$here/docs/tetflow-gui-cleave.png"
# The same net: EvaluateQuality's mesh coloured by minimum dihedral angle, with its report and
# histogram.
shot "$here/Nets/default.srn" --select m4 --color min_dihedral --clip y:0.5 --show-report \
  --screenshot "$here/docs/tetflow-gui-quality.png"
# The certificate on the old default settings (blend_sigma 1, no label repair): EvaluateQuality's
# mesh coloured by certificate_flags, which marks the CSF's extra pieces and the brain-skull contact.
sed -e 's/<var name="blend_sigma" val="{0.5}"/<var name="blend_sigma" val="{1}"/g' \
    -e 's/<var name="repair_labels" val="{true}"/<var name="repair_labels" val="{false}"/' \
    -e 's/<var name="require_components" val="{true}"/<var name="require_components" val="{false}"/' \
    -e 's/<var name="forbid_spurious_contacts" val="{true}"/<var name="forbid_spurious_contacts" val="{false}"/' \
    "$here/Nets/default.srn" > "$out/old-default.srn"
# The certificate fails there on purpose: tetflow-gui writes the picture and exits 1.
shot "$out/old-default.srn" --select m4 --color certificate_flags --clip y:0.5 --show-report \
  --screenshot "$here/docs/tetflow-gui-certificate.png" || [ $? -eq 1 ]
# The particle background of the unstructured adaptive net (GenerateBackgroundMesh), clipped.
shot "$here/Nets/adaptive_particles.srn" --select m2 --clip y:0.5 --show-report \
  --screenshot "$here/docs/tetflow-gui-particles.png"
# The CAD electrode net: the potential of the bipolar electrode's solve, clipped through its axis.
shot "$here/Nets/cad_electrode.srn" --select m4 --color potential --clip x:0.5 --show-report \
  --screenshot "$here/docs/tetflow-gui-cad.png"
# The EEG net: AssembleFEMPoisson's parameters (the longest list), each value whole and with its
# unit, beside the dipole's potential on the diverging colour scale, clipped through the dipole;
# the legend names the tissues.
shot "$here/Nets/head_dipole.srn" --select m4 --color potential --clip x:0.5 \
  --screenshot "$here/docs/tetflow-gui-dipole.png"
