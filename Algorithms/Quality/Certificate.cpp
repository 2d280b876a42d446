#include "Certificate.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <unordered_map>

#include "Algorithms/Core/CancellableSort.h"
#include "Algorithms/Core/Errors.h"
#include "LabelTopology.h"
#include "TetQuality.h"
#include "VoxelOwners.h"

namespace tetflow {

namespace {

constexpr double kExcludedCoverage = 0.01;

} // namespace

const char* componentIssueName(ComponentIssueKind k) {
  switch (k) {
    case ComponentIssueKind::Lost: return "lost";
    case ComponentIssueKind::LostSmall: return "lost_small";
    case ComponentIssueKind::Split: return "split";
    case ComponentIssueKind::Merged: return "merged";
    case ComponentIssueKind::Spurious: return "spurious";
  }
  return "?";
}

std::string describePlace(const Place& p) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "(%.1f, %.1f, %.1f) mm, box [%.1f..%.1f, %.1f..%.1f, %.1f..%.1f]",
                p.centroid[0], p.centroid[1], p.centroid[2], p.boxMin[0], p.boxMax[0], p.boxMin[1],
                p.boxMax[1], p.boxMin[2], p.boxMax[2]);
  return buf;
}

CertificateResult certifyMesh(const TetMesh& mesh, const LabelVolume& labels, Progress& progress) {
  mesh.validateStructure("mesh");
  if (mesh.numTets() == 0) throw InputError("the mesh has no tets: nothing to certify");
  if (labels.grid.voxelCount() <= 0 || labels.data.size() != size_t(labels.grid.voxelCount()))
    throw InputError("the label volume is empty or its data does not match its dims");
  if (mesh.numTets() >= size_t(std::numeric_limits<int32_t>::max()) / 4)
    throw InputError("mesh of " + std::to_string(mesh.numTets()) + " tets is too large for the certificate");
  const auto& g = labels.grid;
  const int64_t nx = g.dims[0], ny = g.dims[1];
  const int64_t nTets = static_cast<int64_t>(mesh.numTets());

  progress.beginStage("image");
  LabelImageTopology img = analyzeLabelImage(labels, progress);

  progress.beginStage("mesh");
  const std::vector<int32_t> nb = tetFaceNeighbours(mesh, progress);
  progress.checkCancel();
  DisjointSets meshSets = sameLabelPieces(mesh, nb);
  progress.checkCancel();
  struct MeshComponent {
    int32_t label = 0;
    int64_t tets = 0;
    PlaceAcc where; // tet centroids weighted by volume; box of the centroids
  };
  std::vector<int32_t> meshComp(mesh.numTets());
  std::vector<MeshComponent> mcomps;
  {
    std::vector<int32_t> rootComp(mesh.numTets(), -1);
    for (int64_t t = 0; t < nTets; ++t) {
      progress.checkCancelEvery(t);
      const int32_t r = meshSets.find(static_cast<int32_t>(t));
      int32_t& c = rootComp[static_cast<size_t>(r)];
      if (c < 0) {
        c = static_cast<int32_t>(mcomps.size());
        mcomps.push_back({});
        mcomps.back().label = mesh.materials[static_cast<size_t>(t)];
      }
      meshComp[static_cast<size_t>(t)] = c;
      auto& mc = mcomps[static_cast<size_t>(c)];
      ++mc.tets;
      mc.where.add(tetCentroid(mesh, size_t(t)), std::abs(mesh.tetVolume(size_t(t))));
    }
  }
  std::map<uint64_t, std::pair<double, PlaceAcc>> meshContacts;
  for (int64_t t = 0; t < nTets; ++t) {
    progress.checkCancelEvery(t);
    for (int f = 0; f < 4; ++f) {
      const int32_t o = nb[static_cast<size_t>(4 * t + f)];
      if (o <= t) continue;
      const int32_t a = mesh.materials[static_cast<size_t>(t)], b = mesh.materials[static_cast<size_t>(o)];
      if (a == b) continue;
      Vec3 c;
      const double area = tetFaceArea(mesh, size_t(t), f, &c);
      auto& e = meshContacts[labelPairKey(a, b)];
      e.first += area;
      e.second.add(c, area);
    }
  }
  progress.checkCancel();

  // --- rasterise: the tet containing each voxel centre (smallest index on shared faces) -------
  progress.beginStage("match");
  // Voxel centres in the mesh (covered) and in tets of their own label (agree), per image
  // component.
  const size_t nComps = img.comps.size();
  std::vector<int64_t> coveredComp(nComps, 0), agreeComp(nComps, 0);
  // The local element size of each image component: the mean longest edge (mm) of the tets that
  // hold its voxel centres, whatever their label (a lost component's are the other labels' tets).
  // Summed in whole micrometres so the sums do not depend on the thread count.
  std::vector<int32_t> edgeMicrons(mesh.numTets());
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < nTets; ++t) {
    const auto& q = mesh.tets[size_t(t)];
    const double m = longestEdge(mesh.points[size_t(q[0])], mesh.points[size_t(q[1])], mesh.points[size_t(q[2])],
                                 mesh.points[size_t(q[3])]);
    edgeMicrons[size_t(t)] = int32_t(std::min(std::llround(m * 1e3), 2000000000LL));
  }
  std::vector<int64_t> edgeSumComp(nComps, 0);
  const size_t threads = static_cast<size_t>(omp_get_max_threads());
  std::vector<std::vector<int64_t>> cov(threads), agr(threads);
  std::vector<std::vector<int64_t>> edg(threads);
  const VoxelOwners owners(mesh, g, progress, [&](int me, int64_t v, int32_t t, int w) {
    auto& c = cov[size_t(me)];
    auto& a = agr[size_t(me)];
    auto& e = edg[size_t(me)];
    if (c.empty()) {
      c.assign(nComps, 0);
      a.assign(nComps, 0);
      e.assign(nComps, 0);
    }
    const size_t comp = static_cast<size_t>(img.comp[size_t(v)]);
    c[comp] += w;
    e[comp] += int64_t(w) * edgeMicrons[size_t(t)];
    if (mesh.materials[size_t(t)] == labels.data[size_t(v)]) a[comp] += w;
  });
  for (size_t th = 0; th < threads; ++th)
    for (size_t c = 0; c < cov[th].size(); ++c) {
      coveredComp[c] += cov[th][c];
      agreeComp[c] += agr[th][c];
      edgeSumComp[c] += edg[th][c];
    }
  std::vector<std::vector<int64_t>>().swap(cov);
  std::vector<std::vector<int64_t>>().swap(agr);
  std::vector<std::vector<int64_t>>().swap(edg);
  std::vector<int32_t>().swap(edgeMicrons);
  const std::vector<Vec3>& ip = owners.indexPoints();

  // --- votes: every tet for the image component of its label at / next to its centroid -------
  std::vector<int32_t> vote(mesh.numTets(), -1);
  std::vector<int32_t> centroidVoxelComp(mesh.numTets(), -1);
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < nTets; ++t) {
    const auto& q = mesh.tets[static_cast<size_t>(t)];
    const Vec3 c = 0.25 * (ip[size_t(q[0])] + ip[size_t(q[1])] + ip[size_t(q[2])] + ip[size_t(q[3])]);
    int64_t r[3];
    for (int a = 0; a < 3; ++a)
      r[a] = std::clamp<int64_t>(static_cast<int64_t>(std::llround(c[a])), 0, g.dims[a] - 1);
    const int64_t v = r[0] + nx * (r[1] + ny * r[2]);
    centroidVoxelComp[static_cast<size_t>(t)] = img.comp[static_cast<size_t>(v)];
    vote[static_cast<size_t>(t)] = voteImageComponent(labels, img.comp, c, mesh.materials[static_cast<size_t>(t)]);
  }
  // Stripped exteriors: a label whose components reaching the box got (almost) no tets voting for
  // them had its exterior removed (CleaveMesh strip_exterior, or another tool); those components
  // are left out of every comparison, its cavities are compared.
  std::vector<uint8_t> strippedComp(img.comps.size(), 0);
  std::map<int32_t, int64_t> strippedVoxels;
  {
    std::map<int32_t, std::pair<double, double>> boxVotes; // label -> (voted volume, voxel volume)
    for (const auto& c : img.comps)
      if (c.touchesBox) boxVotes[c.label].second += double(c.voxels) * g.voxelVolume();
    std::vector<double> votedVolume(img.comps.size(), 0.0);
    for (int64_t t = 0; t < nTets; ++t)
      if (vote[size_t(t)] >= 0) votedVolume[size_t(vote[size_t(t)])] += std::abs(mesh.tetVolume(size_t(t)));
    for (size_t c = 0; c < img.comps.size(); ++c)
      if (img.comps[c].touchesBox) boxVotes[img.comps[c].label].first += votedVolume[c];
    std::map<int32_t, bool> labelHasTets;
    for (int64_t t = 0; t < nTets; ++t) labelHasTets[mesh.materials[size_t(t)]] = true;
    // Candidates: the box components of labels with tets whose box components got (almost) no
    // votes.
    for (size_t c = 0; c < img.comps.size(); ++c) {
      const auto& ic = img.comps[c];
      if (!ic.touchesBox || !labelHasTets[ic.label]) continue; // a label with no tets: see "excluded"
      const auto& bv = boxVotes[ic.label];
      if (bv.first <= kExcludedCoverage * bv.second) strippedComp[c] = 1;
    }
    // A stripped exterior lies (mostly) outside the mesh; a box component that the mesh lost (other
    // labels' tets over its voxels) was not stripped. Voxel centres in a tet, per candidate label.
    if (std::find(strippedComp.begin(), strippedComp.end(), 1) != strippedComp.end()) {
      std::map<int32_t, std::pair<int64_t, int64_t>> boxInside; // label -> (inside, voxels)
      for (size_t c = 0; c < nComps; ++c) {
        if (!strippedComp[c]) continue;
        auto& bi = boxInside[img.comps[c].label];
        bi.first += coveredComp[c];
        bi.second += img.comps[c].voxels;
      }
      for (size_t c = 0; c < img.comps.size(); ++c) {
        if (!strippedComp[c]) continue;
        const auto& bi = boxInside[img.comps[c].label];
        if (2 * bi.first > bi.second) strippedComp[c] = 0;
        else strippedVoxels[img.comps[c].label] += img.comps[c].voxels;
      }
    }
  }
  if (!strippedVoxels.empty()) {
    // The image's contacts without the stripped voxels.
    img.contacts.clear();
    const double faceArea[3] = {g.spacing[1] * g.spacing[2], g.spacing[0] * g.spacing[2], g.spacing[0] * g.spacing[1]};
    const int64_t nz = g.dims[2];
    for (int64_t k = 0; k < nz; ++k)
      for (int64_t j = 0; j < ny; ++j)
        for (int64_t i = 0; i < nx; ++i) {
          const int64_t v = i + nx * (j + ny * k);
          if (strippedComp[size_t(img.comp[size_t(v)])]) continue;
          const int32_t a = labels.data[size_t(v)];
          for (int ax = 0; ax < 3; ++ax) {
            const int64_t d[3] = {ax == 0, ax == 1, ax == 2};
            if (i + d[0] >= nx || j + d[1] >= ny || k + d[2] >= nz) continue;
            const int64_t w = v + d[0] + nx * (d[1] + ny * d[2]);
            const int32_t b = labels.data[size_t(w)];
            if (a == b || strippedComp[size_t(img.comp[size_t(w)])]) continue;
            auto& e = img.contacts[labelPairKey(a, b)];
            e.first += faceArea[ax];
            e.second.add(g.indexToPhysical(double(i) + 0.5 * double(d[0]), double(j) + 0.5 * double(d[1]),
                                           double(k) + 0.5 * double(d[2])),
                         faceArea[ax]);
          }
        }
    progress.checkCancel();
  }

  // Labels: per label figures from voxels and tets.
  CertificateResult res;
  res.names = labels.labelNames;
  for (const auto& [L, n] : mesh.materialNames) res.names[L] = n;
  std::map<int32_t, LabelCertificate> byLabel;
  std::map<int32_t, int64_t> covered; // voxel centres inside the mesh, per image label
  std::map<int32_t, int64_t> agree;
  for (size_t c = 0; c < nComps; ++c) {
    const int32_t L = img.comps[c].label;
    auto& lc = byLabel[L];
    if (strippedComp[c]) continue; // counted in strippedVoxels
    lc.voxels += img.comps[c].voxels;
    covered[L] += coveredComp[c];
    agree[L] += agreeComp[c];
  }
  for (int64_t t = 0; t < nTets; ++t) {
    auto& lc = byLabel[mesh.materials[static_cast<size_t>(t)]];
    ++lc.tets;
    lc.meshVolume += mesh.tetVolume(size_t(t));
  }
  std::map<int32_t, bool> excluded;
  int64_t agreeAll = 0, voxAll = 0;
  for (auto& [L, lc] : byLabel) {
    lc.label = L;
    lc.voxelVolume = double(lc.voxels) * g.voxelVolume();
    lc.strippedVoxels = strippedVoxels.count(L) ? strippedVoxels[L] : 0;
    lc.strippedVolume = double(lc.strippedVoxels) * g.voxelVolume();
    if (lc.strippedVoxels > 0) res.strippedLabels.push_back(L);
    lc.excluded = lc.tets == 0 && lc.voxels > 0 && double(covered[L]) <= kExcludedCoverage * double(lc.voxels);
    excluded[L] = lc.excluded;
    if (lc.excluded) {
      res.excludedLabels.push_back(L);
      continue;
    }
    lc.absError = lc.meshVolume - lc.voxelVolume;
    lc.relError = lc.voxels > 0 ? lc.absError / lc.voxelVolume : 0.0;
    lc.agreement = lc.voxels > 0 ? double(agree[L]) / double(lc.voxels) : 0.0;
    agreeAll += agree[L];
    voxAll += lc.voxels;
    if (lc.voxels > 0 && std::abs(lc.relError) > std::abs(res.worstRelError)) {
      res.worstRelError = lc.relError;
      res.worstLabel = L;
    }
  }
  res.agreement = voxAll > 0 ? double(agreeAll) / double(voxAll) : 0.0;
  for (size_t c = 0; c < img.comps.size(); ++c) {
    if (strippedComp[c]) continue;
    auto& lc = byLabel[img.comps[c].label];
    ++lc.imageComponents;
    if (img.comps[c].cores > 0) ++lc.robustComponents;
    // Smaller than an element: its volume below h^3, h its local element size.
    if (coveredComp[c] <= 0) continue;
    const double h = 1e-3 * double(edgeSumComp[c]) / double(coveredComp[c]);
    const double cube = h * h * h;
    if (double(img.comps[c].voxels) * g.voxelVolume() < cube) {
      ++lc.smallComponents;
      lc.volumeAllowance += cube;
    }
  }
  for (const auto& c : mcomps) ++byLabel[c.label].meshComponents;

  progress.checkCancel();
  std::unordered_map<uint64_t, double> overlap; // (mesh comp, image comp) -> volume
  for (int64_t t = 0; t < nTets; ++t) {
    const int32_t c = vote[static_cast<size_t>(t)];
    if (c < 0) continue;
    overlap[(uint64_t(uint32_t(meshComp[size_t(t)])) << 32) | uint32_t(c)] += std::abs(mesh.tetVolume(size_t(t)));
  }
  // Deterministic order for the lists below.
  std::vector<std::pair<uint64_t, double>> ov(overlap.begin(), overlap.end());
  std::sort(ov.begin(), ov.end());
  std::vector<std::vector<std::pair<int32_t, double>>> piecesOf(img.comps.size()); // mesh comps
  std::vector<std::vector<int32_t>> imageOf(mcomps.size());                          // image comps
  for (const auto& [k, vol] : ov) {
    const int32_t m = static_cast<int32_t>(k >> 32), c = static_cast<int32_t>(uint32_t(k));
    piecesOf[size_t(c)].push_back({m, vol});
    imageOf[size_t(m)].push_back(c);
  }

  res.flags.assign(mesh.numTets(), 0);
  std::vector<int32_t> meshFlag(mcomps.size(), 0);
  std::vector<uint8_t> lostComp(img.comps.size(), 0);
  for (size_t c = 0; c < img.comps.size(); ++c) {
    const auto& ic = img.comps[c];
    if (excluded[ic.label] || strippedComp[c]) continue;
    auto& pieces = piecesOf[c];
    ComponentIssue is;
    is.label = ic.label;
    is.voxels = ic.voxels;
    is.cores = ic.cores;
    is.pieces = static_cast<int>(pieces.size());
    is.where = ic.where.place();
    if (pieces.empty()) {
      is.kind = ic.cores > 0 ? ComponentIssueKind::Lost : ComponentIssueKind::LostSmall;
      if (ic.cores > 0) lostComp[c] = 1;
      res.componentIssues.push_back(is);
    } else if (static_cast<int>(pieces.size()) > std::max(1, ic.cores)) {
      is.kind = ComponentIssueKind::Split;
      res.componentIssues.push_back(is);
      size_t largest = 0;
      for (size_t p = 1; p < pieces.size(); ++p)
        if (pieces[p].second > pieces[largest].second) largest = p;
      for (size_t p = 0; p < pieces.size(); ++p)
        if (p != largest) meshFlag[size_t(pieces[p].first)] |= 2;
    }
  }
  for (size_t m = 0; m < mcomps.size(); ++m) {
    const auto& mc = mcomps[m];
    int robust = 0;
    for (int32_t c : imageOf[m]) robust += img.comps[size_t(c)].cores > 0 ? 1 : 0;
    ComponentIssue is;
    is.label = mc.label;
    is.meshVolume = mc.where.weight;
    is.where = mc.where.place();
    if (imageOf[m].empty()) {
      is.kind = ComponentIssueKind::Spurious;
      meshFlag[m] |= 1;
      res.componentIssues.push_back(is);
    } else if (robust >= 2) {
      is.kind = ComponentIssueKind::Merged;
      is.pieces = robust;
      meshFlag[m] |= 4;
      res.componentIssues.push_back(is);
    }
  }
  for (const auto& is : res.componentIssues) {
    auto& lc = byLabel[is.label];
    switch (is.kind) {
      case ComponentIssueKind::Lost: ++lc.lost; ++res.lost; break;
      case ComponentIssueKind::LostSmall: ++lc.lostSmall; ++res.lostSmall; break;
      case ComponentIssueKind::Split: ++lc.split; ++res.split; break;
      case ComponentIssueKind::Merged: ++lc.merged; ++res.merged; break;
      case ComponentIssueKind::Spurious: ++lc.spurious; ++res.spurious; break;
    }
  }
  std::stable_sort(res.componentIssues.begin(), res.componentIssues.end(),
                   [](const ComponentIssue& a, const ComponentIssue& b) {
                     if (a.kind != b.kind) return a.kind < b.kind;
                     const double sa = a.voxels > 0 ? double(a.voxels) : a.meshVolume;
                     const double sb = b.voxels > 0 ? double(b.voxels) : b.meshVolume;
                     return sa > sb;
                   });
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < nTets; ++t) {
    int32_t f = meshFlag[size_t(meshComp[size_t(t)])];
    const int32_t cc = centroidVoxelComp[size_t(t)];
    if (cc >= 0 && lostComp[size_t(cc)]) f |= 8;
    res.flags[size_t(t)] = f;
  }
  if (std::find(lostComp.begin(), lostComp.end(), 1) != lostComp.end())
    owners.forEachOwned([&](int, int64_t v, int32_t t) {
      if (lostComp[size_t(img.comp[size_t(v)])]) std::atomic_ref<int32_t>(res.flags[size_t(t)]).fetch_or(8);
    });

  // --- contacts ---------------------------------------------------------------------------
  for (const auto& [k, e] : meshContacts) {
    const auto [a, b] = labelPairOf(k);
    if (excluded[a] || excluded[b]) continue;
    auto it = img.contacts.find(k);
    if (it != img.contacts.end()) continue;
    ContactIssue ci;
    ci.a = a;
    ci.b = b;
    ci.meshArea = e.first;
    ci.where = e.second.place();
    res.spuriousContacts.push_back(ci);
    res.spuriousContactArea += e.first;
  }
  for (const auto& [k, e] : img.contacts) {
    const auto [a, b] = labelPairOf(k);
    if (excluded[a] || excluded[b]) continue;
    if (meshContacts.count(k)) continue;
    ContactIssue ci;
    ci.a = a;
    ci.b = b;
    ci.imageArea = e.first;
    ci.where = e.second.place();
    res.missingContacts.push_back(ci);
  }
  std::stable_sort(res.spuriousContacts.begin(), res.spuriousContacts.end(),
                   [](const ContactIssue& x, const ContactIssue& y) { return x.meshArea > y.meshArea; });
  std::stable_sort(res.missingContacts.begin(), res.missingContacts.end(),
                   [](const ContactIssue& x, const ContactIssue& y) { return x.imageArea > y.imageArea; });
  if (!res.spuriousContacts.empty()) {
    for (int64_t t = 0; t < nTets; ++t)
      for (int f = 0; f < 4; ++f) {
        const int32_t o = nb[static_cast<size_t>(4 * t + f)];
        if (o < 0) continue;
        const int32_t a = mesh.materials[size_t(t)], b = mesh.materials[size_t(o)];
        if (a == b) continue;
        const uint64_t k = labelPairKey(a, b);
        if (!img.contacts.count(k) && !excluded[a] && !excluded[b]) res.flags[size_t(t)] |= 16;
      }
  }
  progress.checkCancel();

  // --- interfaces: non-manifold edges (sorted (edge, label, tet) records) ---------------------
  progress.beginStage("interfaces");
  // Each edge of a face between labels (or on the boundary) is filed under its smaller vertex with
  // (larger vertex, the face's tet's label, the tet) (fileByBucket), then the vertices in order, so
  // edges come in ascending (smaller, larger) order as one sort of every record would give.
  const size_t nP = mesh.numPoints();
  {
    struct EdgeRec {
      int32_t b;
      int32_t label;
      int32_t tet;
      bool operator<(const EdgeRec& o) const {
        return b != o.b ? b < o.b : (label != o.label ? label < o.label : tet < o.tet);
      }
    };
    auto records = [&](int64_t t, auto&& emit) {
      const int32_t L = mesh.materials[size_t(t)];
      for (int f = 0; f < 4; ++f) {
        const int32_t o = nb[static_cast<size_t>(4 * t + f)];
        if (o >= 0 && mesh.materials[size_t(o)] == L) continue;
        const auto& q = mesh.tets[size_t(t)];
        const int32_t v[3] = {q[kTetFaceVertices[f][0]], q[kTetFaceVertices[f][1]], q[kTetFaceVertices[f][2]]};
        for (int e = 0; e < 3; ++e)
          emit(std::min(v[e], v[(e + 1) % 3]), EdgeRec{std::max(v[e], v[(e + 1) % 3]), L, static_cast<int32_t>(t)});
      }
    };
    std::vector<int64_t> start;
    std::vector<EdgeRec> er;
    fileByBucket<EdgeRec>(nTets, nP, records, start, er, progress);
    for (size_t a = 0; a < nP; ++a) {
      int32_t lastBad = -1;
      const size_t end = size_t(start[a + 1]);
      for (size_t i = size_t(start[a]); i < end;) {
        size_t j = i + 1;
        while (j < end && er[j].b == er[i].b && er[j].label == er[i].label) ++j;
        if (j - i > 2) {
          if (er[i].b != lastBad) {
            ++res.nonmanifoldEdges;
            lastBad = er[i].b;
            if (res.nonmanifoldPlaces.size() < 20)
              res.nonmanifoldPlaces.push_back(0.5 * (mesh.points[a] + mesh.points[size_t(er[i].b)]));
          }
          ++byLabel[er[i].label].nonmanifoldEdges;
          for (size_t k = i; k < j; ++k) res.flags[size_t(er[k].tet)] |= 32;
        }
        i = j;
      }
    }
  }
  progress.checkCancel();

  // --- interfaces: non-manifold vertices (vertex stars) ------------------------------------
  const VertexStars stars = vertexStars(mesh);
  progress.checkCancel();
  const std::vector<int64_t>& off = stars.offset;
  const std::vector<int32_t>& star = stars.tets;
  std::vector<uint8_t> badVertex(nP, 0);
  std::vector<std::map<int32_t, int64_t>> badPerLabel(static_cast<size_t>(omp_get_max_threads()));
  LoopCancel starCancel(progress);
#pragma omp parallel
  {
    auto& mine = badPerLabel[static_cast<size_t>(omp_get_thread_num())];
    std::vector<int32_t> parent;
    std::vector<std::pair<int64_t, int64_t>> links;
    std::vector<int32_t> labelsHere, labs, count;
#pragma omp for schedule(dynamic, 1024)
    for (int64_t p = 0; p < static_cast<int64_t>(nP); ++p) {
      if (starCancel.skip(p)) continue;
      const int64_t b = off[size_t(p)], e = off[size_t(p) + 1];
      if (e - b < 2) continue;
      const int32_t L0 = mesh.materials[size_t(star[size_t(b)])];
      bool mixed = false;
      for (int64_t s = b + 1; s < e && !mixed; ++s) mixed = mesh.materials[size_t(star[size_t(s)])] != L0;
      if (!mixed) continue;
      const int64_t k = e - b;
      // Local adjacency through the three faces at p of each star tet (a star is ascending).
      const auto first = star.begin() + b, last = star.begin() + e;
      auto local = [&](int32_t t) -> int64_t {
        const auto it = std::lower_bound(first, last, t);
        return it != last && *it == t ? int64_t(it - first) : -1;
      };
      links.clear();
      for (int64_t s = 0; s < k; ++s) {
        const int32_t t = star[size_t(b + s)];
        for (int f = 0; f < 4; ++f) {
          if (mesh.tets[size_t(t)][f] == p) continue; // the face opposite p
          const int32_t o = nb[static_cast<size_t>(4 * t + f)];
          if (o > t) {
            const int64_t lo = local(o);
            if (lo >= 0) links.push_back({s, lo});
          }
        }
      }
      labs.resize(size_t(k));
      for (int64_t s = 0; s < k; ++s) labs[size_t(s)] = mesh.materials[size_t(star[size_t(b + s)])];
      labelsHere.assign(labs.begin(), labs.end());
      std::sort(labelsHere.begin(), labelsHere.end());
      labelsHere.erase(std::unique(labelsHere.begin(), labelsHere.end()), labelsHere.end());
      auto groups = [&](auto inSet) {
        parent.resize(size_t(k));
        std::iota(parent.begin(), parent.end(), 0);
        auto find = [&](int32_t x) {
          while (parent[size_t(x)] != x) x = parent[size_t(x)] = parent[size_t(parent[size_t(x)])];
          return x;
        };
        for (const auto& [x, y] : links)
          if (inSet(x) && inSet(y)) {
            const int32_t rx = find(int32_t(x)), ry = find(int32_t(y));
            if (rx != ry) parent[size_t(std::max(rx, ry))] = std::min(rx, ry);
          }
        int count = 0;
        for (int64_t s = 0; s < k; ++s)
          if (inSet(s) && find(int32_t(s)) == s) ++count;
        return count;
      };
      // Groups of each label's tets; with two labels, the tets of neither are those of the other.
      count.clear();
      for (const int32_t lab : labelsHere) count.push_back(groups([&](int64_t s) { return labs[size_t(s)] == lab; }));
      for (size_t l = 0; l < labelsHere.size(); ++l) {
        const int32_t lab = labelsHere[l];
        auto isL = [&](int64_t s) { return labs[size_t(s)] == lab; };
        if (count[l] > 1 || (labelsHere.size() == 2 ? count[1 - l] > 1 : groups([&](int64_t s) { return !isL(s); }) > 1)) {
          badVertex[size_t(p)] = 1;
          ++mine[lab];
          for (int64_t s = 0; s < k; ++s)
            if (isL(s)) {
              std::atomic_ref<int32_t> fl(res.flags[size_t(star[size_t(b + s)])]);
              fl.fetch_or(32, std::memory_order_relaxed);
            }
        }
      }
    }
  }
  starCancel.rethrow();
  for (const auto& m : badPerLabel)
    for (const auto& [L, c] : m) byLabel[L].nonmanifoldVertices += c;
  for (size_t p = 0; p < nP; ++p)
    if (badVertex[p]) {
      ++res.nonmanifoldVertices;
      if (res.nonmanifoldPlaces.size() < 20) res.nonmanifoldPlaces.push_back(mesh.points[p]);
    }
  progress.endStage();

  for (auto& [L, lc] : byLabel) res.labels.push_back(lc);
  return res;
}

std::string CertificateResult::labelText(int32_t label) const { return "label " + numberAndName(label); }

std::string CertificateResult::labelPairText(int32_t a, int32_t b) const {
  return "labels " + numberAndName(a) + " and " + numberAndName(b);
}

std::string CertificateResult::numberAndName(int32_t label) const {
  const auto it = names.find(label);
  return std::to_string(label) + (it == names.end() || it->second.empty() ? std::string() : " (" + it->second + ")");
}

std::vector<std::string> certificateFailures(const CertificateResult& r, const CertificateThresholds& t) {
  std::vector<std::string> out;
  char buf[512];
  if (t.maxVolumeError > 0) {
    const LabelCertificate* worst = nullptr;
    int over = 0;
    for (const auto& lc : r.labels) {
      if (lc.excluded || lc.voxels == 0) continue;
      if (std::abs(lc.relError) > t.maxVolumeError &&
          std::abs(lc.absError) > t.smallComponentAllowance * lc.volumeAllowance) {
        ++over;
        if (!worst || std::abs(lc.relError) > std::abs(worst->relError)) worst = &lc;
      }
    }
    if (worst) {
      std::snprintf(buf, sizeof buf,
                    "max_volume_error %.3g %%: %d label(s) exceed it; worst is %s at %+.2f %% "
                    "(mesh %.6g mm^3, voxels %.6g mm^3",
                    100.0 * t.maxVolumeError, over, r.labelText(worst->label).c_str(), 100.0 * worst->relError,
                    worst->meshVolume, worst->voxelVolume);
      std::string msg = buf;
      if (worst->smallComponents > 0 && t.smallComponentAllowance > 0) {
        std::snprintf(buf, sizeof buf, ", beyond the %.6g mm^3 allowed for its %d component(s) smaller than an element",
                      t.smallComponentAllowance * worst->volumeAllowance, worst->smallComponents);
        msg += buf;
      }
      out.push_back(msg + "); refine the background at thin layers (smaller cell_size / min_cell_size) or lower "
                          "blend_sigma");
    }
  }
  if (t.requireComponents) {
    int bad = r.lost + r.split + r.merged + r.spurious;
    if (bad > 0) {
      const ComponentIssue* first = nullptr;
      for (const auto& is : r.componentIssues)
        if (is.kind != ComponentIssueKind::LostSmall) {
          first = &is;
          break;
        }
      std::string what;
      if (first) {
        if (first->voxels > 0)
          std::snprintf(buf, sizeof buf, "%s: %s, image component of %lld voxels, %d mesh piece(s), at %s",
                        componentIssueName(first->kind), r.labelText(first->label).c_str(), static_cast<long long>(first->voxels),
                        first->pieces, describePlace(first->where).c_str());
        else
          std::snprintf(buf, sizeof buf, "%s: %s, mesh component of %.6g mm^3 at %s",
                        componentIssueName(first->kind), r.labelText(first->label).c_str(), first->meshVolume,
                        describePlace(first->where).c_str());
        what = buf;
      }
      std::snprintf(buf, sizeof buf,
                    "require_components: %d lost, %d split, %d merged, %d spurious component(s); worst: ",
                    r.lost, r.split, r.merged, r.spurious);
      out.push_back(std::string(buf) + what);
    }
  }
  if (t.forbidSpuriousContacts && !r.spuriousContacts.empty()) {
    const auto& c = r.spuriousContacts.front();
    std::snprintf(buf, sizeof buf,
                  "forbid_spurious_contacts: %zu label pair(s) touch in the mesh but not in the image; "
                  "worst: %s over %.6g mm^2 at %s",
                  r.spuriousContacts.size(), r.labelPairText(c.a, c.b).c_str(), c.meshArea, describePlace(c.where).c_str());
    out.push_back(buf);
  }
  return out;
}

void writeCertificateReport(const CertificateResult& r, Report& report, size_t maxListed) {
  report.set("cert_rule",
             "per label: every robust (6-erosion surviving) 26-connected image component kept, "
             "none split beyond its cores, none merged, no spurious mesh component; contacts by "
             "voxel faces; volume within max_volume_error, or within h^3 per component smaller than "
             "h^3 (h its local element size)");
  std::string ex;
  for (int32_t L : r.excludedLabels) ex += (ex.empty() ? "" : " ") + std::to_string(L);
  report.set("cert_excluded_labels", ex);
  std::string st;
  for (int32_t L : r.strippedLabels) st += (st.empty() ? "" : " ") + std::to_string(L);
  report.set("cert_stripped_labels", st.empty() ? std::string("none") : st);
  report.set("cert_voxel_agreement", ReportValue(r.agreement));
  report.set("cert_worst_volume_rel_error", ReportValue(r.worstRelError));
  report.set("cert_worst_volume_label", ReportValue(int64_t(r.worstLabel)));
  report.set("cert_components_lost", ReportValue(int64_t(r.lost)));
  report.set("cert_components_lost_small", ReportValue(int64_t(r.lostSmall)));
  report.set("cert_components_split", ReportValue(int64_t(r.split)));
  report.set("cert_components_merged", ReportValue(int64_t(r.merged)));
  report.set("cert_components_spurious", ReportValue(int64_t(r.spurious)));
  report.set("cert_spurious_contacts", ReportValue(int64_t(r.spuriousContacts.size())));
  report.set("cert_spurious_contact_area_mm2", ReportValue(r.spuriousContactArea));
  report.set("cert_missing_contacts", ReportValue(int64_t(r.missingContacts.size())));
  report.set("cert_nonmanifold_edges", ReportValue(r.nonmanifoldEdges));
  report.set("cert_nonmanifold_vertices", ReportValue(r.nonmanifoldVertices));
  for (const auto& lc : r.labels) {
    const std::string k = "cert_label_" + std::to_string(lc.label) + "_";
    if (auto n = r.names.find(lc.label); n != r.names.end() && !n->second.empty()) report.set(k + "name", n->second);
    if (lc.excluded) {
      report.set(k + "excluded", ReportValue(true));
      continue;
    }
    if (lc.strippedVoxels > 0) {
      report.set(k + "stripped_voxels", ReportValue(lc.strippedVoxels));
      report.set(k + "stripped_mm3", ReportValue(lc.strippedVolume));
    }
    report.set(k + "voxel_volume_mm3", ReportValue(lc.voxelVolume));
    report.set(k + "mesh_volume_mm3", ReportValue(lc.meshVolume));
    report.set(k + "volume_abs_error_mm3", ReportValue(lc.absError));
    report.set(k + "volume_rel_error", ReportValue(lc.relError));
    report.set(k + "image_components", ReportValue(int64_t(lc.imageComponents)));
    report.set(k + "robust_components", ReportValue(int64_t(lc.robustComponents)));
    report.set(k + "mesh_components", ReportValue(int64_t(lc.meshComponents)));
    report.set(k + "voxel_agreement", ReportValue(lc.agreement));
    report.set(k + "small_components", ReportValue(int64_t(lc.smallComponents)));
    report.set(k + "volume_allowance_mm3", ReportValue(lc.volumeAllowance));
  }
  char buf[512];
  for (size_t i = 0; i < r.componentIssues.size() && i < maxListed; ++i) {
    const auto& is = r.componentIssues[i];
    if (is.voxels > 0)
      std::snprintf(buf, sizeof buf, "%s: %s, image component of %lld voxels (%d core(s)), %d mesh piece(s), at %s",
                    componentIssueName(is.kind), r.labelText(is.label).c_str(), static_cast<long long>(is.voxels), is.cores,
                    is.pieces, describePlace(is.where).c_str());
    else if (is.kind == ComponentIssueKind::Merged)
      std::snprintf(buf, sizeof buf, "merged: %s, mesh component of %.6g mm^3 joins %d robust image components, at %s",
                    r.labelText(is.label).c_str(), is.meshVolume, is.pieces, describePlace(is.where).c_str());
    else
      std::snprintf(buf, sizeof buf, "%s: %s, mesh component of %.6g mm^3, at %s",
                    componentIssueName(is.kind), r.labelText(is.label).c_str(), is.meshVolume, describePlace(is.where).c_str());
    report.set("cert_issue_" + std::to_string(i + 1), std::string(buf));
  }
  for (size_t i = 0; i < r.spuriousContacts.size() && i < maxListed; ++i) {
    const auto& c = r.spuriousContacts[i];
    std::snprintf(buf, sizeof buf, "%s: %.6g mm^2 in the mesh, none in the image, at %s",
                  r.labelPairText(c.a, c.b).c_str(),
                  c.meshArea, describePlace(c.where).c_str());
    report.set("cert_spurious_contact_" + std::to_string(i + 1), std::string(buf));
  }
  for (size_t i = 0; i < r.missingContacts.size() && i < maxListed; ++i) {
    const auto& c = r.missingContacts[i];
    std::snprintf(buf, sizeof buf, "%s: %.6g mm^2 in the image, none in the mesh, at %s",
                  r.labelPairText(c.a, c.b).c_str(),
                  c.imageArea, describePlace(c.where).c_str());
    report.set("cert_missing_contact_" + std::to_string(i + 1), std::string(buf));
  }
  std::string places;
  for (size_t i = 0; i < r.nonmanifoldPlaces.size() && i < 5; ++i) {
    std::snprintf(buf, sizeof buf, "%s(%.1f, %.1f, %.1f)", i ? " " : "", r.nonmanifoldPlaces[i][0],
                  r.nonmanifoldPlaces[i][1], r.nonmanifoldPlaces[i][2]);
    places += buf;
  }
  if (!places.empty()) report.set("cert_nonmanifold_at_mm", places);
}

} // namespace tetflow
