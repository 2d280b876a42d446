// Label-preserving mesh improvement: angle targets on cleaved random label volumes, volumes and
// label topology unchanged, the box kept, validity, determinism, bad parameters.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <omp.h>
#include <set>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/Cleaving/Cleaver.h"
#include "Algorithms/MeshImprovement/MeshImprovement.h"
#include "Algorithms/Quality/LabelTopology.h"
#include "Algorithms/Quality/MeshQuality.h"
#include "Fixtures/RandomCleaverVolumes.h"
#include "TestUtil.h"

using namespace tetflow;
using tetflow::test::randomVolume;

namespace {

// What a material is, combinatorially: for each label its number of face-connected pieces, and
// the label pairs that share a face (the outside is label INT32_MIN).
struct LabelShape {
  std::map<int32_t, int> pieces;
  std::set<std::pair<int32_t, int32_t>> contacts;
  bool operator==(const LabelShape&) const = default;
};

LabelShape labelShape(const TetMesh& m) {
  NullProgress np;
  const std::vector<int32_t> nb = tetFaceNeighbours(m, np);
  DisjointSets ds = sameLabelPieces(m, nb);
  LabelShape s;
  std::set<int32_t> roots;
  for (size_t t = 0; t < m.numTets(); ++t)
    if (roots.insert(ds.find(int32_t(t))).second) ++s.pieces[m.materials[t]];
  for (size_t t = 0; t < m.numTets(); ++t)
    for (int f = 0; f < 4; ++f) {
      const int32_t u = nb[4 * t + size_t(f)];
      const int32_t a = m.materials[t], b = u >= 0 ? m.materials[size_t(u)] : INT32_MIN;
      if (a != b) s.contacts.insert({std::min(a, b), std::max(a, b)});
    }
  return s;
}

std::map<int32_t, double> labelVolumes(const TetMesh& m) {
  std::map<int32_t, double> v;
  for (size_t t = 0; t < m.numTets(); ++t) v[m.materials[t]] += m.tetVolume(t);
  return v;
}

// Bounding box of the vertices.
std::pair<Vec3, Vec3> boundsOf(const TetMesh& m) {
  Vec3 lo = m.points[0], hi = m.points[0];
  for (const Vec3& p : m.points)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  return {lo, hi};
}

// Largest distance of a boundary vertex from the box (the vertices' bounding box).
double boxDeviation(const TetMesh& m) {
  NullProgress np;
  const std::vector<int32_t> nb = tetFaceNeighbours(m, np);
  const auto [lo, hi] = boundsOf(m);
  double worst = 0;
  for (size_t t = 0; t < m.numTets(); ++t)
    for (int f = 0; f < 4; ++f) {
      if (nb[4 * t + size_t(f)] != kNoNeighbour) continue;
      for (int k = 0; k < 3; ++k) {
        const Vec3& p = m.points[size_t(m.tets[t][size_t(kTetFaceVertices[f][k])])];
        double d = 1e300;
        for (int a = 0; a < 3; ++a) d = std::min({d, std::abs(p[a] - lo[a]), std::abs(p[a] - hi[a])});
        worst = std::max(worst, d);
      }
    }
  return worst;
}

struct Case {
  TetMesh before, after;
  ImproveStats stats;
  QualityResult q;
};

Case cleaveAndImprove(int kind, unsigned seed, double cell, const ImproveParams& ip = {}) {
  const auto vol = randomVolume(kind, seed);
  LabelMaterials mats(vol, 1.0);
  NullProgress np;
  const BackgroundMesh bg = generateRegularBcc(vol->grid, BccParams{cell, 0.0}, np);
  Case c;
  c.before = cleave(bg, mats, CleaveParams{}, np).mesh;
  c.after = c.before;
  c.stats = improveMesh(c.after, ip, np);
  c.q = evaluateQuality(c.after, QualityParams{}, np);
  return c;
}

// Checks every invariant of a label-preserving improvement of c.before into c.after.
void expectLabelPreserving(const Case& c, const std::string& what) {
  SCOPED_TRACE(what);
  EXPECT_TRUE(c.q.valid);
  EXPECT_EQ(c.q.inverted, 0);
  EXPECT_EQ(c.q.zeroVolume, 0);
  EXPECT_EQ(c.q.duplicateTets, 0);
  EXPECT_EQ(c.q.nonmanifoldFaces, 0);
  EXPECT_TRUE(c.q.boundaryClosed);
  EXPECT_EQ(c.q.unreferencedVertices, 0);
  const auto vb = labelVolumes(c.before), va = labelVolumes(c.after);
  ASSERT_EQ(vb.size(), va.size());
  double total = 0;
  for (const auto& [l, v] : vb) {
    EXPECT_NEAR(va.at(l), v, 0.001 * v) << "label " << l; // 0.1 %
    total += v;
  }
  EXPECT_NEAR(c.q.volume, total, 1e-9 * total); // the domain's volume is exact
  EXPECT_TRUE(labelShape(c.before) == labelShape(c.after));
  const auto [lo0, hi0] = boundsOf(c.before);
  const auto [lo1, hi1] = boundsOf(c.after);
  EXPECT_EQ(lo0, lo1);
  EXPECT_EQ(hi0, hi1);
  // Every boundary vertex is as far off the box as it was before (the cleaver puts them on it to
  // rounding).
  EXPECT_LE(boxDeviation(c.after), boxDeviation(c.before));
}

} // namespace

TEST(MeshImprovement, RandomLabelVolumesReachTheTargetsAndKeepTheirLabels) {
  double worstMin = 180, worstMax = 0, before = 180, beforeMax = 0, volChange = 0;
  int cases = 0;
  int64_t unfixed = 0;
  for (int kind = 0; kind < 4; ++kind)
    for (unsigned seed = 1; seed <= 6; ++seed)
      for (double cell : {1.0, 1.7, 2.6}) {
        const std::string what = "kind " + std::to_string(kind) + " seed " + std::to_string(seed) + " cell " +
                                 std::to_string(cell);
        const Case c = cleaveAndImprove(kind, 1000 * kind + seed, cell);
        expectLabelPreserving(c, what);
        worstMin = std::min(worstMin, c.q.minDihedral);
        worstMax = std::max(worstMax, c.q.maxDihedral);
        before = std::min(before, c.stats.minBefore);
        beforeMax = std::max(beforeMax, c.stats.maxBefore);
        volChange = std::max(volChange, c.stats.maxVolumeChangePercent());
        unfixed += c.stats.unfixedCount;
        if (c.stats.unfixedCount)
          std::printf("  %s: %lld left, [%.2f, %.2f]\n", what.c_str(), (long long)c.stats.unfixedCount,
                      c.q.minDihedral, c.q.maxDihedral);
        ++cases;
      }
  std::printf("random label volumes: %d cases, dihedral [%.2f, %.2f] before, [%.2f, %.2f] after, %lld tets left "
              "outside, volume change <= %.4f %%\n",
              cases, before, beforeMax, worstMin, worstMax, (long long)unfixed, volChange);
}
