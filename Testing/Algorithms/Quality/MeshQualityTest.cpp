// Tests for Algorithms/Quality/MeshQuality: cubes split into 5 and 6 tets, validity counters on
// hand-built meshes, the face analysis against a brute-force reference on random tet soups (both
// key widths), histogram / threshold / median consistency, per-material volumes with references,
// the report layout, and bad input.
#include "Algorithms/Quality/MeshQuality.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <random>
#include <set>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Quality/TetQuality.h"
#include "Fixtures/MeshChecks.h"
#include "TestUtil.h"

namespace tetflow {
namespace {

constexpr double kTol = 1e-12;

using test::orientPositive;

// Unit cube corners, index i + 2j + 4k for corner (i,j,k).
std::vector<Vec3> cubeCorners(double h = 1.0, Vec3 o = {0, 0, 0}) {
  std::vector<Vec3> p;
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) p.push_back(o + Vec3{i * h, j * h, k * h});
  return p;
}

// 4 corner tets (material 1) around the central regular tet 0-3-5-6 (material 2).
TetMesh cubeFive() {
  TetMesh m;
  m.points = cubeCorners();
  m.tets = {{1, 0, 3, 5}, {2, 0, 3, 6}, {4, 0, 5, 6}, {7, 3, 5, 6}, {0, 3, 5, 6}};
  m.materials = {1, 1, 1, 1, 2};
  orientPositive(m);
  return m;
}

// The 6 Kuhn tets around the diagonal 0-7 (one per axis order).
TetMesh cubeSix() {
  TetMesh m;
  m.points = cubeCorners();
  const int axis[3] = {1, 2, 4};
  int perm[3] = {0, 1, 2};
  do {
    const int a = axis[perm[0]], b = a + axis[perm[1]];
    m.tets.push_back({0, a, b, 7});
  } while (std::next_permutation(perm, perm + 3));
  m.materials.assign(m.tets.size(), 3);
  orientPositive(m);
  return m;
}

// nx*ny*nz cubes of edge h, 6 Kuhn tets each, interior vertices moved by up to perturb*h per
// axis (perturb <= 0.2 keeps every tet positive: the shortest Kuhn altitude is h/sqrt 2).
TetMesh kuhnCubes(int nx, int ny, int nz, double h, double perturb, unsigned seed) {
  TetMesh m;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-perturb * h, perturb * h);
  auto vid = [&](int i, int j, int k) { return i + (nx + 1) * (j + (ny + 1) * k); };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        Vec3 p{i * h, j * h, k * h};
        if (i > 0 && j > 0 && k > 0 && i < nx && j < ny && k < nz) p = p + Vec3{u(rng), u(rng), u(rng)};
        m.points.push_back(p);
      }
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const int c[8] = {vid(i, j, k),         vid(i + 1, j, k),         vid(i, j + 1, k),
                          vid(i + 1, j + 1, k), vid(i, j, k + 1),         vid(i + 1, j, k + 1),
                          vid(i, j + 1, k + 1), vid(i + 1, j + 1, k + 1)};
        const int axis[3] = {1, 2, 4};
        int perm[3] = {0, 1, 2};
        do {
          const int a = axis[perm[0]], b = a + axis[perm[1]];
          m.tets.push_back({c[0], c[a], c[b], c[7]});
          m.materials.push_back(i < nx / 2 ? 1 : 2);
        } while (std::next_permutation(perm, perm + 3));
      }
  orientPositive(m);
  return m;
}

QualityResult evaluate(const TetMesh& m, QualityParams p = {}) {
  NullProgress progress;
  return evaluateQuality(m, p, progress);
}

void expectCleanCube(const QualityResult& r, int64_t tets, int64_t interior) {
  EXPECT_EQ(r.tets, tets);
  EXPECT_EQ(r.vertices, 8);
  EXPECT_NEAR(r.volume, 1.0, kTol);
  EXPECT_TRUE(r.valid);
  EXPECT_TRUE(r.boundaryClosed);
  EXPECT_EQ(r.inverted, 0);
  EXPECT_EQ(r.zeroVolume, 0);
  EXPECT_EQ(r.duplicateTets, 0);
  EXPECT_EQ(r.nonmanifoldFaces, 0);
  EXPECT_EQ(r.foldedFaces, 0);
  EXPECT_EQ(r.boundaryFaces, 12); // 6 cube faces, 2 triangles each
  EXPECT_EQ(r.interiorFaces, interior);
  EXPECT_EQ(r.boundaryEdges, 18); // 12 cube edges + 6 face diagonals
  EXPECT_EQ(r.openBoundaryEdges, 0);
  EXPECT_EQ(r.nonmanifoldBoundaryEdges, 0);
  EXPECT_EQ(r.unreferencedVertices, 0);
  int64_t sum = 0;
  for (int64_t c : r.histogram) sum += c;
  EXPECT_EQ(sum, tets);
}

TEST(MeshQuality, CubeSplitIntoFiveTets) {
  const auto r = evaluate(cubeFive());
  expectCleanCube(r, 5, 4);
  const double corner = std::acos(1.0 / std::sqrt(3.0)) * 180.0 / std::numbers::pi;
  const double regular = std::acos(1.0 / 3.0) * 180.0 / std::numbers::pi;
  EXPECT_NEAR(r.minDihedral, corner, 1e-9);
  EXPECT_NEAR(r.maxDihedral, 90.0, 1e-9);
  EXPECT_EQ(r.histogram.size(), 36u);
  EXPECT_EQ(r.histogram[10], 4); // 54.7 in [50, 55)
  EXPECT_EQ(r.histogram[14], 1); // 70.5 in [70, 75)
  EXPECT_EQ(r.tetsBelow, (std::array<int64_t, 3>{0, 0, 0}));
  EXPECT_NEAR(r.aspectRatioMin, 1.0 / std::sqrt(6.0), 1e-12);
  EXPECT_NEAR(r.aspectRatioMedian, 1.0 / std::sqrt(6.0), 1e-12);
  EXPECT_NEAR(r.radiusRatioMin, std::sqrt(3.0) - 1.0, 1e-12);
  EXPECT_NEAR(r.radiusRatioMedian, std::sqrt(3.0) - 1.0, 1e-12);
  ASSERT_EQ(r.materials.size(), 2u);
  EXPECT_EQ(r.materials.at(1).tets, 4);
  EXPECT_NEAR(r.materials.at(1).volume, 2.0 / 3.0, kTol);
  EXPECT_EQ(r.materials.at(2).tets, 1);
  EXPECT_NEAR(r.materials.at(2).volume, 1.0 / 3.0, kTol);
  EXPECT_FALSE(r.materials.at(1).hasReference);
  // Per-tet fields match the per-element functions.
  const TetMesh m = cubeFive();
  for (const char* f : {"min_dihedral", "max_dihedral", "aspect_ratio", "radius_ratio", "volume"}) {
    ASSERT_TRUE(r.cellFields.count(f)) << f;
    EXPECT_EQ(r.cellFields.at(f).components, 1);
    EXPECT_EQ(r.cellFields.at(f).values.size(), 5u);
  }
  EXPECT_NEAR(r.cellFields.at("min_dihedral").values[4], regular, 1e-9);
  EXPECT_NEAR(r.cellFields.at("radius_ratio").values[4], 1.0, 1e-12);
  EXPECT_NEAR(r.cellFields.at("volume").values[0], 1.0 / 6.0, kTol);
}

TEST(MeshQuality, CubeSplitIntoSixTets) {
  const auto r = evaluate(cubeSix());
  expectCleanCube(r, 6, 6);
  // Kuhn tets: dihedral angles between 45 and 90.
  EXPECT_NEAR(r.minDihedral, 45.0, 1e-9);
  EXPECT_NEAR(r.maxDihedral, 90.0, 1e-9);
  EXPECT_EQ(r.histogram[9], 6); // [45, 50)
  for (double v : r.cellFields.at("volume").values) EXPECT_NEAR(v, 1.0 / 6.0, kTol);
  EXPECT_EQ(r.materials.size(), 1u);
  EXPECT_EQ(r.materials.at(3).tets, 6);
}

TEST(MeshQuality, InvertedTetIsCountedAndFoldsItsFaces) {
  TetMesh m = cubeFive();
  std::swap(m.tets[4][0], m.tets[4][1]); // the central tet
  const auto r = evaluate(m);
  EXPECT_EQ(r.inverted, 1);
  EXPECT_EQ(r.zeroVolume, 0);
  EXPECT_FALSE(r.valid);
  EXPECT_EQ(r.foldedFaces, 4); // every face of the central tet is seen from the same side twice
  EXPECT_EQ(r.nonmanifoldFaces, 0);
  EXPECT_TRUE(r.boundaryClosed);
  EXPECT_NEAR(r.volume, 2.0 / 3.0 - 1.0 / 3.0, kTol); // signed sum
  EXPECT_NEAR(r.cellFields.at("volume").values[4], -1.0 / 3.0, kTol);
  // Shape metrics do not depend on orientation.
  EXPECT_NEAR(r.cellFields.at("radius_ratio").values[4], 1.0, 1e-12);
}

TEST(MeshQuality, DuplicatedTetIsCounted) {
  TetMesh m = cubeFive();
  const auto t = m.tets[0];
  m.tets.push_back({t[1], t[2], t[0], t[3]}); // same vertex set, other (even) order
  m.materials.push_back(1);
  const auto r = evaluate(m);
  EXPECT_EQ(r.duplicateTets, 1);
  EXPECT_EQ(r.inverted, 0);
  EXPECT_FALSE(r.valid);
  EXPECT_EQ(r.nonmanifoldFaces, 1); // the face shared with the central tet now has 3 tets
  EXPECT_EQ(r.boundaryFaces, 9);    // the corner's 3 outer faces are now in 2 tets each
  EXPECT_EQ(r.foldedFaces, 3);      // ... both on the same side
}

TEST(MeshQuality, FaceSharedByThreeTets) {
  TetMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.2, 0.2, 1}, {0.3, 0.3, -1}, {0.4, 0.1, 2}};
  m.tets = {{0, 1, 2, 3}, {0, 2, 1, 4}, {0, 1, 2, 5}};
  m.materials = {1, 1, 1};
  orientPositive(m);
  const auto r = evaluate(m);
  EXPECT_EQ(r.nonmanifoldFaces, 1);
  EXPECT_EQ(r.interiorFaces, 0);
  EXPECT_EQ(r.boundaryFaces, 9);
  EXPECT_EQ(r.duplicateTets, 0);
  EXPECT_EQ(r.inverted, 0);
  EXPECT_FALSE(r.valid);
  // Each edge of the shared triangle lies in 3 boundary faces: the boundary is not closed.
  EXPECT_EQ(r.nonmanifoldBoundaryEdges, 3);
  EXPECT_FALSE(r.boundaryClosed);
}

TEST(MeshQuality, ZeroVolumeTetIsCountedNotInverted) {
  TetMesh m = cubeSix();
  m.points.push_back({0.7, 0.3, 0.0}); // on the cube's bottom face, inside triangle 0-1-3
  m.tets.push_back({0, 1, 3, 8});
  m.materials.push_back(3);
  const auto r = evaluate(m);
  EXPECT_EQ(r.zeroVolume, 1);
  EXPECT_EQ(r.inverted, 0);
  EXPECT_FALSE(r.valid);
  EXPECT_EQ(r.minDihedral, 0.0);
  EXPECT_EQ(r.maxDihedral, 180.0);
  EXPECT_EQ(r.aspectRatioMin, 0.0);
  EXPECT_EQ(r.radiusRatioMin, 0.0);
  EXPECT_EQ(r.histogram[0], 1);
  EXPECT_EQ(r.tetsBelow[0], 1);
  EXPECT_NEAR(r.volume, 1.0, kTol);
  for (const auto& [name, f] : r.cellFields)
    for (double v : f.values) EXPECT_FALSE(std::isnan(v)) << name;
}

TEST(MeshQuality, RepeatedVertexTetIsZeroVolumeAndLeftOutOfFaces) {
  TetMesh m = cubeSix();
  m.tets.push_back({0, 1, 1, 7});
  m.materials.push_back(3);
  const auto r = evaluate(m);
  EXPECT_EQ(r.repeatedVertexTets, 1);
  EXPECT_EQ(r.zeroVolume, 1);
  EXPECT_EQ(r.boundaryFaces, 12);
  EXPECT_EQ(r.interiorFaces, 6);
  EXPECT_FALSE(r.valid);
}

TEST(MeshQuality, OpenBoundaryAcrossAnEdge) {
  // Two tets sharing only an edge: valid by DESIGN §6 (every face in one tet) but the boundary
  // surface is not closed (the shared edge is in 4 boundary faces).
  TetMesh m;
  m.points = {{0, 0, 0}, {0, 0, 1}, {1, 0, 0.5}, {1, 1, 0.5}, {-1, 0, 0.5}, {-1, -1, 0.5}, {7, 7, 7}};
  m.tets = {{0, 1, 2, 3}, {0, 1, 4, 5}};
  m.materials = {1, 1};
  orientPositive(m);
  const auto r = evaluate(m);
  EXPECT_TRUE(r.valid);
  EXPECT_EQ(r.boundaryFaces, 8);
  EXPECT_FALSE(r.boundaryClosed);
  EXPECT_EQ(r.nonmanifoldBoundaryEdges, 1);
  EXPECT_EQ(r.openBoundaryEdges, 0);
  EXPECT_EQ(r.boundaryEdges, 11);
  EXPECT_EQ(r.unreferencedVertices, 1); // vertex 6
}

TEST(MeshQuality, OpenBoundaryEdgeInOneBoundaryFace) {
  // Three tets on triangle 0-1-2 plus a tet gluing two of them along 0-1-3 and 0-1-5: edge 0-1 is
  // then in a single boundary face (0-1-4).
  TetMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.2, 0.2, 1}, {0.3, 0.3, -1}, {0.4, 0.1, 2}};
  m.tets = {{0, 1, 2, 3}, {0, 2, 1, 4}, {0, 1, 2, 5}, {0, 1, 3, 5}};
  m.materials = {1, 1, 1, 1};
  orientPositive(m);
  const auto r = evaluate(m);
  EXPECT_GE(r.openBoundaryEdges, 1);
  EXPECT_FALSE(r.boundaryClosed);
  EXPECT_FALSE(r.valid);
}

// ---- brute-force reference for the face analysis --------------------------------------------

struct FaceTally {
  int64_t boundary = 0, interior = 0, nonmanifold = 0, folded = 0, duplicates = 0;
  int64_t edges = 0, open = 0, nmEdges = 0, unreferenced = 0;
};

FaceTally brute(const TetMesh& m) {
  FaceTally b;
  std::map<std::array<int32_t, 3>, std::vector<int>> faces; // sorted face -> side signs
  std::set<std::array<int32_t, 4>> sets;
  std::set<int32_t> used;
  for (const auto& q : m.tets) {
    auto s = q;
    std::sort(s.begin(), s.end());
    if (!sets.insert(s).second) ++b.duplicates;
    for (int32_t v : q) used.insert(v);
    if (std::adjacent_find(s.begin(), s.end()) != s.end()) continue;
    for (int f = 0; f < 4; ++f) {
      // Face opposite corner f, its corners listed in tet order. Listed so, the face is
      // outward-oriented for even f and inward for odd f; the parity of the sorting permutation
      // combined with f tells which side of the sorted face the tet lies on.
      std::array<int32_t, 3> face;
      int n = 0;
      for (int c = 0; c < 4; ++c)
        if (c != f) face[n++] = q[c];
      int parity = 0;
      for (int i = 0; i < 3; ++i)
        for (int j = i + 1; j < 3; ++j)
          if (face[i] > face[j]) parity ^= 1;
      auto sorted = face;
      std::sort(sorted.begin(), sorted.end());
      const int vertexParity = f % 2;
      faces[sorted].push_back(parity ^ vertexParity);
    }
  }
  std::map<std::array<int32_t, 2>, int> edges;
  for (const auto& [f, sides] : faces) {
    if (sides.size() == 1) {
      ++b.boundary;
      ++edges[{f[0], f[1]}];
      ++edges[{f[1], f[2]}];
      ++edges[{f[0], f[2]}];
    } else if (sides.size() == 2) {
      ++b.interior;
      if (sides[0] == sides[1]) ++b.folded;
    } else {
      ++b.nonmanifold;
    }
  }
  for (const auto& [e, c] : edges) {
    ++b.edges;
    if (c == 1) ++b.open;
    if (c > 2) ++b.nmEdges;
  }
  b.unreferenced = static_cast<int64_t>(m.numPoints()) - static_cast<int64_t>(used.size());
  return b;
}

void expectMatchesBrute(const TetMesh& m) {
  const auto r = evaluate(m);
  const FaceTally b = brute(m);
  EXPECT_EQ(r.boundaryFaces, b.boundary);
  EXPECT_EQ(r.interiorFaces, b.interior);
  EXPECT_EQ(r.nonmanifoldFaces, b.nonmanifold);
  EXPECT_EQ(r.foldedFaces, b.folded);
  EXPECT_EQ(r.duplicateTets, b.duplicates);
  EXPECT_EQ(r.boundaryEdges, b.edges);
  EXPECT_EQ(r.openBoundaryEdges, b.open);
  EXPECT_EQ(r.nonmanifoldBoundaryEdges, b.nmEdges);
  EXPECT_EQ(r.boundaryClosed, b.open == 0 && b.nmEdges == 0);
  EXPECT_EQ(r.unreferencedVertices, b.unreferenced);
}

// A perturbed grid with random damage: dropped, duplicated, inverted and random extra tets.
TetMesh damagedGrid(unsigned seed) {
  TetMesh g = kuhnCubes(4, 3, 3, 1.0, 0.15, seed);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pct(0, 99);
  std::uniform_int_distribution<int32_t> vert(0, static_cast<int32_t>(g.numPoints()) - 1);
  TetMesh m;
  m.points = g.points;
  for (size_t t = 0; t < g.numTets(); ++t) {
    const int r = pct(rng);
    if (r < 5) continue; // dropped
    auto q = g.tets[t];
    if (r < 10) std::swap(q[2], q[3]); // inverted
    m.tets.push_back(q);
    m.materials.push_back(g.materials[t]);
    if (r >= 95) { // duplicated, rotated corner order
      m.tets.push_back({q[1], q[2], q[0], q[3]});
      m.materials.push_back(g.materials[t]);
    }
  }
  for (int k = 0; k < 10; ++k) { // random tets on existing vertices (may repeat a vertex)
    m.tets.push_back({vert(rng), vert(rng), vert(rng), vert(rng)});
    m.materials.push_back(9);
  }
  return m;
}

TEST(MeshQuality, FaceAnalysisMatchesBruteForceOnRandomSoups) {
  for (unsigned seed : {1u, 2u, 3u, 4u, 5u}) {
    SCOPED_TRACE(seed);
    expectMatchesBrute(damagedGrid(seed));
  }
  expectMatchesBrute(kuhnCubes(3, 2, 2, 0.5, 0.1, 7));
}

TEST(MeshQuality, WideKeysAboveTwoMillionVertices) {
  // More than 2^21 vertices switches to 128-bit face keys; use the highest indices.
  TetMesh small = damagedGrid(11);
  TetMesh m;
  const size_t pad = (size_t(1) << 21) + 5;
  m.points.assign(pad, Vec3{0, 0, 0});
  m.points.insert(m.points.end(), small.points.begin(), small.points.end());
  for (auto q : small.tets) {
    for (auto& v : q) v += static_cast<int32_t>(pad);
    m.tets.push_back(q);
  }
  m.materials = small.materials;
  const auto r = evaluate(m);
  const auto s = evaluate(small);
  EXPECT_EQ(r.boundaryFaces, s.boundaryFaces);
  EXPECT_EQ(r.interiorFaces, s.interiorFaces);
  EXPECT_EQ(r.nonmanifoldFaces, s.nonmanifoldFaces);
  EXPECT_EQ(r.foldedFaces, s.foldedFaces);
  EXPECT_EQ(r.duplicateTets, s.duplicateTets);
  EXPECT_EQ(r.boundaryEdges, s.boundaryEdges);
  EXPECT_EQ(r.openBoundaryEdges, s.openBoundaryEdges);
  EXPECT_EQ(r.nonmanifoldBoundaryEdges, s.nonmanifoldBoundaryEdges);
  EXPECT_EQ(r.unreferencedVertices, s.unreferencedVertices + static_cast<int64_t>(pad));
}

TEST(MeshQuality, PerturbedGridStatisticsAreConsistent) {
  const TetMesh m = kuhnCubes(8, 7, 6, 2.0, 0.15, 42);
  for (double w : {5.0, 7.0, 0.5, 90.0}) {
    SCOPED_TRACE(w);
    QualityParams p;
    p.bin_width_deg = w;
    const auto r = evaluate(m, p);
    EXPECT_TRUE(r.valid);
    EXPECT_TRUE(r.boundaryClosed);
    EXPECT_NEAR(r.volume, 16.0 * 14.0 * 12.0, 1e-9);
    EXPECT_EQ(r.histogram.size(), static_cast<size_t>(std::ceil(180.0 / w - 1e-9)));
    int64_t sum = 0;
    for (int64_t c : r.histogram) sum += c;
    EXPECT_EQ(sum, r.tets);
    // FaceTally-force figures from the fields.
    const auto& mn = r.cellFields.at("min_dihedral").values;
    const auto& mx = r.cellFields.at("max_dihedral").values;
    EXPECT_EQ(r.minDihedral, *std::min_element(mn.begin(), mn.end()));
    EXPECT_EQ(r.maxDihedral, *std::max_element(mx.begin(), mx.end()));
    std::vector<int64_t> hist(r.histogram.size(), 0);
    std::array<int64_t, 3> below{};
    for (double a : mn) {
      ++hist[std::min(hist.size() - 1, static_cast<size_t>(std::floor(a / w)))];
      for (int k = 0; k < 3; ++k) below[k] += a < kMinDihedralThresholds[k] ? 1 : 0;
    }
    EXPECT_EQ(r.histogram, hist);
    EXPECT_EQ(r.tetsBelow, below);
    if (w == 5.0) {
      EXPECT_EQ(r.tetsBelow[0], r.histogram[0]);
      EXPECT_EQ(r.tetsBelow[2], r.histogram[0] + r.histogram[1] + r.histogram[2]);
    }
    auto ar = r.cellFields.at("aspect_ratio").values;
    std::sort(ar.begin(), ar.end());
    EXPECT_EQ(r.aspectRatioMin, ar.front());
    ASSERT_EQ(ar.size() % 2, 0u);
    EXPECT_DOUBLE_EQ(r.aspectRatioMedian, 0.5 * (ar[ar.size() / 2 - 1] + ar[ar.size() / 2]));
    auto rr = r.cellFields.at("radius_ratio").values;
    std::sort(rr.begin(), rr.end());
    EXPECT_EQ(r.radiusRatioMin, rr.front());
    EXPECT_DOUBLE_EQ(r.radiusRatioMedian, 0.5 * (rr[rr.size() / 2 - 1] + rr[rr.size() / 2]));
    for (size_t t = 0; t < m.numTets(); t += 97) {
      const auto& q = m.tets[t];
      const auto e = tetMetrics(m.points[q[0]], m.points[q[1]], m.points[q[2]], m.points[q[3]]);
      EXPECT_EQ(mn[t], e.minDihedral);
      EXPECT_EQ(r.cellFields.at("volume").values[t], e.volume);
    }
  }
}

TEST(MeshQuality, PerMaterialVolumesWithReference) {
  QualityParams p;
  p.referenceVolumes = {{1, 0.6}, {2, 1.0 / 3.0}, {7, 2.0}};
  const auto r = evaluate(cubeFive(), p);
  ASSERT_EQ(r.materials.size(), 2u);
  const auto& m1 = r.materials.at(1);
  EXPECT_TRUE(m1.hasReference);
  EXPECT_DOUBLE_EQ(m1.reference, 0.6);
  EXPECT_NEAR(m1.relError, (2.0 / 3.0 - 0.6) / 0.6, 1e-12);
  EXPECT_NEAR(r.materials.at(2).relError, 0.0, 1e-12);
  EXPECT_EQ(r.referenceLabelsMissing, std::vector<int32_t>{7});

  Report rep;
  writeQualityReport(r, rep);
  EXPECT_EQ(rep.number("material_1_tets"), 4);
  EXPECT_NEAR(rep.number("material_1_volume_mm3"), 2.0 / 3.0, 1e-12);
  EXPECT_DOUBLE_EQ(rep.number("material_1_reference_mm3"), 0.6);
  EXPECT_NEAR(rep.number("material_1_volume_rel_error"), (2.0 / 3.0 - 0.6) / 0.6, 1e-12);
  EXPECT_EQ(std::get<std::string>(*rep.find("reference_labels_missing")), "7");
  EXPECT_FALSE(rep.has("material_7_tets"));
}

TEST(MeshQuality, ReportLayout) {
  const auto r = evaluate(cubeFive());
  Report rep;
  writeQualityReport(r, rep);
  std::vector<std::string> keys;
  for (const auto& e : rep.entries()) keys.push_back(e.first);
  const std::vector<std::string> head{
      "tets", "vertices", "valid", "inverted", "zero_volume", "repeated_vertex_tets",
      "duplicate_tets", "nonmanifold_faces", "interior_faces", "boundary_faces", "folded_faces",
      "boundary_edges", "open_boundary_edges", "nonmanifold_boundary_edges", "boundary_closed",
      "unreferenced_vertices", "min_dihedral_deg", "max_dihedral_deg", "tets_below_5deg",
      "tets_below_10deg", "tets_below_15deg", "aspect_ratio_min", "aspect_ratio_median",
      "radius_ratio_min", "radius_ratio_median", "volume_mm3", "material_1_tets",
      "material_1_volume_mm3", "material_2_tets", "material_2_volume_mm3", "histogram_bin_deg",
      "min_dihedral_histogram"};
  EXPECT_EQ(keys, head);
  EXPECT_EQ(rep.number("tets"), 5);
  EXPECT_EQ(std::get<bool>(*rep.find("valid")), true);
  EXPECT_EQ(std::get<bool>(*rep.find("boundary_closed")), true);
  EXPECT_EQ(rep.number("boundary_faces"), 12);
  EXPECT_NEAR(rep.number("volume_mm3"), 1.0, 1e-12);
  const auto hist = std::get<std::string>(*rep.find("min_dihedral_histogram"));
  EXPECT_EQ(hist.rfind("0-5:0 5-10:0 10-15:0 ", 0), 0u) << hist;
  EXPECT_NE(hist.find(" 50-55:4 "), std::string::npos) << hist;
  EXPECT_NE(hist.find(" 70-75:1 "), std::string::npos) << hist;
  EXPECT_EQ(hist.substr(hist.size() - 10), " 175-180:0") << hist;

  // Non-integer bin width: labels keep their decimals, the last bin is clipped at 180.
  QualityParams p;
  p.bin_width_deg = 7.5;
  Report rep2;
  writeQualityReport(evaluate(cubeFive(), p), rep2);
  const auto hist2 = std::get<std::string>(*rep2.find("min_dihedral_histogram"));
  EXPECT_EQ(hist2.rfind("0-7.5:0 7.5-15:0 ", 0), 0u) << hist2;
  EXPECT_NE(hist2.find(" 52.5-60:4 "), std::string::npos) << hist2;
  EXPECT_EQ(hist2.substr(hist2.size() - 12), " 172.5-180:0") << hist2;
  QualityParams p7;
  p7.bin_width_deg = 7;
  const auto r7 = evaluate(cubeFive(), p7);
  EXPECT_EQ(r7.histogram.size(), 26u);
  EXPECT_EQ(histogramBinLabel(r7, 25), "175-180");
}

TEST(MeshQuality, StagesAndCancellation) {
  const TetMesh m = kuhnCubes(4, 4, 4, 1.0, 0.1, 3);
  NullProgress progress;
  evaluateQuality(m, {}, progress);
  std::vector<std::string> names;
  for (const auto& s : progress.stageTimes()) names.push_back(s.name);
  EXPECT_EQ(names, (std::vector<std::string>{"metrics", "topology", "statistics"}));
  NullProgress cancelled;
  cancelled.requestCancel();
  EXPECT_THROW(evaluateQuality(m, {}, cancelled), Cancelled);
}

TEST(MeshQuality, BadInputIsRefused) {
  NullProgress progress;
  TetMesh empty;
  EXPECT_THROW_MSG(evaluateQuality(empty, {}, progress), InputError, "no tetrahedra");
  const TetMesh cube = cubeFive();
  for (double w : {0.0, -5.0, 90.5, std::nan("")}) {
    QualityParams p;
    p.bin_width_deg = w;
    EXPECT_THROW_MSG(evaluateQuality(cube, p, progress), InputError, "bin width", "90");
  }
  QualityParams p;
  p.bin_width_deg = 90.0; // the upper end is allowed
  EXPECT_EQ(evaluateQuality(cube, p, progress).histogram.size(), 2u);
  p.referenceVolumes[4] = 0.0;
  EXPECT_THROW_MSG(evaluateQuality(cube, p, progress), InputError, "reference volume",
                   "material 4");
  TetMesh broken = cube;
  broken.tets[2][1] = 99;
  EXPECT_THROW_MSG(evaluateQuality(broken, {}, progress), InputError, "EvaluateQuality",
                   "refers to vertex 99");
}

// Not run by default: timing on a 1.5 million tet grid
// (--gtest_also_run_disabled_tests --gtest_filter='*Timing*').
TEST(MeshQuality, DISABLED_TimingOnALargeGrid) {
  const TetMesh m = kuhnCubes(64, 64, 64, 1.0, 0.15, 5);
  NullProgress progress;
  const auto r = evaluateQuality(m, {}, progress);
  EXPECT_TRUE(r.valid);
  EXPECT_TRUE(r.boundaryClosed);
  for (const auto& s : progress.stageTimes())
    std::printf("%s: %.3f s (%zu tets)\n", s.name.c_str(), s.seconds, m.numTets());
}

} // namespace
} // namespace tetflow
