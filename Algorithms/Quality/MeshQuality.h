#pragma once
// Quality evaluation of a whole tetrahedral mesh (DESIGN §3 EvaluateQuality, §6 definitions).
//
// evaluateQuality() computes, for a TetMesh (points in mm, 0-based tets, per-tet material label):
//  - per-tet metrics (TetQuality.h) as cell fields, one value per tet, in tet order:
//      "min_dihedral" [deg], "max_dihedral" [deg], "aspect_ratio", "radius_ratio",
//      "volume" [mm^3, signed: < 0 for an inverted tet];
//  - validity (DESIGN §6): inverted, zero-volume and duplicate tets, how the triangular faces are
//    shared, whether the boundary surface is closed, unreferenced vertices;
//  - angle statistics: min / max dihedral over all tets, a histogram of the per-tet minimum
//    dihedral angle, counts of tets whose minimum dihedral is below 5, 10 and 15 degrees;
//  - aspect ratio and radius ratio min and median, total and per-material volume, and the
//    relative difference to reference volumes when given (fidelity, DESIGN §6).
// The per-tet work runs in parallel with OpenMP (omp_get_max_threads() threads). Face analysis
// sorts packed integer keys (parallel sort): O(n log n) time and O(n) extra memory for n tets
// (about 4 keys of 8 bytes per tet below 2^21 vertices, 16 bytes per key above).
//
// Stages reported to the Progress sink: "metrics", "topology", "statistics". Cancellation is
// honoured between blocks of tets (throws Cancelled).
//
// Errors (InputError): a mesh failing TetMesh::validateStructure, a mesh without tets, a bin
// width outside [kMinBinWidthDeg, 90] or not finite, a reference volume that is not a finite
// number > 0.
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Report.h"
#include "Algorithms/Core/TetMesh.h"

namespace tetflow {

// Smallest accepted histogram bin width [deg]: at most 180000 bins (the brief's range is (0, 90];
// widths below this would only exhaust memory).
inline constexpr double kMinBinWidthDeg = 1e-3;

struct QualityParams {
  double bin_width_deg = 5.0;                  // histogram bin width [deg], in [kMinBinWidthDeg, 90]
  std::map<int32_t, double> referenceVolumes;  // optional reference volume [mm^3] per material label
};

// Thresholds [deg] of QualityResult::tetsBelow.
inline constexpr std::array<double, 3> kMinDihedralThresholds{5.0, 10.0, 15.0};

struct MaterialQuality {
  int64_t tets = 0;
  double volume = 0.0;        // sum of the signed tet volumes of this label [mm^3]
  bool hasReference = false;
  double reference = 0.0;     // [mm^3], when hasReference
  double relError = 0.0;      // (volume - reference) / reference, when hasReference
};

struct QualityResult {
  int64_t vertices = 0;
  int64_t tets = 0;

  // --- validity -------------------------------------------------------------------------
  // Each tet is in at most one of: zero-volume (|V| <= kZeroVolumeRelTol * L_max^3, which
  // includes tets repeating a vertex index), inverted (V < 0 and not zero-volume).
  int64_t inverted = 0;
  int64_t zeroVolume = 0;
  int64_t repeatedVertexTets = 0; // tets naming one vertex twice (also counted in zeroVolume);
                                  // their faces are left out of the face analysis
  int64_t duplicateTets = 0;      // tets whose vertex set equals that of an earlier tet
  // Distinct triangular faces (vertex sets), by the number of tets containing them.
  int64_t boundaryFaces = 0;      // in exactly one tet
  int64_t interiorFaces = 0;      // in exactly two tets
  int64_t nonmanifoldFaces = 0;   // in more than two tets
  // Interior faces whose two tets lie on the same side of it (overlap or inversion). Reported,
  // but not part of `valid` (DESIGN §6 defines validity without it).
  int64_t foldedFaces = 0;
  // Edges of the boundary faces: closed when every one is in exactly two boundary faces.
  int64_t boundaryEdges = 0;             // distinct edges of boundary faces
  int64_t openBoundaryEdges = 0;         // in exactly one boundary face
  int64_t nonmanifoldBoundaryEdges = 0;  // in more than two boundary faces
  bool boundaryClosed = false;
  int64_t unreferencedVertices = 0;      // vertices used by no tet
  // DESIGN §6: every tet has positive volume (inverted == 0 and zeroVolume == 0), no duplicate
  // tets, every face in one (boundary) or two (interior) tets (nonmanifoldFaces == 0).
  bool valid = false;

  // --- angles (degrees) -----------------------------------------------------------------
  double minDihedral = 0.0; // min over tets of the per-tet minimum dihedral angle
  double maxDihedral = 0.0; // max over tets of the per-tet maximum dihedral angle
  // Histogram of the per-tet minimum dihedral angle: bin i counts angles in
  // [i*binWidth, (i+1)*binWidth), the last bin ends at 180 and includes it;
  // ceil(180 / binWidth) bins; the counts sum to `tets`.
  double binWidth = 5.0;
  std::vector<int64_t> histogram;
  std::array<int64_t, 3> tetsBelow{}; // tets with min dihedral < kMinDihedralThresholds[i]

  // --- ratios (dimensionless) -----------------------------------------------------------
  // Median of an even count is the mean of the two middle values.
  double aspectRatioMin = 0.0, aspectRatioMedian = 0.0;
  double radiusRatioMin = 0.0, radiusRatioMedian = 0.0;

  // --- volumes (mm^3) -------------------------------------------------------------------
  double volume = 0.0; // sum of the signed tet volumes
  std::map<int32_t, MaterialQuality> materials;     // every label present in the mesh
  std::vector<int32_t> referenceLabelsMissing;      // reference labels without any tet, ascending

  // Per-tet fields named as above, components = 1, size = tets.
  std::map<std::string, Field> cellFields;
};

QualityResult evaluateQuality(const TetMesh& mesh, const QualityParams& params, Progress& progress);

// Bin label "lo-hi" of histogram bin i (e.g. "5-10", "2.5-5").
std::string histogramBinLabel(const QualityResult& r, size_t bin);

// Fills `report` in this order (existing keys are replaced in place):
//   tets, vertices, valid, inverted, zero_volume, repeated_vertex_tets, duplicate_tets,
//   nonmanifold_faces, interior_faces, boundary_faces, folded_faces, boundary_edges,
//   open_boundary_edges, nonmanifold_boundary_edges, boundary_closed, unreferenced_vertices,
//   min_dihedral_deg, max_dihedral_deg, tets_below_5deg, tets_below_10deg, tets_below_15deg,
//   aspect_ratio_min, aspect_ratio_median, radius_ratio_min, radius_ratio_median, volume_mm3,
//   then per material label L (ascending): material_L_tets, material_L_volume_mm3 and, with a
//   reference, material_L_reference_mm3, material_L_volume_rel_error; then
//   reference_labels_missing (space-separated labels, only when there are references),
//   histogram_bin_deg, and min_dihedral_histogram ("0-5:0 5-10:3 ..." every bin, in order).
void writeQualityReport(const QualityResult& result, Report& report);

} // namespace tetflow
