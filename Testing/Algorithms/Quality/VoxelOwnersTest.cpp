// Tests for VoxelOwners (Algorithms/Quality/VoxelOwners.h): on random meshes against grids whose
// voxel centres fall on their vertices, edges and faces (held by several tets) or between them,
// with jittered points, inverted and overlapping tets, the weighted calls of the constructor sum
// to one call per held voxel with its owner (the smallest tet that holds it, by the definition's
// test applied to every voxel and every tet), and forEachOwned visits exactly those pairs.
#include "Algorithms/Quality/VoxelOwners.h"

#include <gtest/gtest.h>

#include <random>

#include "Algorithms/Quality/LabelTopology.h"
#include "Fixtures/VoxelMesh.h"

namespace tetflow {
namespace {

// The definition, voxel by voxel: the smallest tet whose four volumes with the voxel centre in a
// vertex's place are, signed like its own, at least -1e-9 of its volume; -1 when none.
std::vector<int32_t> ownersByDefinition(const TetMesh& m, const GridGeometry& g) {
  const IndexFrame frame{g};
  std::vector<int32_t> owner(size_t(g.voxelCount()), -1);
  for (size_t t = 0; t < m.numTets(); ++t) {
    Vec3 P[4];
    for (int c = 0; c < 4; ++c) P[c] = frame.toIndex(m.points[size_t(m.tets[t][c])]);
    const double vol = signedTetVolume(P[0], P[1], P[2], P[3]);
    if (vol == 0.0) continue;
    const double tol = -1e-9 * std::abs(vol), s = vol > 0 ? 1.0 : -1.0;
    for (int64_t k = 0; k < g.dims[2]; ++k)
      for (int64_t j = 0; j < g.dims[1]; ++j)
        for (int64_t i = 0; i < g.dims[0]; ++i) {
          const Vec3 x{double(i), double(j), double(k)};
          if (s * signedTetVolume(x, P[1], P[2], P[3]) < tol || s * signedTetVolume(P[0], x, P[2], P[3]) < tol ||
              s * signedTetVolume(P[0], P[1], x, P[3]) < tol || s * signedTetVolume(P[0], P[1], P[2], x) < tol)
            continue;
          int32_t& o = owner[size_t(i + g.dims[0] * (j + g.dims[1] * k))];
          if (o < 0) o = int32_t(t);
        }
  }
  return owner;
}

TEST(VoxelOwners, EveryHeldVoxelCountsOnceWithTheSmallestTetThatHoldsIt) {
  int64_t shared = 0, held = 0, cases = 0;
  for (unsigned seed = 1; seed <= 40; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    LabelVolume v;
    GridGeometry mg;
    mg.dims = {2 + int64_t(rng() % 4), 2 + int64_t(rng() % 4), 2 + int64_t(rng() % 3)};
    mg.spacing = {1.0 + 0.5 * double(rng() % 3), 1.0, 1.0 + 0.5 * double(rng() % 2)};
    v.allocate(mg, 1);
    TetMesh m = test::voxelMesh(v);
    const int kind = int(seed % 4);
    if (kind == 1) // points moved off the lattice
      for (auto& p : m.points) p = p + Vec3{0.2 * u(rng), 0.2 * u(rng), 0.2 * u(rng)};
    if (kind == 2) { // overlapping and inverted copies of some tets
      for (int c = 0, n = int(m.numTets()); c < 5; ++c) {
        TetMesh::Tet q = m.tets[rng() % uint32_t(n)];
        if (rng() % 2) std::swap(q[0], q[1]);
        m.tets.push_back(q);
        m.materials.push_back(2);
      }
    }
    if (kind == 3) { // a flat tet (holds nothing) and a long one across the others
      m.tets.push_back({m.tets[0][0], m.tets[0][1], m.tets[0][1], m.tets[0][2]});
      m.materials.push_back(3);
      m.points.push_back(m.points.front() + Vec3{-3.0, -2.0, -1.0});
      m.tets.push_back({int32_t(m.numPoints() - 1), m.tets[5][1], m.tets[7][2], m.tets.back()[3]});
      m.materials.push_back(3);
    }
    // A finer grid over the mesh: its voxel centres on the mesh's vertices, edges and faces
    // (kind 0 with unit steps) or off them (shifted origins, rotated axes).
    GridGeometry g;
    const double step = 0.25 * double(1 + rng() % 2);
    for (int a = 0; a < 3; ++a)
      g.dims[a] = int64_t(std::ceil(double(mg.dims[a]) * mg.spacing[a] / step)) + 3 + int64_t(rng() % 3);
    g.spacing = {step, step, step * (rng() % 3 == 0 ? 1.5 : 1.0)};
    g.origin = mg.indexToPhysical(-0.5, -0.5, -0.5) - Vec3{step, step, step};
    if (seed % 5 == 0) g.origin = g.origin + Vec3{0.37 * step * u(rng), 0.11 * step, 0.0};
    if (seed % 7 == 0) { // axes turned about z
      const double c = std::cos(0.3), s = std::sin(0.3);
      g.direction = Mat3{{{c, -s, 0.0}, {s, c, 0.0}, {0.0, 0.0, 1.0}}};
    }
    const std::vector<int32_t> want = ownersByDefinition(m, g);

    // Per thread: two tets that hold one voxel may be scanned on different threads.
    const size_t threads = size_t(omp_get_max_threads());
    std::vector<std::vector<int64_t>> counts(threads, std::vector<int64_t>(want.size(), 0)), sums = counts;
    NullProgress np;
    const VoxelOwners owners(m, g, np, [&](int me, int64_t vox, int32_t t, int w) {
      counts[size_t(me)][size_t(vox)] += w;
      sums[size_t(me)][size_t(vox)] += int64_t(w) * t;
    });
    std::vector<int64_t> count(want.size(), 0), tetSum(want.size(), 0);
    for (size_t th = 0; th < threads; ++th)
      for (size_t x = 0; x < want.size(); ++x) {
        count[x] += counts[th][x];
        tetSum[x] += sums[th][x];
      }
    std::vector<int32_t> visited(want.size(), -1);
    int64_t visits = 0;
    owners.forEachOwned([&](int, int64_t vox, int32_t t) {
#pragma omp critical
      {
        ++visits;
        EXPECT_EQ(visited[size_t(vox)], -1) << "seed " << seed << ": voxel " << vox << " visited twice";
        visited[size_t(vox)] = t;
      }
    });
    int64_t heldHere = 0;
    for (size_t x = 0; x < want.size(); ++x) {
      ASSERT_EQ(count[x], want[x] >= 0 ? 1 : 0) << "seed " << seed << " voxel " << x;
      if (want[x] >= 0) {
        ++heldHere;
        ASSERT_EQ(tetSum[x], want[x]) << "seed " << seed << " voxel " << x;
      }
      ASSERT_EQ(visited[x], want[x]) << "seed " << seed << " voxel " << x;
    }
    EXPECT_EQ(visits, heldHere);
    held += heldHere;
    shared += owners.sharedVoxels();
    ++cases;
  }
  // The cases reach what they are meant to: many voxels held, and several hundred of them by more
  // than one tet.
  EXPECT_GT(held, 20000);
  EXPECT_GT(shared, 500);
}

} // namespace
} // namespace tetflow
