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
#include <utility>
#include <vector>

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
// computed here. `joins` (LabelTopology.h), when given, connect pieces of the label through a part
// of the exterior that was never meshed (CleavePipeline's cull): a piece with such a join goes, as
// one with a face on the box does. Throws InputError for a mesh failing validateStructure.
StripStats stripExterior(TetMesh& mesh, const LabelVolume& labels, const LabelImageTopology* image,
                         const StripParams& params, const DomainBox& box, Progress& progress,
                         const std::vector<std::pair<int32_t, int32_t>>* joins = nullptr,
                         std::vector<int32_t>* faceNeighbours = nullptr);
// `faceNeighbours` (tetFaceNeighbours of the mesh, or empty): used when filled, and on return those
// of the stripped mesh (renumbered; a face towards a removed tet is a boundary face), or empty
// when they were not known.

// Whether a point lies in the exterior of `params.label`: the voxel nearest to it carries the
// label and is in one of its 26-connected components that reach the box (any of its components
// with `params.cavities`), as stripExterior sees them. From the label's runs (LabelRuns.h): memory
// for its runs, not per voxel. `labels` must outlive it.
class ExteriorTest {
public:
  ExteriorTest(const LabelVolume& labels, const StripParams& params, Progress& progress);
  bool operator()(const Vec3& p) const;

private:
  const LabelVolume& labels_;
  std::vector<int64_t> start_;   // per row: its first run
  std::vector<int32_t> i0_, i1_; // runs (of the label only)
  std::vector<uint8_t> exterior_; // per run
};

// Removes the vertices no tet uses, renumbering the rest in order (point fields follow).
void removeUnusedVertices(TetMesh& mesh);

// strip_* keys.
void writeStripReport(const StripStats& s, bool cavities, Report& report);

} // namespace tetflow
