#include <gtest/gtest.h>

#include <cmath>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Phantom.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {
double relErr(double a, double b) { return std::abs(a - b) / b; }
} // namespace

TEST(Phantom, HeadLayersHaveTheirAnalyticVolumes) {
  PhantomParams p;
  p.kind = PhantomKind::Head;
  p.voxel_size = 2.0;
  const Phantom ph = makePhantom(p);
  const auto counts = labelCounts(ph.volume);
  const auto exact = ph.analyticVolumes();
  ASSERT_EQ(counts.size(), 5u); // background + 4 layers
  for (const auto& [label, vol] : exact) {
    const double voxVol = counts.at(label) * ph.volume.grid.voxelVolume();
    // Thin layers (6 mm at 2 mm voxels) converge slowest; the brain is within 1 %.
    EXPECT_LT(relErr(voxVol, vol), label == 4 ? 0.01 : 0.1) << "label " << label;
  }
}

TEST(Phantom, VolumeErrorShrinksWithVoxelSize) {
  for (PhantomKind kind : {PhantomKind::Sphere, PhantomKind::TwoSpheres, PhantomKind::Shell}) {
    // Centre sampling converges at first order on average but not monotonically step by step
    // (the surface crosses voxel centres irregularly): compare the coarsest and finest grids.
    double coarse = -1, fine = 0;
    for (double h : {4.0, 2.0, 1.0}) {
      PhantomParams p;
      p.kind = kind;
      p.radius = 30.0;
      p.shell_thickness = 8.0;
      p.voxel_size = h;
      const Phantom ph = makePhantom(p);
      const auto counts = labelCounts(ph.volume);
      double err = 0;
      for (const auto& [label, vol] : ph.analyticVolumes())
        err = std::max(err, relErr(counts.at(label) * ph.volume.grid.voxelVolume(), vol));
      if (coarse < 0) coarse = err;
      fine = err;
    }
    EXPECT_LT(fine, coarse) << phantomKindName(kind);
    EXPECT_LT(fine, 0.01) << phantomKindName(kind);
  }
}

TEST(Phantom, VoxelsMatchAnalyticLabelAtCentres) {
  for (PhantomKind kind : {PhantomKind::Head, PhantomKind::Sphere, PhantomKind::TwoSpheres,
                           PhantomKind::Shell, PhantomKind::Blob}) {
    PhantomParams p;
    p.kind = kind;
    p.radius = 20;
    p.skull_radius = 18;
    p.csf_radius = 15;
    p.brain_radius = 12;
    p.voxel_size = 1.5;
    const Phantom ph = makePhantom(p);
    const auto& g = ph.volume.grid;
    for (int64_t k = 0; k < g.dims[2]; k += 3)
      for (int64_t j = 0; j < g.dims[1]; j += 2)
        for (int64_t i = 0; i < g.dims[0]; ++i)
          ASSERT_EQ(ph.volume.at(i, j, k), ph.labelAt(g.indexToPhysical(i, j, k)))
              << phantomKindName(kind) << " at " << i << "," << j << "," << k;
  }
}

TEST(Phantom, GridIsCentredAndCoversTheShapes) {
  PhantomParams p;
  p.kind = PhantomKind::Sphere;
  p.radius = 10;
  p.voxel_size = 1.0;
  p.margin = 2;
  const Phantom ph = makePhantom(p);
  const auto& g = ph.volume.grid;
  EXPECT_EQ(g.dims[0], 25); // ceil(2*(10+2)/1) + 1
  const Vec3 first = g.indexToPhysical(0, 0, 0);
  const Vec3 last = g.indexToPhysical(g.dims[0] - 1, g.dims[1] - 1, g.dims[2] - 1);
  for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(first[a], -last[a]);
  // Border voxels are background.
  for (int64_t j = 0; j < g.dims[1]; ++j)
    for (int64_t i = 0; i < g.dims[0]; ++i) EXPECT_EQ(ph.volume.at(i, j, 0), 0);
}

namespace {
int64_t g0(const Phantom& ph) { return ph.volume.grid.dims[0] / 2; }
int64_t g1(const Phantom& ph) { return ph.volume.grid.dims[1] / 2; }
} // namespace

TEST(Phantom, TwoSpheresTouchAtTheOrigin) {
  PhantomParams p;
  p.kind = PhantomKind::TwoSpheres;
  p.radius = 10;
  p.voxel_size = 1.0;
  const Phantom ph = makePhantom(p);
  EXPECT_EQ(ph.labelAt({-0.1, 0, 0}), 1);
  EXPECT_EQ(ph.labelAt({0.1, 0, 0}), 2);
  EXPECT_EQ(ph.labelAt({0, 0.5, 0}), 0);
  const auto c = labelCounts(ph.volume);
  // Mirror-symmetric grid; the single voxel at the touching point goes to label 2 (painted last).
  EXPECT_EQ(c.at(1) + 1, c.at(2));
  EXPECT_EQ(ph.volume.at(g0(ph), g1(ph), g1(ph)), 2);
}

TEST(Phantom, BlobIsSevenIsolatedVoxels) {
  PhantomParams p;
  p.kind = PhantomKind::Blob;
  p.radius = 10;
  p.voxel_size = 1.0;
  const Phantom ph = makePhantom(p);
  const auto c = labelCounts(ph.volume);
  ASSERT_EQ(c.count(2), 1u);
  EXPECT_EQ(c.at(2), 7);
  EXPECT_DOUBLE_EQ(ph.analyticVolumes().at(2), 7.0);
  // Isolated: no blob voxel touches label 1 (26-neighbourhood).
  const auto& g = ph.volume.grid;
  for (int64_t k = 1; k + 1 < g.dims[2]; ++k)
    for (int64_t j = 1; j + 1 < g.dims[1]; ++j)
      for (int64_t i = 1; i + 1 < g.dims[0]; ++i) {
        if (ph.volume.at(i, j, k) != 2) continue;
        for (int dk = -1; dk <= 1; ++dk)
          for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di) EXPECT_NE(ph.volume.at(i + di, j + dj, k + dk), 1);
      }
}

TEST(Phantom, BadParametersNameTheParameter) {
  PhantomParams p;
  p.voxel_size = 0;
  EXPECT_THROW_MSG(makePhantom(p), InputError, "voxel_size", "positive");
  p = PhantomParams{};
  p.skull_radius = 100;
  EXPECT_THROW_MSG(makePhantom(p), InputError, "skull_radius");
  p = PhantomParams{};
  p.voxel_size = 0.01;
  EXPECT_THROW_MSG(makePhantom(p), InputError, "4096");
  EXPECT_THROW_MSG(phantomKindFromName("cube"), InputError, "cube", "two_spheres");
  EXPECT_EQ(phantomKindFromName("shell"), PhantomKind::Shell);
}
