// Tests for analyzeLabelImage (Algorithms/Quality/LabelTopology.h), which works on the runs of the
// rows (LabelRuns.h), against a plain voxel-by-voxel computation of the same definitions: BFS
// components numbered in scan order, cores and their 26-connected groups, box contact, places,
// the face contacts with their areas and face centres, and the voxels of coreless components. Random volumes with fixed seeds, with
// long runs (boxes), salt (runs of one voxel), diagonal-only contacts and labels on the box.
#include "Algorithms/Quality/LabelRuns.h"
#include "Algorithms/Quality/LabelTopology.h"

#include <gtest/gtest.h>

#include "Fixtures/VoxelComponents.h"

#include <algorithm>
#include <array>
#include <deque>
#include <map>
#include <random>
#include <set>

namespace tetflow {
namespace {

LabelVolume randomLabelVolume(std::mt19937& rng, bool salt) {
  std::uniform_int_distribution<int> dim(1, 12), lab(0, 4), coin(0, 99);
  LabelVolume v;
  GridGeometry g;
  g.dims = {dim(rng), dim(rng), dim(rng)};
  g.spacing = {0.5 + 0.25 * (rng() % 4), 1.0, 0.75};
  g.origin = {1.0, -2.0, 0.5};
  v.allocate(g, lab(rng));
  const int boxes = 1 + int(rng() % 8);
  for (int b = 0; b < boxes; ++b) {
    const int32_t L = lab(rng);
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      const int n = int(g.dims[a]);
      lo[a] = int(rng() % n);
      hi[a] = std::min(n - 1, lo[a] + int(rng() % 6));
    }
    for (int k = lo[2]; k <= hi[2]; ++k)
      for (int j = lo[1]; j <= hi[1]; ++j)
        for (int i = lo[0]; i <= hi[0]; ++i) v.at(i, j, k) = L;
  }
  if (salt)
    for (auto& x : v.data)
      if (coin(rng) < 6) x = lab(rng);
  return v;
}

struct ExpectedTopology {
  std::vector<int32_t> comp;
  std::vector<ImageComponent> comps;
  std::map<uint64_t, std::pair<double, PlaceAcc>> contacts;
};

ExpectedTopology byVoxels(const LabelVolume& v) {
  const auto& g = v.grid;
  const int nx = int(g.dims[0]), ny = int(g.dims[1]), nz = int(g.dims[2]);
  auto in = [&](int i, int j, int k) { return test::insideVolume(v, i, j, k); };
  auto core = [&](int i, int j, int k) { return test::isCoreVoxel(v, i, j, k); };
  auto bfs = [&](auto member) { return test::voxelComponents(v, member, true); };
  ExpectedTopology e;
  const auto [comp, n] = bfs([](int, int, int) { return true; });
  const auto [cores, nc] = bfs(core);
  e.comp = comp;
  e.comps.resize(size_t(n));
  std::vector<std::set<int32_t>> coreSets(static_cast<size_t>(n));
  const double fa[3] = {g.spacing[1] * g.spacing[2], g.spacing[0] * g.spacing[2], g.spacing[0] * g.spacing[1]};
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const size_t p = size_t(v.index(i, j, k));
        ImageComponent& c = e.comps[size_t(comp[p])];
        c.label = v.data[p];
        ++c.voxels;
        c.where.add(g.indexToPhysical(i, j, k), 1.0);
        c.touchesBox = c.touchesBox || i == 0 || j == 0 || k == 0 || i == nx - 1 || j == ny - 1 || k == nz - 1;
        if (cores[p] >= 0) coreSets[size_t(comp[p])].insert(cores[p]);
        const int nb[3][3] = {{i + 1, j, k}, {i, j + 1, k}, {i, j, k + 1}};
        for (int a = 0; a < 3; ++a) {
          if (!in(nb[a][0], nb[a][1], nb[a][2]) || v.at(nb[a][0], nb[a][1], nb[a][2]) == v.data[p]) continue;
          auto& ct = e.contacts[labelPairKey(v.data[p], v.at(nb[a][0], nb[a][1], nb[a][2]))];
          ct.first += fa[a];
          ct.second.add(g.indexToPhysical(i + (a == 0 ? 0.5 : 0.0), j + (a == 1 ? 0.5 : 0.0), k + (a == 2 ? 0.5 : 0.0)),
                        fa[a]);
        }
      }
  (void)nc;
  for (int32_t c = 0; c < n; ++c) e.comps[size_t(c)].cores = int(coreSets[size_t(c)].size());
  return e;
}

void expectNear(const Vec3& a, const Vec3& b) {
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(a[i], b[i], 1e-9);
}

TEST(LabelTopology, TheRunsGiveWhatAVoxelByVoxelAnalysisGives) {
  std::mt19937 rng(20261126);
  NullProgress np;
  for (int c = 0; c < 120; ++c) {
    SCOPED_TRACE("case " + std::to_string(c));
    const LabelVolume v = randomLabelVolume(rng, c % 3 != 0);
    const LabelImageTopology got = analyzeLabelImage(v, np);
    const ExpectedTopology want = byVoxels(v);
    ASSERT_EQ(got.comp, want.comp);
    ASSERT_EQ(got.comps.size(), want.comps.size());
    for (size_t i = 0; i < want.comps.size(); ++i) {
      const ImageComponent &a = got.comps[i], &b = want.comps[i];
      EXPECT_EQ(a.label, b.label);
      EXPECT_EQ(a.voxels, b.voxels);
      EXPECT_EQ(a.cores, b.cores) << "component " << i;
      EXPECT_EQ(a.touchesBox, b.touchesBox);
      EXPECT_NEAR(a.where.weight, b.where.weight, 1e-9);
      expectNear(a.where.place().centroid, b.where.place().centroid);
      expectNear(a.where.place().boxMin, b.where.place().boxMin);
      expectNear(a.where.place().boxMax, b.where.place().boxMax);
    }
    ASSERT_EQ(got.contacts.size(), want.contacts.size());
    for (const auto& [key, e] : want.contacts) {
      ASSERT_TRUE(got.contacts.count(key));
      const auto& g = got.contacts.at(key);
      EXPECT_NEAR(g.first, e.first, 1e-9);
      expectNear(g.second.place().centroid, e.second.place().centroid);
      expectNear(g.second.place().boxMin, e.second.place().boxMin);
      expectNear(g.second.place().boxMax, e.second.place().boxMax);
    }
    // The coreless voxels alone (corelessVoxels): empty when every component has a core.
    const std::vector<uint8_t> coreless = corelessVoxels(v, np);
    const bool anyCoreless =
        std::any_of(want.comps.begin(), want.comps.end(), [](const ImageComponent& k) { return k.cores == 0; });
    ASSERT_EQ(coreless.empty(), !anyCoreless);
    for (size_t p = 0; p < coreless.size(); ++p)
      ASSERT_EQ(coreless[p] != 0, want.comps[size_t(want.comp[p])].cores == 0) << "voxel " << p;
    // The contact pairs alone (labelContactPairs) are the same pairs.
    std::vector<std::pair<int32_t, int32_t>> pairs;
    for (const auto& [key, e] : want.contacts) pairs.push_back(labelPairOf(key));
    EXPECT_EQ(labelContactPairs(v), pairs);
  }
}

// Runs of one label only, and the joins: two runs that touch only at a corner are one component.
TEST(LabelTopology, RunsOfOneLabelAndCornerJoins) {
  LabelVolume v;
  GridGeometry g;
  g.dims = {4, 2, 2};
  v.allocate(g, 0);
  v.at(0, 0, 0) = 1; // touches (1, 1, 1) at a corner only
  v.at(1, 1, 1) = 1;
  v.at(3, 0, 0) = 1; // apart
  const LabelRows rows = labelRows(v, 1);
  ASSERT_EQ(rows.runs.size(), 3u);
  DisjointSets sets(rows.runs.size());
  NullProgress np;
  joinRuns(rows, sets, np);
  EXPECT_EQ(sets.find(0), sets.find(2)); // rows 0 (0,0,0) and 3 (1,1,1)
  EXPECT_NE(sets.find(0), sets.find(1));
  const LabelRows all = labelRows(v);
  EXPECT_EQ(all.runs.size(), 8u); // rows 1001, 0000, 0000, 0100: every row tiled
  // Cores: the voxels of label 0 whose six neighbours in the volume are 0: (2,1,0), (2,0,1), (3,1,1).
  const LabelRows cores = coreRows(v);
  ASSERT_EQ(cores.runs.size(), 3u);
  EXPECT_EQ(cores.start, (std::vector<int64_t>{0, 0, 1, 2, 3}));
  EXPECT_EQ(cores.runs[2].i0, 3);
}

} // namespace
} // namespace tetflow
