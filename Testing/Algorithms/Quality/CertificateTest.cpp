// Tests for Algorithms/Quality/Certificate: the exact voxel mesh (every voxel split into 6 Kuhn
// tets) of random label volumes against a brute-force voxel computation of the same rules (BFS, not
// union-find); deliberately damaged meshes (a component relabelled away, a spurious island, two
// blobs bridged, a label removed from the outside) must be flagged with the right counts, places
// and per-tet flags; contacts, non-manifold edges, thresholds and bad input.
#include "Algorithms/Quality/Certificate.h"
#include "Algorithms/Quality/LabelTopology.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <omp.h>
#include <map>
#include <random>
#include <set>
#include <tuple>

#include "Algorithms/Core/Errors.h"
#include "Fixtures/VoxelComponents.h"
#include "Fixtures/VoxelMesh.h"
#include "TestUtil.h"

namespace tetflow {
namespace {
using test::firstTet;
using test::relabelVoxel;
using test::voxelMesh;

LabelVolume blankVolume(int nx, int ny, int nz, double h = 1.0, int32_t fill = 0) {
  LabelVolume v;
  GridGeometry g;
  g.dims = {nx, ny, nz};
  g.spacing = {h, h, h};
  g.origin = {1.0, -2.0, 0.5};
  v.allocate(g, fill);
  return v;
}

CertificateResult certify(const TetMesh& m, const LabelVolume& v) {
  NullProgress p;
  return certifyMesh(m, v, p);
}

const LabelCertificate& labelOf(const CertificateResult& r, int32_t L) {
  for (const auto& lc : r.labels)
    if (lc.label == L) return lc;
  throw std::runtime_error("label not in the certificate");
}

// --- brute force: the rules of Certificate.h by BFS over voxels -----------------------------
struct VoxelRules {
  std::map<int32_t, int> image26, robust, mesh6, split;
};

VoxelRules bruteForce(const LabelVolume& v) {
  auto core = [&](int i, int j, int k) { return test::isCoreVoxel(v, i, j, k); };
  auto components = [&](auto member, bool full) { return test::voxelComponents(v, member, full); };
  auto all = [](int, int, int) { return true; };
  const auto [c26, n26] = components(all, true);
  const auto [c6, n6] = components(all, false);
  const auto [cc, ncc] = components(core, true);
  std::vector<int32_t> labelOf26(static_cast<size_t>(n26));
  std::vector<std::set<int>> pieces(static_cast<size_t>(n26)), cores(static_cast<size_t>(n26));
  for (int64_t x = 0; x < v.grid.voxelCount(); ++x) {
    labelOf26[size_t(c26[size_t(x)])] = v.data[size_t(x)];
    pieces[size_t(c26[size_t(x)])].insert(c6[size_t(x)]);
    if (cc[size_t(x)] >= 0) cores[size_t(c26[size_t(x)])].insert(cc[size_t(x)]);
  }
  (void)n6;
  (void)ncc;
  VoxelRules b;
  std::set<std::pair<int32_t, int>> seen6;
  for (int64_t x = 0; x < v.grid.voxelCount(); ++x) seen6.insert({v.data[size_t(x)], c6[size_t(x)]});
  for (const auto& [L, c] : seen6) ++b.mesh6[L];
  for (int c = 0; c < n26; ++c) {
    const int32_t L = labelOf26[size_t(c)];
    ++b.image26[L];
    if (!cores[size_t(c)].empty()) ++b.robust[L];
    if (int(pieces[size_t(c)].size()) > std::max<int>(1, int(cores[size_t(c)].size()))) ++b.split[L];
  }
  return b;
}

LabelVolume randomSegmentation(std::mt19937& rng) {
  std::uniform_int_distribution<int> dim(4, 11), lab(1, 4), coin(0, 99);
  LabelVolume v = blankVolume(dim(rng), dim(rng), dim(rng), 0.5 + 0.25 * (rng() % 4));
  // Random boxes of random labels over a background of 0, plus salt: components of every kind.
  const int boxes = 2 + int(rng() % 6);
  for (int b = 0; b < boxes; ++b) {
    const int32_t L = lab(rng);
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      const int n = int(v.grid.dims[a]);
      lo[a] = int(rng() % n);
      hi[a] = std::min(n - 1, lo[a] + int(rng() % 5));
    }
    for (int k = lo[2]; k <= hi[2]; ++k)
      for (int j = lo[1]; j <= hi[1]; ++j)
        for (int i = lo[0]; i <= hi[0]; ++i) v.at(i, j, k) = L;
  }
  for (auto& x : v.data)
    if (coin(rng) < 4) x = lab(rng);
  return v;
}

TEST(Certificate, ExactVoxelMeshesOfRandomVolumesMatchTheBruteForceRules) {
  std::mt19937 rng(20261124);
  for (int c = 0; c < 40; ++c) {
    const LabelVolume v = randomSegmentation(rng);
    const TetMesh m = voxelMesh(v);
    const CertificateResult r = certify(m, v);
    const VoxelRules b = bruteForce(v);
    SCOPED_TRACE("case " + std::to_string(c));
    EXPECT_TRUE(r.excludedLabels.empty());
    EXPECT_DOUBLE_EQ(r.agreement, 1.0);
    EXPECT_TRUE(r.spuriousContacts.empty());
    EXPECT_TRUE(r.missingContacts.empty());
    EXPECT_EQ(r.lost + r.lostSmall + r.merged + r.spurious, 0);
    int split = 0;
    for (const auto& [L, n] : b.image26) {
      const auto& lc = labelOf(r, L);
      EXPECT_NEAR(lc.relError, 0.0, 1e-10) << "label " << L;
      EXPECT_EQ(lc.imageComponents, n) << "label " << L;
      EXPECT_EQ(lc.robustComponents, b.robust.count(L) ? b.robust.at(L) : 0) << "label " << L;
      // Face-connected voxel tets are the 6-connected voxel components.
      EXPECT_EQ(lc.meshComponents, b.mesh6.at(L)) << "label " << L;
      EXPECT_EQ(lc.split, b.split.count(L) ? b.split.at(L) : 0) << "label " << L;
      split += lc.split;
    }
    EXPECT_EQ(r.split, split);
    // Flags only where a split component has extra pieces (2) or a non-manifold interface (32).
    for (int32_t f : r.flags) EXPECT_EQ(f & ~(2 | 32), 0);
  }
}

// Non-manifold interfaces by their definition, set by set: an edge of the faces between labels
// (or on the boundary) that more than two such faces of one label's tets share; a vertex around
// which one label's tets, or the other tets, fall into more than one group joined by faces at the
// vertex (searched tet by tet). The counts per label and in all, and flag 32 on exactly the tets
// of those edges' records and of those vertices' labels, on the voxel meshes of random volumes
// (whose voxel edges and corners give both).
TEST(Certificate, NonManifoldEdgesAndVerticesAreTheDefinitions) {
  std::mt19937 rng(71);
  int64_t edgesSeen = 0, verticesSeen = 0;
  for (int c = 0; c < 12; ++c) {
    const LabelVolume v = randomSegmentation(rng);
    const TetMesh m = voxelMesh(v);
    const CertificateResult r = certify(m, v);
    NullProgress np;
    const std::vector<int32_t> nb = tetFaceNeighbours(m, np);
    std::vector<int32_t> flag(m.numTets(), 0);
    std::map<int32_t, int64_t> edgesOf, verticesOf;
    // Edges.
    std::map<std::tuple<int32_t, int32_t, int32_t>, std::vector<int32_t>> rec; // (a, b, label) -> tets
    for (size_t t = 0; t < m.numTets(); ++t)
      for (int f = 0; f < 4; ++f) {
        const int32_t o = nb[4 * t + size_t(f)];
        if (o >= 0 && m.materials[size_t(o)] == m.materials[t]) continue;
        for (int e = 0; e < 3; ++e) {
          const int32_t x = m.tets[t][kTetFaceVertices[f][e]], y = m.tets[t][kTetFaceVertices[f][(e + 1) % 3]];
          rec[{std::min(x, y), std::max(x, y), m.materials[t]}].push_back(int32_t(t));
        }
      }
    std::set<std::pair<int32_t, int32_t>> badEdges;
    for (const auto& [key, tets] : rec)
      if (tets.size() > 2) {
        badEdges.insert({std::get<0>(key), std::get<1>(key)});
        ++edgesOf[std::get<2>(key)];
        for (int32_t t : tets) flag[size_t(t)] = 32;
      }
    // Vertices.
    std::vector<std::vector<int32_t>> starOf(m.numPoints());
    for (size_t t = 0; t < m.numTets(); ++t)
      for (int32_t p : m.tets[t]) starOf[size_t(p)].push_back(int32_t(t));
    int64_t badVertices = 0;
    for (size_t p = 0; p < m.numPoints(); ++p) {
      const auto& st = starOf[p];
      auto groupsOf = [&](auto member) {
        std::set<int32_t> left;
        for (int32_t t : st)
          if (member(t)) left.insert(t);
        int groups = 0;
        while (!left.empty()) {
          ++groups;
          std::deque<int32_t> q{*left.begin()};
          left.erase(left.begin());
          while (!q.empty()) {
            const int32_t t = q.front();
            q.pop_front();
            for (int f = 0; f < 4; ++f) {
              if (m.tets[size_t(t)][f] == int32_t(p)) continue; // a face at p omits another vertex
              const int32_t o = nb[4 * size_t(t) + size_t(f)];
              if (o >= 0 && left.erase(o)) q.push_back(o);
            }
          }
        }
        return groups;
      };
      std::set<int32_t> labels;
      for (int32_t t : st) labels.insert(m.materials[size_t(t)]);
      if (labels.size() < 2) continue;
      bool bad = false;
      for (int32_t L : labels)
        if (groupsOf([&](int32_t t) { return m.materials[size_t(t)] == L; }) > 1 ||
            groupsOf([&](int32_t t) { return m.materials[size_t(t)] != L; }) > 1) {
          bad = true;
          ++verticesOf[L];
          for (int32_t t : st)
            if (m.materials[size_t(t)] == L) flag[size_t(t)] = 32;
        }
      badVertices += bad ? 1 : 0;
    }
    SCOPED_TRACE("case " + std::to_string(c));
    EXPECT_EQ(r.nonmanifoldEdges, int64_t(badEdges.size()));
    EXPECT_EQ(r.nonmanifoldVertices, badVertices);
    for (const auto& lc : r.labels) {
      EXPECT_EQ(lc.nonmanifoldEdges, edgesOf.count(lc.label) ? edgesOf[lc.label] : 0) << "label " << lc.label;
      EXPECT_EQ(lc.nonmanifoldVertices, verticesOf.count(lc.label) ? verticesOf[lc.label] : 0) << "label " << lc.label;
    }
    for (size_t t = 0; t < m.numTets(); ++t) ASSERT_EQ(r.flags[t] & 32, flag[t]) << "tet " << t;
    // The places: the first (up to 20) bad edges' midpoints, in ascending order of their ends.
    size_t i = 0;
    for (const auto& [a, b] : badEdges) {
      if (i == 20 || i >= r.nonmanifoldPlaces.size()) break;
      const Vec3 mid = 0.5 * (m.points[size_t(a)] + m.points[size_t(b)]);
      for (int x = 0; x < 3; ++x) EXPECT_DOUBLE_EQ(r.nonmanifoldPlaces[i][x], mid[x]);
      ++i;
    }
    edgesSeen += int64_t(badEdges.size());
    verticesSeen += badVertices;
  }
  EXPECT_GT(edgesSeen, 20);
  EXPECT_GT(verticesSeen, 20);
}

TEST(Certificate, ContactsAreFaceContactsWithTheirArea) {
  LabelVolume v = blankVolume(4, 3, 3, 2.0);
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j) {
      v.at(0, j, k) = 1;
      v.at(1, j, k) = 1;
      v.at(2, j, k) = 2;
      v.at(3, j, k) = 3;
    }
  TetMesh m = voxelMesh(v);
  CertificateResult r = certify(m, v);
  EXPECT_TRUE(r.spuriousContacts.empty());
  EXPECT_TRUE(r.missingContacts.empty());
  // Relabel the middle slab 2 -> 1 in the mesh: contact 1-3 appears (9 faces of 4 mm^2), 1-2 and
  // 2-3 disappear, label 2 is lost (its slab is one voxel thick: no core), nothing robust lost.
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j) relabelVoxel(v, m, 2, j, k, 1);
  r = certify(m, v);
  ASSERT_EQ(r.spuriousContacts.size(), 1u);
  EXPECT_EQ(r.spuriousContacts[0].a, 1);
  EXPECT_EQ(r.spuriousContacts[0].b, 3);
  EXPECT_NEAR(r.spuriousContacts[0].meshArea, 36.0, 1e-9);
  EXPECT_NEAR(r.spuriousContacts[0].where.centroid[0], v.grid.indexToPhysical(2.5, 0, 0)[0], 1e-9);
  ASSERT_EQ(r.missingContacts.size(), 2u);
  EXPECT_NEAR(r.missingContacts[0].imageArea, 36.0, 1e-9);
  EXPECT_EQ(r.lostSmall, 1);
  EXPECT_EQ(r.lost, 0);
  EXPECT_NEAR(labelOf(r, 2).relError, -1.0, 1e-12);
  EXPECT_NEAR(labelOf(r, 1).relError, 0.5, 1e-12);
  int touching = 0;
  for (size_t t = 0; t < m.numTets(); ++t) touching += (r.flags[t] & 16) ? 1 : 0;
  EXPECT_GT(touching, 0);
}

// A component at the box that the mesh lost under another label's tets was not stripped: it is
// lost (and its contacts still count), where a stripped exterior leaves its voxels outside the mesh.
TEST(Certificate, ABoxComponentLostUnderOtherTetsIsLostNotStripped) {
  LabelVolume v = blankVolume(12, 10, 9, 1.5);
  std::fill(v.data.begin(), v.data.end(), 1);
  for (int k = 0; k <= 2; ++k) // label 5 at the box corner (one core voxel, the box does not erode)...
    for (int j = 0; j <= 2; ++j)
      for (int i = 0; i <= 2; ++i) v.at(i, j, k) = 5;
  for (int k = 4; k <= 6; ++k) // ... and inside
    for (int j = 4; j <= 6; ++j)
      for (int i = 5; i <= 7; ++i) v.at(i, j, k) = 5;
  TetMesh m = voxelMesh(v);
  for (int k = 0; k <= 2; ++k)
    for (int j = 0; j <= 2; ++j)
      for (int i = 0; i <= 2; ++i) relabelVoxel(v, m, i, j, k, 1);
  CertificateResult r = certify(m, v);
  EXPECT_TRUE(r.strippedLabels.empty());
  EXPECT_EQ(r.lost, 1);
  EXPECT_EQ(labelOf(r, 5).voxels, 54);
  // Removing those tets instead strips the exterior of 5: left out, not lost.
  TetMesh cut;
  cut.points = m.points;
  for (size_t t = 0; t < m.numTets(); ++t) {
    const Vec3 c = tetCentroid(m, t);
    bool corner = true; // in the corner's voxels (index < 2.5)
    for (int a = 0; a < 3; ++a) corner = corner && (c[a] - v.grid.origin[a]) / 1.5 < 2.5;
    if (corner) continue;
    cut.tets.push_back(m.tets[t]);
    cut.materials.push_back(m.materials[t]);
  }
  r = certify(cut, v);
  EXPECT_EQ(r.strippedLabels, std::vector<int32_t>{5});
  EXPECT_EQ(r.lost, 0);
  EXPECT_EQ(labelOf(r, 5).voxels, 27);
}

TEST(Certificate, ARelabelledRobustComponentIsLostWithItsSizeAndPlace) {
  LabelVolume v = blankVolume(12, 10, 9, 1.5);
  // Two 3x3x3 cubes of label 5 (each with one core voxel) in a background of 1.
  std::fill(v.data.begin(), v.data.end(), 1);
  for (int k = 2; k <= 4; ++k)
    for (int j = 2; j <= 4; ++j)
      for (int i = 2; i <= 4; ++i) {
        v.at(i, j, k) = 5;
        v.at(i + 5, j + 3, k + 2) = 5;
      }
  TetMesh m = voxelMesh(v);
  CertificateResult r = certify(m, v);
  EXPECT_EQ(labelOf(r, 5).imageComponents, 2);
  EXPECT_EQ(labelOf(r, 5).robustComponents, 2);
  EXPECT_EQ(r.lost + r.split + r.merged + r.spurious, 0);
  // Delete the second cube from the mesh by relabelling its tets to the background.
  for (int k = 4; k <= 6; ++k)
    for (int j = 5; j <= 7; ++j)
      for (int i = 7; i <= 9; ++i) relabelVoxel(v, m, i, j, k, 1);
  r = certify(m, v);
  ASSERT_EQ(r.lost, 1);
  const ComponentIssue& is = r.componentIssues.front();
  EXPECT_EQ(is.kind, ComponentIssueKind::Lost);
  EXPECT_EQ(is.label, 5);
  EXPECT_EQ(is.voxels, 27);
  EXPECT_EQ(is.cores, 1);
  const Vec3 c = v.grid.indexToPhysical(8, 6, 5);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(is.where.centroid[a], c[a], 1e-9);
    EXPECT_NEAR(is.where.boxMax[a] - is.where.boxMin[a], 3.0, 1e-9); // centres 1.5 mm apart
  }
  int flagged = 0;
  for (size_t t = 0; t < m.numTets(); ++t) flagged += (r.flags[t] & 8) ? 1 : 0;
  EXPECT_EQ(flagged, 27 * 6);
  const auto fails = certificateFailures(r, {0.0, true, false});
  ASSERT_EQ(fails.size(), 1u);
  EXPECT_NE(fails[0].find("1 lost"), std::string::npos) << fails[0];
  EXPECT_NE(fails[0].find("label 5, image component of 27 voxels"), std::string::npos) << fails[0];
}

TEST(Certificate, AnIslandIsSpuriousAndABridgeMergesTwoBlobs) {
  LabelVolume v = blankVolume(13, 7, 7);
  std::fill(v.data.begin(), v.data.end(), 1);
  // Cubes of label 2 at x 1..3 and 5..7, one voxel of background between them.
  for (int k = 2; k <= 4; ++k)
    for (int j = 2; j <= 4; ++j)
      for (int i = 1; i <= 3; ++i) {
        v.at(i, j, k) = 2;
        v.at(i + 4, j, k) = 2;
      }
  TetMesh m = voxelMesh(v);
  relabelVoxel(v, m, 4, 3, 3, 2);  // bridge
  relabelVoxel(v, m, 11, 3, 3, 2); // island in the background
  const CertificateResult r = certify(m, v);
  EXPECT_EQ(r.merged, 1);
  EXPECT_EQ(r.spurious, 1);
  EXPECT_EQ(r.lost + r.split, 0);
  const auto& lc = labelOf(r, 2);
  EXPECT_EQ(lc.imageComponents, 2);
  EXPECT_EQ(lc.meshComponents, 2);
  bool sawSpurious = false;
  for (const auto& is : r.componentIssues)
    if (is.kind == ComponentIssueKind::Spurious) {
      sawSpurious = true;
      EXPECT_NEAR(is.meshVolume, 1.0, 1e-12);
      const Vec3 c = v.grid.indexToPhysical(11, 3, 3);
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(is.where.centroid[a], c[a], 1e-9);
    }
  EXPECT_TRUE(sawSpurious);
  for (size_t t = firstTet(v, 11, 3, 3); t < firstTet(v, 11, 3, 3) + 6; ++t) EXPECT_TRUE(r.flags[t] & 1);
  for (size_t t = firstTet(v, 2, 3, 3); t < firstTet(v, 2, 3, 3) + 6; ++t) EXPECT_TRUE(r.flags[t] & 4);
  // Thresholds: the component rule fails, the volume rule only above the error.
  EXPECT_EQ(certificateFailures(r, {0.0, true, false}).size(), 1u);
  EXPECT_TRUE(certificateFailures(r, {0.05, false, true}).empty()); // +2/54 = 3.7 %, no new contact
  const auto f = certificateFailures(r, {0.03, false, false});
  ASSERT_EQ(f.size(), 1u);
  EXPECT_NE(f[0].find("worst is label 2 at +3.70 %"), std::string::npos) << f[0];

  // With tissue names (the mesh's first, then the volume's), every message names the tissue.
  v.labelNames = {{1, "CSF"}, {2, "ventricle"}};
  m.materialNames = {{2, "grey matter"}};
  const CertificateResult named = certify(m, v);
  EXPECT_EQ(named.names, (std::map<int32_t, std::string>{{1, "CSF"}, {2, "grey matter"}}));
  const auto g = certificateFailures(named, {0.03, true, false});
  ASSERT_EQ(g.size(), 2u);
  EXPECT_NE(g[0].find("worst is label 2 (grey matter) at +3.70 %"), std::string::npos) << g[0];
  EXPECT_NE(g[1].find(": label 2 (grey matter), "), std::string::npos) << g[1];
  Report rep;
  writeCertificateReport(named, rep);
  EXPECT_EQ(std::get<std::string>(*rep.find("cert_label_1_name")), "CSF");
  EXPECT_NE(std::get<std::string>(*rep.find("cert_issue_1")).find("label 2 (grey matter)"), std::string::npos);
  EXPECT_EQ(named.labelPairText(1, 2), "labels 1 (CSF) and 2 (grey matter)");
  EXPECT_EQ(named.labelPairText(1, 9), "labels 1 (CSF) and 9");
}

TEST(Certificate, AStrippedOutsideLabelIsExcluded) {
  LabelVolume v = blankVolume(8, 8, 8);
  for (int k = 2; k <= 5; ++k)
    for (int j = 2; j <= 5; ++j)
      for (int i = 2; i <= 5; ++i) v.at(i, j, k) = (i < 4) ? 3 : 4;
  TetMesh full = voxelMesh(v);
  TetMesh m;
  m.points = full.points;
  for (size_t t = 0; t < full.numTets(); ++t)
    if (full.materials[t] != 0) {
      m.tets.push_back(full.tets[t]);
      m.materials.push_back(full.materials[t]);
    }
  const CertificateResult r = certify(m, v);
  ASSERT_EQ(r.excludedLabels, std::vector<int32_t>{0});
  EXPECT_TRUE(labelOf(r, 0).excluded);
  EXPECT_EQ(r.lost + r.lostSmall + r.split + r.merged + r.spurious, 0);
  EXPECT_TRUE(r.missingContacts.empty()); // 0-3 and 0-4 are not compared
  EXPECT_DOUBLE_EQ(r.agreement, 1.0);
  Report rep;
  writeCertificateReport(r, rep);
  EXPECT_EQ(std::get<std::string>(*rep.find("cert_excluded_labels")), "0");
  EXPECT_TRUE(std::get<bool>(*rep.find("cert_label_0_excluded")));
  EXPECT_NEAR(rep.number("cert_label_3_volume_rel_error"), 0.0, 1e-12);
  EXPECT_EQ(rep.number("cert_label_4_mesh_components"), 1);
}

TEST(Certificate, LabelsTouchingAlongAnEdgeAreNonManifoldThere) {
  LabelVolume v = blankVolume(4, 4, 3);
  v.at(1, 1, 1) = 7;
  v.at(2, 2, 1) = 7; // shares only the edge x = 1.5, y = 1.5 with the first
  const TetMesh m = voxelMesh(v);
  const CertificateResult r = certify(m, v);
  EXPECT_EQ(r.nonmanifoldEdges, 1); // one lattice edge, non-manifold for labels 7 and 0
  EXPECT_EQ(labelOf(r, 7).nonmanifoldEdges, 1);
  EXPECT_GE(r.nonmanifoldVertices, 2); // the two ends of that edge
  ASSERT_FALSE(r.nonmanifoldPlaces.empty());
  const Vec3 mid = v.grid.indexToPhysical(1.5, 1.5, 1);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(r.nonmanifoldPlaces[0][a], mid[a], 1e-9);
  // 26-connected, two 6-connected pieces, no cores: one split component.
  EXPECT_EQ(labelOf(r, 7).imageComponents, 1);
  EXPECT_EQ(labelOf(r, 7).meshComponents, 2);
  EXPECT_EQ(r.split, 1);
}

TEST(Certificate, AMeshLabelAbsentFromTheImageIsSpuriousAndBadInputIsRefused) {
  LabelVolume v = blankVolume(5, 5, 5, 1.0, 2);
  TetMesh m = voxelMesh(v);
  relabelVoxel(v, m, 2, 2, 2, 9);
  const CertificateResult r = certify(m, v);
  EXPECT_EQ(r.spurious, 1);
  EXPECT_EQ(labelOf(r, 9).voxels, 0);
  EXPECT_EQ(labelOf(r, 9).tets, 6);
  ASSERT_EQ(r.spuriousContacts.size(), 1u);
  EXPECT_NEAR(r.spuriousContacts[0].meshArea, 6.0, 1e-9);

  NullProgress p;
  TetMesh empty;
  EXPECT_THROW_MSG(certifyMesh(empty, v, p), InputError, "no tets");
  TetMesh broken = m;
  broken.tets[0][0] = 100000;
  EXPECT_THROW(certifyMesh(broken, v, p), InputError);
}

// A 24^3 volume of 1 mm voxels against the voxel mesh of a 6^3 volume of 4 mm voxels over the
// same box: every tet's longest edge is the coarse voxel's diagonal, 4 sqrt(3) mm, so h^3 = 332.6
// mm^3 everywhere and a component is smaller than an element below 332 voxels.
TEST(Certificate, ComponentsSmallerThanAnElementAreJudgedByPresenceWithinTheirAllowance) {
  LabelVolume fine = blankVolume(24, 24, 24, 1.0, 1);
  LabelVolume coarse = blankVolume(6, 6, 6, 4.0, 1);
  coarse.grid.origin = fine.grid.origin + Vec3{1.5, 1.5, 1.5};
  const double h = 4.0 * std::sqrt(3.0), cube = h * h * h;
  fine.at(6, 6, 6) = 7;                 // a one-voxel cavity: coreless
  for (int k = 13; k <= 15; ++k)         // a 3x3x3 cube with one core voxel
    for (int j = 13; j <= 15; ++j)
      for (int i = 13; i <= 15; ++i) fine.at(i, j, k) = 8;
  for (int k = 0; k < 8; ++k)            // an 8^3 = 512-voxel block: larger than an element
    for (int j = 16; j < 24; ++j)
      for (int i = 16; i < 24; ++i) fine.at(i, j, k) = 9;
  coarse.at(1, 1, 1) = 7; // the cavity as one coarse voxel: 64 mm^3 for 1 (+6300 %)
  coarse.at(4, 4, 0) = 9; coarse.at(5, 4, 0) = 9; coarse.at(4, 5, 0) = 9; coarse.at(5, 5, 0) = 9; // 256 of 512
  coarse.at(4, 4, 1) = 9; coarse.at(5, 4, 1) = 9; coarse.at(4, 5, 1) = 9; coarse.at(5, 5, 1) = 9; // all of 512
  TetMesh m = voxelMesh(coarse);
  CertificateResult r = certify(m, fine);
  const auto& c7 = labelOf(r, 7);
  EXPECT_EQ(c7.smallComponents, 1);
  EXPECT_NEAR(c7.volumeAllowance, cube, 1e-3 * cube); // lengths summed in micrometres
  EXPECT_NEAR(c7.relError, 63.0, 1e-9);
  EXPECT_EQ(labelOf(r, 8).smallComponents, 1);
  EXPECT_EQ(labelOf(r, 8).lost, 1); // robust and absent: small does not excuse it
  EXPECT_EQ(r.spurious + r.split + r.merged, 0);
  EXPECT_EQ(labelOf(r, 9).smallComponents, 0);
  EXPECT_EQ(labelOf(r, 9).volumeAllowance, 0.0);
  EXPECT_NEAR(labelOf(r, 9).relError, 0.0, 1e-12);
  EXPECT_EQ(labelOf(r, 1).smallComponents, 0);
  // The volume check passes (label 7 is +6300 % but 63 mm^3 < h^3; label 8 is -100 % = -27 mm^3);
  // the component rule still fails on the lost cube.
  CertificateThresholds th;
  th.maxVolumeError = 0.015;
  EXPECT_TRUE(certificateFailures(r, th).empty());
  th.requireComponents = true;
  auto f = certificateFailures(r, th);
  ASSERT_EQ(f.size(), 1u);
  EXPECT_NE(f[0].find("1 lost"), std::string::npos) << f[0];
  EXPECT_NE(f[0].find("label 8, image component of 27 voxels"), std::string::npos) << f[0];
  // Without the allowance, percentages alone: label 7 is the worst.
  th.requireComponents = false;
  th.smallComponentAllowance = 0.0;
  f = certificateFailures(r, th);
  ASSERT_EQ(f.size(), 1u);
  EXPECT_NE(f[0].find("2 label(s) exceed it; worst is label 7 at +6300.00 %"), std::string::npos) << f[0];
  // An allowance smaller than the error: the message says what was allowed.
  th.smallComponentAllowance = 0.1; // 33 mm^3 < 63
  f = certificateFailures(r, th);
  ASSERT_EQ(f.size(), 1u);
  EXPECT_NE(f[0].find("1 label(s) exceed it; worst is label 7"), std::string::npos) << f[0];
  EXPECT_NE(f[0].find("allowed for its 1 component(s) smaller than an element"), std::string::npos) << f[0];
  // A big label is judged by its percentage: half of label 9 missing fails at -50 %.
  coarse.at(4, 4, 1) = 1; coarse.at(5, 4, 1) = 1; coarse.at(4, 5, 1) = 1; coarse.at(5, 5, 1) = 1;
  r = certify(voxelMesh(coarse), fine);
  th.smallComponentAllowance = 1.0;
  f = certificateFailures(r, th);
  ASSERT_EQ(f.size(), 1u);
  EXPECT_NE(f[0].find("worst is label 9 at -50.00 %"), std::string::npos) << f[0];
  Report rep;
  writeCertificateReport(r, rep);
  EXPECT_EQ(std::get<int64_t>(*rep.find("cert_label_7_small_components")), 1);
  EXPECT_NEAR(std::get<double>(*rep.find("cert_label_7_volume_allowance_mm3")), cube, 1e-3 * cube);
}

TEST(Certificate, SameResultOnOneAndTwoThreads) {
  std::mt19937 rng(7);
  const LabelVolume v = randomSegmentation(rng);
  TetMesh m = voxelMesh(v);
  for (size_t t = 0; t < m.numTets(); t += 13) m.materials[t] = 1 + int32_t(t % 3);
  const int before = omp_get_max_threads();
  omp_set_num_threads(1);
  const CertificateResult a = certify(m, v);
  omp_set_num_threads(2);
  const CertificateResult b = certify(m, v);
  omp_set_num_threads(before);
  EXPECT_EQ(a.flags, b.flags);
  EXPECT_EQ(a.componentIssues.size(), b.componentIssues.size());
  EXPECT_EQ(a.nonmanifoldEdges, b.nonmanifoldEdges);
  EXPECT_EQ(a.nonmanifoldVertices, b.nonmanifoldVertices);
  Report ra, rb;
  writeCertificateReport(a, ra);
  writeCertificateReport(b, rb);
  EXPECT_EQ(ra.entries(), rb.entries());
}

} // namespace
} // namespace tetflow
