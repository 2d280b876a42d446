#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/Core/Volume.h"
#include "TestUtil.h"

using namespace tetflow;

TEST(GridGeometry, IndexToPhysicalUsesSpacingOriginAndDirection) {
  GridGeometry g;
  g.dims = {4, 5, 6};
  g.spacing = {0.5, 2.0, 3.0};
  g.origin = {10, 20, 30};
  Vec3 p = g.indexToPhysical(1, 2, 3);
  EXPECT_DOUBLE_EQ(p[0], 10.5);
  EXPECT_DOUBLE_EQ(p[1], 24.0);
  EXPECT_DOUBLE_EQ(p[2], 39.0);
  // Rotation by 90 degrees about z: i axis -> +y, j axis -> -x.
  g.direction = {{{0, -1, 0}, {1, 0, 0}, {0, 0, 1}}};
  p = g.indexToPhysical(1, 2, 3);
  EXPECT_DOUBLE_EQ(p[0], 10 - 4.0);
  EXPECT_DOUBLE_EQ(p[1], 20 + 0.5);
  EXPECT_FALSE(g.isAxisAligned());
  EXPECT_NO_THROW(g.validate("g"));
}

TEST(GridGeometry, ValidateRejectsBadGeometry) {
  GridGeometry g;
  g.dims = {2, 2, 2};
  g.spacing = {1, 0, 1};
  EXPECT_THROW_MSG(g.validate("f.nrrd"), InputError, "f.nrrd", "spacing along axis 1", "positive");
  g.spacing = {1, -2, 1};
  EXPECT_THROW_MSG(g.validate("f.nrrd"), InputError, "axis 1");
  g.spacing = {1, 1, std::numeric_limits<double>::quiet_NaN()};
  EXPECT_THROW_MSG(g.validate("f.nrrd"), InputError, "axis 2");
  g.spacing = {1, 1, 1};
  g.dims = {2, 0, 2};
  EXPECT_THROW_MSG(g.validate("f.nrrd"), InputError, "dimension 1");
  g.dims = {2, 2, 2};
  g.direction = {{{1, 0.5, 0}, {0, 1, 0}, {0, 0, 1}}};
  EXPECT_THROW_MSG(g.validate("f.nrrd"), InputError, "orthonormal");
}

TEST(LabelCounts, CountsEveryLabelIncludingGapsAndNegatives) {
  LabelVolume v;
  GridGeometry g;
  g.dims = {37, 11, 13};
  v.allocate(g, 0);
  std::mt19937 rng(7);
  const int32_t labels[] = {0, 84, 85, 127, 255, -3};
  std::map<int32_t, int64_t> expected;
  for (auto& x : v.data) {
    x = labels[rng() % 6];
    ++expected[x];
  }
  EXPECT_EQ(labelCounts(v), expected);
}

TEST(RequireFinite, NamesTheFirstBadVoxel) {
  ScalarVolume v;
  GridGeometry g;
  g.dims = {3, 4, 5};
  v.allocate(g, 1.0f);
  EXPECT_NO_THROW(requireFinite(v, "s.nrrd"));
  v.at(2, 1, 3) = std::numeric_limits<float>::infinity();
  v.at(1, 3, 4) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW_MSG(requireFinite(v, "s.nrrd"), InputError, "s.nrrd", "(2, 1, 3)", "NaN");
}

TEST(TetMesh, ValidateStructureCatchesInconsistencies) {
  TetMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.tets = {{0, 1, 2, 3}};
  m.materials = {5};
  EXPECT_NO_THROW(m.validateStructure("m"));
  EXPECT_NEAR(m.tetVolume(0), 1.0 / 6.0, 1e-15);
  m.tets[0][3] = 4;
  EXPECT_THROW_MSG(m.validateStructure("m.vtu"), InputError, "m.vtu", "tet 0", "vertex 4");
  m.tets[0][3] = 3;
  m.materials.clear();
  EXPECT_THROW_MSG(m.validateStructure("m"), InputError, "material");
  m.materials = {5};
  m.cellFields["q"] = Field{2, {1.0}};
  EXPECT_THROW_MSG(m.validateStructure("m"), InputError, "'q'");
}

TEST(Progress, RecordsStagesAndCancels) {
  NullProgress p;
  p.beginStage("sample");
  p.report(0.5);
  p.beginStage("stencil");
  p.endStage();
  ASSERT_EQ(p.stageTimes().size(), 2u);
  EXPECT_EQ(p.stageTimes()[0].name, "sample");
  EXPECT_GE(p.stageTimes()[1].seconds, 0.0);
  EXPECT_NO_THROW(p.checkCancel());
  p.requestCancel();
  EXPECT_THROW(p.checkCancel(), Cancelled);
}
