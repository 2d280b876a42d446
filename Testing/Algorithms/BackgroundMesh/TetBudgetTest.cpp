// Tet budgets (TetBudget.h): the prediction of the cleaved mesh's size from a background, the
// fit of a background to a budget, and the thin-layer refinement that follows the layers' own
// thickness (EdgeTopology's split ratio) on root cells that are powers of two of the voxel.
#include <gtest/gtest.h>

#include <random>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/BackgroundMesh/OctreeBcc.h"
#include "Algorithms/BackgroundMesh/TetBudget.h"
#include "Algorithms/BackgroundMesh/ThinLayers.h"
#include "Algorithms/Cleaving/CleavePipeline.h"
#include "Algorithms/Core/Errors.h"
#include "Fixtures/LabelShapes.h"
#include "Fixtures/RandomLabels.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {

BackgroundMesh budgetLattice(const LabelVolume& v, double cell) {
  NullProgress np;
  return generateRegularBcc(v.grid, BccParams{cell, 0.0}, np);
}

// The cleaved mesh's size as CleaveMesh makes it (its defaults: label repair, stripping, volume
// correction; no improvement, which changes few tets).
int64_t cleavedTets(const LabelVolume& v, const BackgroundMesh& bg, std::optional<int32_t> strip) {
  NullProgress np;
  const auto vol = std::make_shared<const LabelVolume>(v);
  const LabelMaterials mats(vol, kDefaultBlendSigma);
  CleavePipelineParams pp;
  pp.strip = strip;
  return int64_t(cleavePipeline(bg, mats, pp, np).cleaved.mesh.numTets());
}

} // namespace

TEST(TetBudget, OneLabelIsItsBackgroundAndNothingWhenStripped) {
  const LabelVolume v = test::labelVolumeOf(12, [](double, double, double) { return 3; });
  const BackgroundMesh bg = budgetLattice(v, 3.0);
  NullProgress np;
  const TetCountPrediction kept = predictCleavedTets(bg.mesh, v, std::nullopt, np);
  EXPECT_EQ(kept.uniformTets, int64_t(bg.mesh.numTets()));
  EXPECT_EQ(kept.cutTets + kept.cutStrippedTets + kept.strippedTets, 0);
  EXPECT_DOUBLE_EQ(kept.tets, double(bg.mesh.numTets()));
  const TetCountPrediction gone = predictCleavedTets(bg.mesh, v, 3, np);
  EXPECT_EQ(gone.strippedTets, int64_t(bg.mesh.numTets()));
  EXPECT_DOUBLE_EQ(gone.tets, 0.0);
}

TEST(TetBudget, EveryTetIsCountedOnceAndCutTetsWhereTheLabelsMeet) {
  // A ball of label 2 in a shell of 1 in 0: the cut tets lie on the two spheres, the rest is one label.
  const LabelVolume v = test::nestedBalls(24, 6.0, 9.0);
  const BackgroundMesh bg = budgetLattice(v, 2.0);
  NullProgress np;
  const TetCountPrediction p = predictCleavedTets(bg.mesh, v, 0, np);
  EXPECT_EQ(p.uniformTets + p.strippedTets + p.cutTets + p.cutStrippedTets, int64_t(bg.mesh.numTets()));
  EXPECT_GT(p.cutTets, 0);         // between 1 and 2
  EXPECT_GT(p.cutStrippedTets, 0); // between 0 and 1
  EXPECT_DOUBLE_EQ(p.tets, double(p.uniformTets) + kCutTets * double(p.cutTets) +
                               kCutStrippedTets * double(p.cutStrippedTets));
}

TEST(TetBudget, ThePredictionIsNearTheCleavedMeshOnRandomVolumes) {
  std::mt19937 rng(20261203);
  double worst = 0.0;
  for (int c = 0; c < test::sanitizerCases(6); ++c) {
    const LabelVolume v = test::voronoiWithSheets(rng, 20);
    const double cell = 1.5 + 0.5 * double(c % 3);
    const BackgroundMesh bg = budgetLattice(v, cell);
    NullProgress np;
    const std::optional<int32_t> strip = c % 2 ? std::optional<int32_t>(v.data[0]) : std::nullopt;
    const double predicted = predictCleavedTets(bg.mesh, v, strip, np).tets;
    const int64_t actual = cleavedTets(v, bg, strip);
    SCOPED_TRACE(::testing::Message() << "case " << c << " cell " << cell << ": predicted " << predicted
                                      << ", cleaved " << actual);
    ASSERT_GT(actual, 0);
    const double err = predicted / double(actual) - 1.0;
    std::printf("  case %d, cell %.1f mm%s: predicted %.0f, cleaved %lld (%+.1f %%)\n", c, cell, strip ? ", stripped" : "",
                predicted, static_cast<long long>(actual), 100.0 * err);
    worst = std::max(worst, std::abs(err));
    // Conservative, as a budget needs: never much below the mesh, and not far above it.
    EXPECT_GT(err, -0.05);
    EXPECT_LT(err, 0.35);
  }
  std::printf("tet prediction on random volumes: worst error %.1f %%\n", 100.0 * worst);
}

TEST(TetBudget, TheAskedSizesStayWhenTheyFit) {
  const LabelVolume v = test::nestedBalls(24, 6.0, 9.0);
  std::vector<double> built;
  auto build = [&](double s) {
    built.push_back(s);
    return budgetLattice(v, 2.0 * s);
  };
  TetBudgetParams p;
  p.maxTets = 10000000;
  NullProgress np;
  const TetBudgetResult r = fitTetBudget(build, v, p, np);
  EXPECT_EQ(r.scale, 1.0);
  ASSERT_EQ(built.size(), 1u);
  EXPECT_EQ(r.tries.size(), 1u);
  EXPECT_EQ(r.background.mesh.numTets(), budgetLattice(v, 2.0).mesh.numTets());
}

TEST(TetBudget, SizesGrowUntilThePredictionFits) {
  const LabelVolume v = test::nestedBalls(32, 7.0, 11.0);
  NullProgress np;
  auto build = [&](double s) { return budgetLattice(v, 1.5 * s); };
  const double full = predictCleavedTets(build(1.0).mesh, v, 0, np).tets;
  for (double fraction : {0.5, 0.2}) {
    TetBudgetParams p;
    p.maxTets = int64_t(full * fraction);
    p.strippedLabel = 0;
    const TetBudgetResult r = fitTetBudget(build, v, p, np);
    SCOPED_TRACE(::testing::Message() << "budget " << p.maxTets);
    EXPECT_GT(r.scale, 1.0);
    EXPECT_LE(r.prediction.tets, double(p.maxTets));
    ASSERT_GE(r.tries.size(), 2u);
    EXPECT_GT(r.tries[r.tries.size() - 2].predicted, double(p.maxTets)); // the try before did not fit
    for (size_t i = 1; i < r.tries.size(); ++i) EXPECT_GT(r.tries[i].scale, r.tries[i - 1].scale);
    // The mesh itself stays within the budget.
    EXPECT_LE(cleavedTets(v, r.background, 0), p.maxTets);
  }
  // Cells coarse enough for 2 % would leave a label (the shell, 1) without a vertex: refused.
  TetBudgetParams p;
  p.maxTets = int64_t(full * 0.02);
  p.strippedLabel = 0;
  try {
    fitTetBudget(build, v, p, np);
    FAIL() << "a budget that loses the ball was met";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot be met without losing label 1: with the sizes x "), std::string::npos)
        << e.what();
  }
}

TEST(TetBudget, AnImpossibleBudgetIsRefusedNamingTheLayer) {
  // A one-voxel shell ("CSF") between a ball and the outside: the thin-layer refinement keeps
  // refining it whatever the cells, so no cell size brings the mesh below its floor.
  LabelVolume v = test::nestedBalls(40, 12.0, 13.0, 2, 3, 1);
  v.labelNames = {{1, "scalp"}, {2, "brain"}, {3, "CSF"}};
  const EdgeTopology thin(v, EdgeTopology::Mode::Separating);
  NullProgress np;
  auto build = [&](double s) {
    return generateThinLayerBcc(v.grid, BccParams{4.0 * s, 0.0}, OctreeBccParams{}, thin, np).background;
  };
  const double floor = predictCleavedTets(build(8.0).mesh, v, std::nullopt, np).tets;
  TetBudgetParams p;
  p.maxTets = int64_t(floor / 4);
  p.maxScale = 8.0;
  p.scaledWhat = "cell_size 4 mm";
  p.refinementAdvice = "raise thin_layer_ratio";
  try {
    fitTetBudget(build, v, p, np);
    FAIL() << "a budget of a quarter of the floor was accepted";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("max_tets " + std::to_string(p.maxTets) + " cannot be met"), std::string::npos) << m;
    EXPECT_NE(m.find("CSF (label 3)"), std::string::npos) << m;
    EXPECT_NE(m.find("raise thin_layer_ratio"), std::string::npos) << m;
    EXPECT_NE(m.find("cell_size 4 mm"), std::string::npos) << m;
  }
  p.maxTets = 0;
  EXPECT_THROW(fitTetBudget(build, v, p, np), InputError);
}

TEST(TetBudget, ASplitRatioCountsOnlyMissesLongerThanItTimesTheLayer) {
  // A one-voxel sheet (x = 10) of label 1 in 0: a 3 mm segment across it sees 1 mm of it.
  LabelVolume v = test::labelVolumeOf(20, [](double x, double, double) { return std::abs(x + 9.5 - 10) < 0.5 ? 1 : 0; });
  EdgeTopology t(v);
  EXPECT_TRUE(t.missesMaterial({8.5, 5, 5}, {11.5, 5, 5}));
  t.setSplitRatio(2.0);
  EXPECT_TRUE(t.missesMaterial({8.5, 5, 5}, {11.5, 5, 5})); // 3 > 2 x 1
  t.setSplitRatio(4.0);
  EXPECT_FALSE(t.missesMaterial({8.5, 5, 5}, {11.5, 5, 5})); // 3 <= 4 x 1
  EXPECT_TRUE(t.missesMaterial({6.5, 5, 5}, {13.5, 5, 5}));  // 7 > 4 x 1
  EXPECT_FALSE(t.missesMaterial({8.5, 5, 5}, {9.2, 5, 5}));  // no miss at any ratio
}

TEST(TetBudget, TwoPiecesOfOneLabelAreKeptApartInSeparatingMode) {
  // Two blocks of label 1 in 0, one voxel of 0 between them (x = 10): a segment from one to the
  // other would merge them. One label in one piece each way would need no refinement at all.
  const LabelVolume two = test::labelVolumeOf(20, [](double x, double y, double z) {
    const double i = x + 9.5;
    return std::abs(y) < 5 && std::abs(z) < 5 && i >= 4 && i <= 16 && std::abs(i - 10) > 0.5 ? 1 : 0;
  });
  const EdgeTopology sep(two, EdgeTopology::Mode::Separating);
  EXPECT_FALSE(sep.nothingMisses());
  EXPECT_TRUE(sep.missesMaterial({8.2, 9.2, 9.2}, {11.8, 9.2, 9.2}));
  EXPECT_FALSE(sep.missesMaterial({8.2, 9.2, 9.2}, {9.2, 9.2, 9.2})); // within one piece
  const LabelVolume one = test::labelVolumeOf(20, [](double x, double y, double z) {
    return std::abs(x) < 5 && std::abs(y) < 5 && std::abs(z) < 5 ? 1 : 0;
  });
  EXPECT_TRUE(EdgeTopology(one, EdgeTopology::Mode::Separating).nothingMisses());
}

TEST(TetBudget, ThinLayerRootsArePowersOfTwoOfTheVoxelAndCoarserCellsGiveNoMoreTets) {
  const LabelVolume v = test::nestedBalls(40, 12.0, 13.0, 2, 3, 1);
  EdgeTopology thin(v, EdgeTopology::Mode::Separating);
  thin.setSplitRatio(2.0);
  NullProgress np;
  size_t previous = SIZE_MAX;
  for (double cell : {2.0, 3.0, 4.0, 5.0, 6.0, 8.0}) { // (40 mm boxes: 16 mm targets would round to 13.3 mm)
    const OctreeBccResult r = generateThinLayerBcc(v.grid, BccParams{cell, 0.0}, OctreeBccParams{}, thin, np);
    const double snapped = std::exp2(std::round(std::log2(cell)));
    SCOPED_TRACE(::testing::Message() << "cell " << cell << " -> " << r.background.cellSize[0]);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(r.background.cellSize[a], 40.0 / std::round(40.0 / snapped), 1e-9);
    EXPECT_LE(r.background.mesh.numTets(), previous);
    previous = r.background.mesh.numTets();
  }
}
