#pragma once
// Stripping the exterior (CleaveMesh `strip_exterior`): the part of one label that surrounds the
// object - the air around a head, the background around an organ - is removed from the mesh; what
// the label has inside the object (air in the sinuses, a cavity of background) stays, as its own
// material.
//
// Which voxels are exterior: the 26-connected components of the label's voxels that reach the
// volume's boundary (a voxel on the box), as the certificate (Algorithms/Quality/Certificate.h)
// sees them; every other component of the label is a cavity and is meant to be meshed.
// Which tets go: the label's tets fall into face-connected pieces; each tet votes, with its volume,
// for the image component at its centroid (the certificate's vote). A piece goes when it has a
// face on the domain box, or when its votes for exterior components are at least its votes for
// cavities (a piece that votes for nothing goes too). With `cavities` the label goes entirely.
// Vertices used by no tet are removed afterwards (indices renumbered in order).
#include <cstdint>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Report.h"
#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/Core/Volume.h"
#include "VolumeCorrection.h"

namespace tetflow {

struct LabelImageTopology;

struct StripParams {
  int32_t label = 0;
  bool cavities = false; // remove the label's cavities too (everything of the label)
};

struct StripStats {
  int32_t label = 0;
  int64_t exteriorVoxels = 0, cavityVoxels = 0; // of the label, in the image
  double exteriorVolume = 0.0, cavityVolume = 0.0; // mm^3 (voxels)
  int cavityComponents = 0;
  int64_t strippedTets = 0, keptTets = 0;        // of the label
  double strippedVolume = 0.0, keptVolume = 0.0; // mm^3 (tets)
};

// `image` may be given when already computed for `labels` (analyzeLabelImage); otherwise it is
// computed here. Throws InputError for a mesh failing validateStructure.
StripStats stripExterior(TetMesh& mesh, const LabelVolume& labels, const LabelImageTopology* image,
                         const StripParams& params, const DomainBox& box, Progress& progress);

// Removes the vertices no tet uses, renumbering the rest in order (point fields follow).
void removeUnusedVertices(TetMesh& mesh);

// strip_* keys.
void writeStripReport(const StripStats& s, bool cavities, Report& report);

} // namespace tetflow
