#pragma once
// A budget of output tets (max_tets): how many tets cleaving will make from a background, and the
// finest background whose mesh fits a budget.
//
// Prediction (predictCleavedTets). Every background vertex takes the label of the voxel holding
// it (nearest voxel centre; outside the grid the boundary voxels continue, as the materials do).
// A background tet whose four vertices carry one label stays one tet in the mesh (none when that
// label is the stripped one: its exterior is removed, and its cavities are small); a tet whose
// vertices carry two or more labels is cut by an interface and becomes kCutTets tets on average
// (cleaving's stencils, the label repair and the quality improvement together), kCutStrippedTets
// when one of the labels is the stripped one (part of it goes with the exterior). The factors
// are measured (Testing/Benchmarks/results/tet_budget.txt: cleaved tets against this prediction on
// the layered heads and the phantom; TetBudget.ThePredictionIsNearTheCleavedMeshOnRandomVolumes):
// the prediction lies above the mesh, by about 6 % on the 1 mm layered heads and by 5 to 30 % on
// small random volumes, so a mesh fitted to a budget stays within it.
//
// Fitting (fitTetBudget). build(s) makes the background with every size multiplied by s >= 1
// (the regular lattice's cell, the octree's sizing field, the particles' spacing); s = 1 is what
// the parameters ask for. When its prediction exceeds the budget, s grows by the cube root of the
// excess (at least 5 %, at most 2x per try; 2x when a try built the very background of the one
// before, as snapped lattice cells do for small factors), so the finest background within the
// budget is found in a few tries; the first that fits is kept. The sizes never shrink below what was asked: a
// budget only ever makes a mesh coarser. When the sizes reach maxScale, or three tries in a row
// shrink the prediction by less than 5 % (what is left is what the thin-layer refinement needs,
// which no size changes), the budget is refused: InputError naming the label that the finest
// tets hold most often (the layer whose refinement costs the budget), the tets that the
// coarsest background tried needs and what to change. A budget never buys a mesh that loses a
// label: when a try leaves fewer than kKeptVertices background vertices in a label (not the
// stripped one) that the sizes asked for gave at least that many, the budget is refused naming
// that label and the tets of the last try that kept it.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Report.h"
#include "Algorithms/Core/Volume.h"

namespace tetflow {

inline constexpr double kCutTets = 1.95;
inline constexpr double kCutStrippedTets = 1.0;
inline constexpr int64_t kKeptVertices = 4;

struct TetCountPrediction {
  int64_t backgroundTets = 0;
  int64_t uniformTets = 0;     // four vertices of one label, kept
  int64_t strippedTets = 0;    // four vertices of the stripped label
  int64_t cutTets = 0;         // several labels, none of them the stripped one
  int64_t cutStrippedTets = 0; // several labels, one of them the stripped one
  double tets = 0.0;           // the prediction
  // The label held by the most vertices-of-finest-tets: among the tets whose longest edge is
  // within a factor 1.5 of the shortest longest edge of the background, the label present (at a
  // vertex) in the largest number of them, and that number. Label 0 / count 0 when empty.
  int32_t finestLabel = 0;
  int64_t finestLabelTets = 0;
  int64_t finestTets = 0;
  double finestEdge = 0.0; // mm, the shortest longest edge
  // Background vertices per label (ascending by label): a label with none is lost to cleaving.
  std::vector<std::pair<int32_t, int64_t>> vertexLabels;
};

// Both cores; the result does not depend on the thread count.
TetCountPrediction predictCleavedTets(const TetMesh& background, const LabelVolume& labels,
                                      std::optional<int32_t> strippedLabel, Progress& progress);

struct TetBudgetParams {
  int64_t maxTets = 0;                  // > 0
  std::optional<int32_t> strippedLabel; // the label CleaveMesh strips (strip_exterior), if any
  double maxScale = 64.0;               // the largest size factor to try
  std::string scaledWhat = "the sizes"; // for messages, e.g. "cell_size 4 mm"
  std::string refinementAdvice;         // what to change when the refinement is what costs
};

struct TetBudgetTry {
  double scale = 1.0;
  int64_t backgroundTets = 0;
  double predicted = 0.0;
};

struct TetBudgetResult {
  BackgroundMesh background;
  TetCountPrediction prediction;
  double scale = 1.0;
  std::vector<TetBudgetTry> tries;
};

TetBudgetResult fitTetBudget(const std::function<BackgroundMesh(double scale)>& build, const LabelVolume& labels,
                             const TetBudgetParams& params, Progress& progress);

// Report keys: predicted_tets, and with a budget max_tets, budget_scale, budget_tries.
void reportTetPrediction(const TetCountPrediction& p, Report& r);

} // namespace tetflow
