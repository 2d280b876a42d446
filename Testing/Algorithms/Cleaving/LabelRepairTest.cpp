// Tests for Algorithms/Cleaving/LabelRepair: on cleaved random label volumes the geometry is
// untouched, forbidden contacts go (the certificate then finds no spurious contact), nothing robust
// is lost; on exact voxel meshes a stray tet island is taken back, a genuine one-voxel component is
// kept and a hole in a layer is sealed; the head phantom's broken CSF is joined; bad parameters.
#include "Algorithms/Cleaving/LabelRepair.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <set>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/Cleaving/Cleaver.h"
#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Phantom.h"
#include "Algorithms/Quality/Certificate.h"
#include "Algorithms/Quality/LabelTopology.h"
#include "Algorithms/Quality/MeshQuality.h"
#include "Fixtures/VoxelMesh.h"
#include "TestUtil.h"

namespace tetflow {
namespace {

// Blobs and one- or two-voxel sheets of 2..6 labels: thin layers that coarse lattices break.
std::shared_ptr<const LabelVolume> layeredVolume(unsigned seed) {
  std::mt19937 rng(seed);
  auto v = std::make_shared<LabelVolume>();
  GridGeometry g;
  g.dims = {14 + int64_t(rng() % 6), 14 + int64_t(rng() % 6), 12 + int64_t(rng() % 6)};
  g.origin = {double(rng() % 5), -3.0, 1.0};
  v->allocate(g, 0);
  const int labels = 2 + int(rng() % 5);
  std::uniform_real_distribution<double> u(0, 1);
  for (int b = 0; b < labels; ++b) {
    const double cx = u(rng) * g.dims[0], cy = u(rng) * g.dims[1], cz = u(rng) * g.dims[2], r = 2 + 5 * u(rng);
    const int32_t L = 1 + int32_t(rng() % labels);
    for (int64_t k = 0; k < g.dims[2]; ++k)
      for (int64_t j = 0; j < g.dims[1]; ++j)
        for (int64_t i = 0; i < g.dims[0]; ++i)
          if ((i - cx) * (i - cx) + (j - cy) * (j - cy) + (k - cz) * (k - cz) < r * r) v->at(i, j, k) = L;
  }
  for (int s = 0; s < 2; ++s) {
    const int axis = int(rng() % 3);
    const int64_t at = 2 + int64_t(rng() % (g.dims[axis] - 4)), thick = 1 + int64_t(rng() % 2);
    const int32_t L = 10 + s;
    for (int64_t k = 0; k < g.dims[2]; ++k)
      for (int64_t j = 0; j < g.dims[1]; ++j)
        for (int64_t i = 0; i < g.dims[0]; ++i) {
          const int64_t c = axis == 0 ? i : axis == 1 ? j : k;
          if (c >= at && c < at + thick) v->at(i, j, k) = L;
        }
  }
  return v;
}

TEST(LabelRepair, CleavedRandomVolumesLoseTheirForbiddenContactsAndKeepTheirGeometry) {
  NullProgress np;
  int repaired = 0;
  for (unsigned seed = 1; seed <= 24; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const auto vol = layeredVolume(seed);
    const LabelMaterials mats(vol, 1.0);
    // The repair knows the labels the cleaver sees (the materials' dominant labels; with blend
    // sigma 1 a one-voxel sheet thins there, so two labels may touch that do not in the input):
    // the certificate here compares with those.
    const LabelVolume seen = mats.dominantLabels();
    const BackgroundMesh bg = generateRegularBcc(mats.grid(), BccParams{1.5 + 0.25 * (seed % 4), 0.0}, np);
    CleaveResult r = cleave(bg, mats, CleaveParams{}, np);
    const TetMesh before = r.mesh;
    const CertificateResult c0 = certifyMesh(before, seen, np);
    const LabelRepairStats st = repairLabels(r.mesh, mats, LabelRepairParams{}, np);
    const CertificateResult c1 = certifyMesh(r.mesh, seen, np);

    // Only labels change.
    EXPECT_EQ(r.mesh.points, before.points);
    EXPECT_EQ(r.mesh.tets, before.tets);
    int64_t changed = 0;
    double changedVolume = 0.0;
    for (size_t t = 0; t < before.numTets(); ++t)
      if (r.mesh.materials[t] != before.materials[t]) {
        ++changed;
        changedVolume += r.mesh.tetVolume(t);
      }
    // A tet may be relabelled twice (contact, then fragment): counts are upper bounds.
    EXPECT_LE(changed, st.contactTets + st.connectTets + st.edgeTets + st.fragmentTets);
    EXPECT_LE(changedVolume, st.relabelledVolume + 1e-9);
    EXPECT_EQ(changed > 0, st.contactTets + st.connectTets + st.edgeTets + st.fragmentTets > 0);

    // Forbidden faces are exactly the certificate's spurious contacts.
    EXPECT_EQ(st.forbiddenFacesBefore > 0, !c0.spuriousContacts.empty());
    EXPECT_NEAR(st.forbiddenAreaBefore, c0.spuriousContactArea, 1e-6 * (1 + c0.spuriousContactArea));
    if (st.unresolvedTets == 0) {
      EXPECT_EQ(st.forbiddenFacesAfter, 0);
      EXPECT_TRUE(c1.spuriousContacts.empty());
    }
    EXPECT_LE(st.forbiddenFacesAfter, st.forbiddenFacesBefore);
    // Fragments only go: no label gains mesh components, and nothing robust is lost.
    for (const auto& lc : c1.labels) {
      for (const auto& old : c0.labels)
        if (old.label == lc.label && !lc.excluded) {
          EXPECT_LE(lc.lost, old.lost) << "label " << lc.label;
        }
    }
    repaired += st.contactTets + st.connections + st.fragments > 0 ? 1 : 0;
  }
  EXPECT_GT(repaired, 5); // the cases do exercise the repair
}

// The check, against a plain reading of its definition: at every vertex, all pairs of its tets
// (forbidden labels; face-joined groups; two groups of a label sharing an edge), and the label
// pieces through faces. On cleaved random volumes (as they come, and with some tets relabelled
// at random, which makes pieces and bad vertices of every kind), with the contacts of the image.
TEST(LabelRepair, TheCheckFindsWhatAPlainReadingOfItsRulesFinds) {
  NullProgress np;
  int withExtra = 0, withBad = 0, clean = 0;
  for (unsigned seed = 1; seed <= 30; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    // Every fifth a ball in a shell (nothing to repair, as a smooth organ).
    auto vol = layeredVolume(seed);
    if (seed % 5 == 0) {
      auto ball = std::make_shared<LabelVolume>();
      ball->allocate(vol->grid, 0);
      const auto& d = vol->grid.dims;
      for (int64_t k = 0; k < d[2]; ++k)
        for (int64_t j = 0; j < d[1]; ++j)
          for (int64_t i = 0; i < d[0]; ++i) {
            const double r = std::hypot(i - d[0] / 2.0, j - d[1] / 2.0, k - d[2] / 2.0);
            ball->at(i, j, k) = r < 3.0 + 0.2 * seed ? 2 : r < 6.0 ? 1 : 0;
          }
      vol = ball;
    }
    const LabelMaterials mats(vol, 0.5);
    const BackgroundMesh bg = generateRegularBcc(mats.grid(), BccParams{1.5 + 0.5 * (seed % 3), 0.0}, np);
    TetMesh mesh = cleave(bg, mats, CleaveParams{}, np).mesh;
    std::mt19937 rng(seed);
    if (seed % 5 != 0 && seed % 3 == 1) {
      // Not only unmixed labels: relabel a few tets to labels of the volume.
      std::vector<int32_t> used(mesh.materials.begin(), mesh.materials.end());
      std::sort(used.begin(), used.end());
      used.erase(std::unique(used.begin(), used.end()), used.end());
      for (int i = 0; i < 1 + int(seed % 7); ++i)
        mesh.materials[rng() % mesh.numTets()] = used[rng() % used.size()];
    } else if (seed % 5 != 0 && seed % 3 == 2) {
      repairLabels(mesh, mats, LabelRepairParams{}, np);
    }
    const auto contacts = labelContactPairs(*vol);
    const LabelRepairCheck check = checkLabelRepair(mesh, contacts, np);

    auto touch = [&](int32_t a, int32_t b) {
      return a == b || std::binary_search(contacts.begin(), contacts.end(), std::pair{std::min(a, b), std::max(a, b)});
    };
    auto shared = [&](int32_t a, int32_t b) {
      int n = 0;
      for (int32_t x : mesh.tets[size_t(a)])
        for (int32_t y : mesh.tets[size_t(b)]) n += x == y;
      return n;
    };
    const VertexStars stars = vertexStars(mesh);
    std::vector<int32_t> bad;
    for (size_t v = 0; v + 1 < stars.offset.size(); ++v) {
      const std::vector<int32_t> s(stars.tets.begin() + stars.offset[v], stars.tets.begin() + stars.offset[v + 1]);
      const size_t k = s.size();
      bool isBad = false, mixed = false;
      DisjointSets groups(k);
      for (size_t a = 0; a < k; ++a)
        for (size_t b = a + 1; b < k; ++b) {
          const int32_t la = mesh.materials[size_t(s[a])], lb = mesh.materials[size_t(s[b])];
          mixed = mixed || la != lb;
          isBad = isBad || !touch(la, lb);
          if (la == lb && shared(s[a], s[b]) == 3) groups.unite(int32_t(a), int32_t(b));
        }
      for (size_t a = 0; a < k; ++a)
        for (size_t b = a + 1; b < k; ++b)
          if (mesh.materials[size_t(s[a])] == mesh.materials[size_t(s[b])] &&
              groups.find(int32_t(a)) != groups.find(int32_t(b)) && shared(s[a], s[b]) >= 2)
            isBad = true;
      if (mixed && isBad) bad.push_back(int32_t(v));
    }
    EXPECT_EQ(check.badVertices, bad);

    const std::vector<int32_t> nb = tetFaceNeighbours(mesh, np);
    DisjointSets pieces = sameLabelPieces(mesh, nb);
    std::map<int32_t, std::vector<int32_t>> tetsOf; // piece root (its smallest tet) -> tets
    for (size_t t = 0; t < mesh.numTets(); ++t) tetsOf[pieces.find(int32_t(t))].push_back(int32_t(t));
    std::map<int32_t, int32_t> largest; // label -> root
    for (const auto& [root, tets] : tetsOf) {
      auto [it, fresh] = largest.try_emplace(mesh.materials[size_t(root)], root);
      if (!fresh && tets.size() > tetsOf[it->second].size()) it->second = root;
    }
    std::vector<std::vector<int32_t>> small;
    bool extra = false, large = false;
    for (const auto& [root, tets] : tetsOf) {
      if (largest[mesh.materials[size_t(root)]] == root) continue;
      extra = true;
      if (tets.size() <= 16) small.push_back(tets);
      else large = true;
    }
    EXPECT_EQ(check.extraPieces, extra);
    EXPECT_EQ(check.largeExtraPieces, large);
    EXPECT_EQ(check.smallPieces, small);
    EXPECT_EQ(check.needed(), labelRepairNeeded(mesh, contacts, np));
    withExtra += extra;
    withBad += !bad.empty();
    clean += !extra && bad.empty();
  }
  // The cases cover each answer.
  EXPECT_GE(withExtra, 5);
  EXPECT_GE(withBad, 5);
  EXPECT_GE(clean, 3);
}

TEST(LabelRepair, AStrayIslandGoesBackAndAGenuineVoxelStays) {
  LabelVolume v;
  GridGeometry g;
  g.dims = {9, 7, 7};
  v.allocate(g, 1);
  for (int64_t k = 0; k < 7; ++k)
    for (int64_t j = 0; j < 7; ++j)
      for (int64_t i = 5; i < 9; ++i) v.at(i, j, k) = 2;
  v.at(2, 3, 3) = 3; // a genuine one-voxel component of label 3 inside label 1
  TetMesh m = test::voxelMesh(v);
  const auto vol = std::make_shared<const LabelVolume>(v);
  const LabelMaterials mats(vol, 0.5);
  // A stray island: one voxel of label 2 deep inside label 1 (1 and 2 do touch in the image).
  test::relabelVoxel(v, m, 2, 1, 5, 2);
  const TetMesh before = m;
  NullProgress np;
  LabelRepairParams p;
  p.fragment_voxels = 2.0; // both the island and the genuine voxel are below it
  const LabelRepairStats st = repairLabels(m, mats, p, np);
  EXPECT_EQ(st.forbiddenFacesBefore, 0);
  EXPECT_EQ(st.fragments, 1);
  EXPECT_EQ(st.fragmentTets, 6);
  for (size_t t = test::firstTet(v, 2, 1, 5); t < test::firstTet(v, 2, 1, 5) + 6; ++t) EXPECT_EQ(m.materials[t], 1);
  for (size_t t = test::firstTet(v, 2, 3, 3); t < test::firstTet(v, 2, 3, 3) + 6; ++t) EXPECT_EQ(m.materials[t], 3);
  // Now the image mesh itself has nothing to repair.
  TetMesh exact = test::voxelMesh(v);
  const LabelRepairStats none = repairLabels(exact, mats, p, np);
  EXPECT_EQ(none.contactTets + none.fragments, 0);
  EXPECT_EQ(exact.materials, test::voxelMesh(v).materials);
}

// A component without a core (a rod one voxel thick) may be lost but not split: when cleaving
// broke it into two pieces that no step joins, the one that is not primary goes, however large,
// and the certificate finds no split. A piece of a component with a core stays (found on the
// layered head at 2 mm: a 7-voxel CSF rod in two pieces of more than a voxel each).
TEST(LabelRepair, ACorelessComponentIsNotLeftInPieces) {
  LabelVolume v;
  GridGeometry g;
  g.dims = {12, 7, 7};
  v.allocate(g, 1);
  for (int64_t i = 2; i < 10; ++i) v.at(i, 3, 3) = 3; // the rod: 8 voxels, no core
  for (int64_t i = 2; i < 10; ++i)                      // a 3x3 bar with a core
    for (int64_t j = 0; j < 3; ++j)
      for (int64_t k = 4; k < 7; ++k) v.at(i, j, k) = 4;
  TetMesh m = test::voxelMesh(v);
  for (int64_t i : {5, 6}) {
    test::relabelVoxel(v, m, i, 3, 3, 1); // the rod in two pieces of 3 voxels
    for (int64_t j = 0; j < 3; ++j)
      for (int64_t k = 4; k < 7; ++k) test::relabelVoxel(v, m, i, j, k, 1); // the bar in two of 9
  }
  const auto vol = std::make_shared<const LabelVolume>(v);
  const LabelMaterials mats(vol, 0.5);
  NullProgress np;
  LabelRepairParams p;
  p.connect = false; // the fragments step alone
  p.edges = false;
  const LabelRepairStats st = repairLabels(m, mats, p, np);
  EXPECT_EQ(st.fragments, 1);
  EXPECT_EQ(st.fragmentTets, 18);
  const CertificateResult c = certifyMesh(m, *vol, np);
  for (const auto& lc : c.labels) {
    if (lc.label == 3) {
      EXPECT_EQ(lc.meshComponents, 1);
      EXPECT_EQ(lc.split, 0);
    }
    if (lc.label == 4) {
      EXPECT_EQ(lc.meshComponents, 2); // a piece of 9 voxels of a 24-voxel component stays
      EXPECT_EQ(lc.split, 1);
    }
  }
}

// A piece of a component with a core that no one- or two-tet path reaches (found on a 99-label
// atlas at 1.5 mm: parcels joined in the image only through voxel edges) is joined by a chain of up
// to six tets of other labels, the least volume first: here a bar cut through by two voxels'
// worth of another label, where the image has the bar whole. The chain lies in the cut, the
// certificate finds one piece, and a bar whose cut is wider than a chain reaches stays in two.
TEST(LabelRepair, APieceNoShortPathReachesIsJoinedByAChain) {
  for (const int64_t cut : {2, 4}) {
    LabelVolume v;
    GridGeometry g;
    g.dims = {14, 7, 7};
    v.allocate(g, 1);
    for (int64_t i = 2; i < 12; ++i)
      for (int64_t j = 0; j < 3; ++j)
        for (int64_t k = 4; k < 7; ++k) v.at(i, j, k) = 4;
    TetMesh m = test::voxelMesh(v);
    for (int64_t i = 5; i < 5 + cut; ++i)
      for (int64_t j = 0; j < 3; ++j)
        for (int64_t k = 4; k < 7; ++k) test::relabelVoxel(v, m, i, j, k, 1);
    const TetMesh before = m;
    const auto vol = std::make_shared<const LabelVolume>(v);
    const LabelMaterials mats(vol, 0.5);
    NullProgress np;
    const LabelRepairStats st = repairLabels(m, mats, LabelRepairParams{}, np);
    EXPECT_EQ(m.points, before.points);
    EXPECT_EQ(m.tets, before.tets);
    const CertificateResult c = certifyMesh(m, *vol, np);
    for (const auto& lc : c.labels)
      if (lc.label == 4) {
        EXPECT_EQ(lc.meshComponents, cut == 2 ? 1 : 2) << "cut " << cut;
        EXPECT_EQ(lc.split, cut == 2 ? 0 : 1) << "cut " << cut;
      }
    if (cut == 2) {
      EXPECT_GE(st.chainConnections, 1);
      // The chain, and what the edges step and the pass after it change around it: a few of the
      // cut's 108 tets, all in the cut, all taking the bar's label.
      size_t changed = 0;
      for (size_t t = 0; t < m.numTets(); ++t)
        if (m.materials[t] != before.materials[t]) {
          ++changed;
          const Vec3 x = tetCentroid(m, t);
          EXPECT_EQ(m.materials[t], 4);
          // (voxel i spans [i - 0.5, i + 0.5])
          EXPECT_TRUE(x[0] > 4.5 && x[0] < 4.5 + double(cut)) << "tet " << t << " at x " << x[0];
        }
      EXPECT_GE(changed, 3u);
      EXPECT_LE(changed, 16u);
    } else {
      EXPECT_EQ(st.chainConnections, 0);
    }
  }
}

// A fragment no neighbouring label may take: a speck of brain in the skull layer between a tongue
// of scalp and a bulge of the CSF (scalp and CSF never touch). It takes the label the image
// favours there among those allowed next to all its neighbours (skull), and a least-volume chain
// of tets to the skull takes it too, so it is no island (found on the particle net, seed 4).
TEST(LabelRepair, AFragmentNoNeighbourMayTakeGoesToTheLayerItLiesIn) {
  LabelVolume v; // slabs along x: scalp 0-2 | skull 3-5 | CSF 6-8 | brain 9-11
  GridGeometry g;
  g.dims = {12, 7, 7};
  v.allocate(g, 1);
  for (int64_t k = 0; k < 7; ++k)
    for (int64_t j = 0; j < 7; ++j)
      for (int64_t i = 3; i < 12; ++i) v.at(i, j, k) = i < 6 ? 2 : i < 9 ? 3 : 4;
  LabelVolume w = v; // the mesh's labels
  w.at(5, 3, 3) = 4;                  // the speck
  w.at(3, 3, 3) = w.at(4, 3, 3) = 1;  // the scalp's tongue
  for (const auto& [j, k] : std::vector<std::pair<int64_t, int64_t>>{{2, 3}, {4, 3}, {3, 2}, {3, 4}})
    w.at(5, j, k) = 3; // the CSF's bulge
  TetMesh m = test::voxelMesh(w);
  const auto vol = std::make_shared<const LabelVolume>(v);
  const LabelMaterials mats(vol, 0.5);
  NullProgress np;
  LabelRepairParams p;
  p.contacts = p.points = p.connect = p.edges = false; // the fragments step alone
  const TetMesh before = m;
  const LabelRepairStats st = repairLabels(m, mats, p, np);
  EXPECT_EQ(st.fragments, 1);
  EXPECT_EQ(st.fragmentChains, 1);
  EXPECT_EQ(st.fragmentTets, 6);
  EXPECT_GE(st.fragmentChainTets, 1);
  EXPECT_LE(st.fragmentChainTets, 6);
  EXPECT_EQ(st.keptSmallPieces, 0);
  for (size_t t = test::firstTet(w, 5, 3, 3); t < test::firstTet(w, 5, 3, 3) + 6; ++t) EXPECT_EQ(m.materials[t], 2);
  for (size_t t = 0; t < m.numTets(); ++t)
    if (m.materials[t] != before.materials[t]) {
      EXPECT_EQ(m.materials[t], 2);
    }
  // Brain and skull are each one piece, and the speck's brain no longer touches the scalp.
  const std::vector<int32_t> nb = tetFaceNeighbours(m, np);
  DisjointSets sets = sameLabelPieces(m, nb);
  std::map<int32_t, std::set<int32_t>> pieces;
  for (size_t t = 0; t < m.numTets(); ++t) pieces[m.materials[t]].insert(sets.find(int32_t(t)));
  EXPECT_EQ(pieces[2].size(), 1u);
  EXPECT_EQ(pieces[4].size(), 1u);
  for (size_t t = 0; t < m.numTets(); ++t)
    for (int f = 0; f < 4; ++f) {
      const int32_t o = nb[4 * t + size_t(f)];
      if (o >= 0 && m.materials[t] == 4) {
        EXPECT_NE(m.materials[size_t(o)], 1) << "tet " << t;
      }
    }
}

TEST(LabelRepair, AForbiddenFaceIsRelabelledToTheLayerBetween) {
  // Slabs 1 | 3 | 2 along x (3 one voxel thick): 1 and 2 never touch.
  LabelVolume v;
  GridGeometry g;
  g.dims = {7, 4, 4};
  v.allocate(g, 1);
  for (int64_t k = 0; k < 4; ++k)
    for (int64_t j = 0; j < 4; ++j) {
      v.at(3, j, k) = 3;
      for (int64_t i = 4; i < 7; ++i) v.at(i, j, k) = 2;
    }
  TetMesh m = test::voxelMesh(v);
  // A hole in the layer: its voxel (3,1,1) is labelled 2 in the mesh, so 1 touches 2.
  test::relabelVoxel(v, m, 3, 1, 1, 2);
  const auto vol = std::make_shared<const LabelVolume>(v);
  const LabelMaterials mats(vol, 0.5);
  NullProgress np;
  LabelRepairParams p;
  p.fragments = false;
  const LabelRepairStats st = repairLabels(m, mats, p, np);
  EXPECT_GT(st.forbiddenFacesBefore, 0);
  EXPECT_NEAR(st.forbiddenAreaBefore, 1.0, 1e-9); // one voxel face
  EXPECT_EQ(st.forbiddenFacesAfter, 0);
  EXPECT_EQ(st.unresolvedTets, 0);
  EXPECT_GT(st.contactTets, 0);
  for (size_t t = test::firstTet(v, 3, 1, 1); t < test::firstTet(v, 3, 1, 1) + 6; ++t)
    if (m.materials[t] != 2) {
      EXPECT_EQ(m.materials[t], 3);
    }
  const CertificateResult c = certifyMesh(m, *vol, np);
  EXPECT_TRUE(c.spuriousContacts.empty());
}

TEST(LabelRepair, BadParametersAreRefused) {
  LabelVolume v;
  GridGeometry g;
  g.dims = {3, 3, 3};
  v.allocate(g, 1);
  TetMesh m = test::voxelMesh(v);
  const LabelMaterials mats(std::make_shared<const LabelVolume>(v), 1.0);
  NullProgress np;
  LabelRepairParams p;
  p.fragment_voxels = -1;
  EXPECT_THROW_MSG(repairLabels(m, mats, p, np), InputError, "fragment_voxels");
}

} // namespace
} // namespace tetflow

namespace tetflow {
namespace {
// The head phantom at 4 mm voxels (CSF one voxel thick), its materials at `sigma`, cleaved on an
// 8 mm lattice with the air stripped.
struct CoarseHead {
  std::shared_ptr<const LabelVolume> vol;
  LabelMaterials mats;
  CleaveResult r;
};
CoarseHead cleaveCoarseHead(double sigma) {
  PhantomParams pp;
  pp.voxel_size = 4.0;
  pp.radius = 92;
  pp.skull_radius = 84;
  pp.csf_radius = 76;
  pp.brain_radius = 72;
  auto vol = std::make_shared<const LabelVolume>(makePhantom(pp).volume);
  LabelMaterials mats(vol, sigma);
  NullProgress np;
  const BackgroundMesh bg = generateRegularBcc(mats.grid(), BccParams{8.0, 0.0}, np);
  CleaveParams cp;
  cp.strip_exterior = 0;
  CleaveResult r = cleave(bg, mats, cp, np);
  return {vol, std::move(mats), std::move(r)};
}

// The head phantom at 4 mm voxels: its CSF is one voxel thick, so a lattice of two voxels breaks it
// into patches and lets brain touch skull. The repair removes the contact and joins the patches.
TEST(LabelRepair, TheHeadPhantomsBrokenCsfIsJoinedAndSealed) {
  CoarseHead h = cleaveCoarseHead(1.0);
  const auto& vol = h.vol;
  const LabelMaterials& mats = h.mats;
  CleaveResult& r = h.r;
  NullProgress np;
  const CertificateResult before = certifyMesh(r.mesh, *vol, np);
  const LabelRepairStats st = repairLabels(r.mesh, mats, LabelRepairParams{}, np);
  const CertificateResult after = certifyMesh(r.mesh, *vol, np);
  const auto csf = [](const CertificateResult& c) {
    for (const auto& lc : c.labels)
      if (lc.label == 3) return lc;
    return LabelCertificate{};
  };
  EXPECT_GT(st.connections, 0);
  EXPECT_GT(st.closedEdges, 0);
  EXPECT_LT(after.nonmanifoldEdges, before.nonmanifoldEdges);
  // Measured: CSF pieces 86 -> 1, volume error -68.2 % -> -39.5 %, contact 21 449 -> 0 mm^2,
  // non-manifold interface edges 216 -> 8.
  EXPECT_EQ(csf(after).meshComponents, 1);
  EXPECT_LE(after.nonmanifoldEdges * 10, before.nonmanifoldEdges);
  EXPECT_GT(before.spuriousContactArea, 0.0);
  EXPECT_EQ(after.spuriousContactArea, 0.0);
  EXPECT_GT(csf(after).relError, csf(before).relError); // the CSF gains volume
  for (const auto& lc : after.labels)
    if (lc.label != 3 && !lc.excluded) {
      EXPECT_EQ(lc.meshComponents, 1) << "label " << lc.label;
    }
}

// Point contacts: brain and skull tets that share only a vertex or an edge through a pinched CSF.
TEST(LabelRepair, PointContactsAreSealedWhenAsked) {
  const CoarseHead h = cleaveCoarseHead(0.5);
  const auto& vol = h.vol;
  const LabelMaterials& mats = h.mats;
  const CleaveResult& r = h.r;
  NullProgress np;
  // Vertices whose tets carry brain (4) and skull (2), which never touch in the image.
  const auto pinched = [](const TetMesh& m) {
    std::vector<uint8_t> brain(m.numPoints(), 0), skull(m.numPoints(), 0);
    for (size_t t = 0; t < m.numTets(); ++t)
      for (int32_t v : m.tets[t]) {
        if (m.materials[t] == 4) brain[size_t(v)] = 1;
        if (m.materials[t] == 2) skull[size_t(v)] = 1;
      }
    int64_t n = 0;
    for (size_t v = 0; v < m.numPoints(); ++v) n += brain[v] && skull[v] ? 1 : 0;
    return n;
  };
  TetMesh plain = r.mesh, sealed = r.mesh;
  repairLabels(plain, mats, LabelRepairParams{}, np);
  LabelRepairParams withPoints;
  withPoints.points = true;
  const LabelRepairStats st = repairLabels(sealed, mats, withPoints, np);
  EXPECT_GT(pinched(plain), 0);
  EXPECT_GT(st.pointContacts, 0);
  EXPECT_LE(pinched(sealed) * 20, pinched(plain));
  const CertificateResult a = certifyMesh(plain, *vol, np), b = certifyMesh(sealed, *vol, np);
  EXPECT_LT(b.nonmanifoldVertices, a.nonmanifoldVertices);
  EXPECT_TRUE(b.spuriousContacts.empty());
  EXPECT_EQ(b.split + b.lost + b.merged + b.spurious, 0);
}
} // namespace
} // namespace tetflow
