// Tests for TrackedPieces (Algorithms/Quality/TrackedPieces.h): after every round of relabelling,
// its pieces are exactly sameLabelPieces' (every tet at the same root), on random voxel meshes with
// random rounds that move single tets, dissolve whole pieces, cut pieces in two and join them, give
// the tets of a box random labels, move a piece's root out while a tet joins it, with and without
// joins; and most rounds are settled without joining every tet again.
#include "Algorithms/Quality/TrackedPieces.h"

#include <gtest/gtest.h>

#include <random>


#include "Fixtures/VoxelMesh.h"

namespace tetflow {
namespace {

LabelVolume blobs(std::mt19937& rng) {
  LabelVolume v;
  GridGeometry g;
  g.dims = {6 + int64_t(rng() % 7), 6 + int64_t(rng() % 7), 5 + int64_t(rng() % 6)};
  v.allocate(g, 0);
  const int boxes = 2 + int(rng() % 6);
  for (int b = 0; b < boxes; ++b) {
    const int32_t L = int32_t(rng() % 4);
    int64_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = int64_t(rng() % uint64_t(g.dims[a]));
      hi[a] = std::min(g.dims[a] - 1, lo[a] + int64_t(rng() % 5));
    }
    for (int64_t k = lo[2]; k <= hi[2]; ++k)
      for (int64_t j = lo[1]; j <= hi[1]; ++j)
        for (int64_t i = lo[0]; i <= hi[0]; ++i) v.at(i, j, k) = L;
  }
  return v;
}

TEST(TrackedPieces, EveryRoundGivesThePiecesOfJoiningEveryTet) {
  int64_t rounds = 0, whole = 0, cut = 0;
  for (unsigned seed = 1; seed <= 60; ++seed) {
    std::mt19937 rng(seed);
    const LabelVolume v = blobs(rng);
    TetMesh mesh = test::voxelMesh(v);
    NullProgress np;
    const std::vector<int32_t> nb = tetFaceNeighbours(mesh, np);
    const int32_t n = int32_t(mesh.numTets());
    TetJoins joins;
    if (seed % 3 == 0)
      for (int j = 0; j < 6; ++j) joins.push_back({int32_t(rng() % uint32_t(n)), int32_t(rng() % uint32_t(n))});
    TrackedPieces tracked(mesh, nb, seed % 3 == 0 ? &joins : nullptr);
    for (int round = 0; round < 12; ++round) {
      const int kind = int(rng() % 6);
      if (kind == 0) { // a few single tets
        for (int k = 0, m = 1 + int(rng() % 5); k < m; ++k) mesh.materials[rng() % uint32_t(n)] = int32_t(rng() % 4);
      } else if (kind == 1) { // a whole piece dissolves into another label
        const DisjointSets s = sameLabelPieces(mesh, nb, seed % 3 == 0 ? &joins : nullptr);
        const int32_t r = s.parent[rng() % uint32_t(n)];
        const int32_t L = (mesh.materials[size_t(r)] + 1 + int32_t(rng() % 3)) % 4;
        for (int32_t t = 0; t < n; ++t)
          if (s.parent[size_t(t)] == r) mesh.materials[size_t(t)] = L;
      } else if (kind == 2) { // a voxel slab: cuts pieces, or joins them
        const int axis = int(rng() % 3);
        const int64_t at = int64_t(rng() % uint64_t(v.grid.dims[axis]));
        const int32_t L = int32_t(rng() % 4);
        for (int64_t k = 0; k < v.grid.dims[2]; ++k)
          for (int64_t j = 0; j < v.grid.dims[1]; ++j)
            for (int64_t i = 0; i < v.grid.dims[0]; ++i)
              if ((axis == 0 ? i : axis == 1 ? j : k) == at && rng() % 4 != 0) test::relabelVoxel(v, mesh, i, j, k, L);
      } else if (kind == 3) { // a box of voxels whose tets each take a random label
        int64_t lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
          lo[a] = int64_t(rng() % uint64_t(v.grid.dims[a]));
          hi[a] = std::min(v.grid.dims[a] - 1, lo[a] + int64_t(rng() % 3));
        }
        for (int64_t k = lo[2]; k <= hi[2]; ++k)
          for (int64_t j = lo[1]; j <= hi[1]; ++j)
            for (int64_t i = lo[0]; i <= hi[0]; ++i)
              for (size_t t = test::firstTet(v, i, j, k); t < test::firstTet(v, i, j, k) + 6; ++t)
                mesh.materials[t] = int32_t(rng() % 4);
      } else if (kind == 4) { // a piece's root (its smallest tet) leaves it while a tet next to it joins
        const DisjointSets s = sameLabelPieces(mesh, nb, seed % 3 == 0 ? &joins : nullptr);
        const int32_t r = s.parent[rng() % uint32_t(n)], M = mesh.materials[size_t(r)];
        std::vector<int32_t> next;
        for (int32_t t = 0; t < n; ++t)
          if (s.parent[size_t(t)] == r)
            for (int f = 0; f < 4; ++f)
              if (const int32_t o = nb[4 * size_t(t) + size_t(f)]; o >= 0 && mesh.materials[size_t(o)] != M) next.push_back(o);
        mesh.materials[size_t(r)] = (M + 1 + int32_t(rng() % 3)) % 4;
        if (!next.empty()) mesh.materials[size_t(next[rng() % next.size()])] = M;
      } // kind 5: nothing changes
      const DisjointSets got = tracked.now();
      const DisjointSets want = sameLabelPieces(mesh, nb, seed % 3 == 0 ? &joins : nullptr);
      ASSERT_EQ(got.parent, want.parent) << "seed " << seed << ", round " << round << ", kind " << kind;
      ++rounds;
    }
    whole += tracked.wholeRounds();
    cut += tracked.partsCutOff();
  }
  // Not every round joined every tet again (the first of each mesh does; cuts may), and parts that
  // came off were found without it.
  EXPECT_LT(whole, rounds / 2) << whole << " of " << rounds;
  EXPECT_GT(cut, 10);
}

} // namespace
} // namespace tetflow
