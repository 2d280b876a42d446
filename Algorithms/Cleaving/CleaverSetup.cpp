// Lattice cleaving, set-up: box constraints, material samples, interface points and adjacency (see CleaverStages.h).
#include "Algorithms/Cleaving/CleaverStages.h"

#include <memory>

namespace tetflow::cleaving_detail {

void Cleaver::computeBoxConstraints() {
  frame_ = mats_.grid().direction;
  const int64_t nv = static_cast<int64_t>(m_.points.size());
  fixedAxes_.assign(static_cast<size_t>(nv), 0);
  std::vector<Vec3> local(static_cast<size_t>(nv));
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (int64_t v = 0; v < nv; ++v) {
    const Vec3 d = m_.points[v] - mats_.grid().origin;
    for (int a = 0; a < 3; ++a) {
      local[v][a] = frame_[0][a] * d[0] + frame_[1][a] * d[1] + frame_[2][a] * d[2];
      lo[a] = std::min(lo[a], local[v][a]);
      hi[a] = std::max(hi[a], local[v][a]);
    }
  }
  boxLo_ = lo;
  boxHi_ = hi;
  for (int64_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a) {
      const double eps = 1e-9 * (hi[a] - lo[a]);
      if (std::abs(local[v][a] - lo[a]) <= eps || std::abs(local[v][a] - hi[a]) <= eps)
        fixedAxes_[v] |= static_cast<uint8_t>(1u << a);
    }
}

void Cleaver::sample() {
  progress_.beginStage("sample");
  const int64_t nv = static_cast<int64_t>(m_.points.size());
  pos_ = m_.points;
  label_.assign(static_cast<size_t>(nv), 0);
  warped_.assign(static_cast<size_t>(nv), 0);
  std::vector<int64_t> counts(static_cast<size_t>(nv) + 1, 0);
  const int64_t block = 4096;
  const int64_t nBlocks = (nv + block - 1) / block;
  std::vector<std::vector<MaterialSample>> blockSamples(static_cast<size_t>(nBlocks));
#pragma omp parallel
  {
    std::vector<MaterialSample> s;
#pragma omp for schedule(dynamic, 1)
    for (int64_t bi = 0; bi < nBlocks; ++bi) {
      // Cancellation: skip the remaining blocks; the exception is thrown after the parallel
      // region (an exception leaving an OpenMP region would terminate the process).
      if (progress_.cancelRequested()) continue;
      auto& out = blockSamples[static_cast<size_t>(bi)];
      for (int64_t v = bi * block; v < std::min(nv, (bi + 1) * block); ++v) {
        mats_.sample(pos_[v], s);
        label_[v] = dominantMaterial(s);
        counts[v + 1] = static_cast<int64_t>(s.size());
        out.insert(out.end(), s.begin(), s.end());
      }
      if (bi % 64 == 0) progress_.report(double(bi) / double(nBlocks));
    }
  }
  progress_.checkCancel();
  sampleStart_.assign(static_cast<size_t>(nv) + 1, 0);
  for (int64_t v = 0; v < nv; ++v) sampleStart_[v + 1] = sampleStart_[v] + counts[v + 1];
  samples_.clear();
  samples_.reserve(static_cast<size_t>(sampleStart_[nv]));
  for (auto& b : blockSamples) {
    samples_.insert(samples_.end(), b.begin(), b.end());
    std::vector<MaterialSample>().swap(b);
  }
}

namespace {
// Numbers the distinct K-vertex simplices (edges, faces) of n tets, Per of them per tet, in the
// order of their sorted vertex ids: ids[i] is simplex i's vertices, tetIds[t][k] the id of tet t's
// k-th, and list[start[i] .. start[i + 1]) the tets that have simplex i, ascending. The same
// numbering as sorting every (vertices, 4-byte slot) pair, without that sort or its 16-byte keys:
// each slot (Per t + k) is filed under its smallest vertex (a counting sort, both threads), then
// each vertex's few slots are sorted by their other vertices and the slot; the slots, in that
// order, are the tet lists. `verts(t, k)` gives the sorted vertices; n Per must fit in 32 bits.
template <int K, int Per, class Verts>
void numberSimplices(int64_t n, size_t nP, Verts verts, std::vector<std::array<int32_t, Per>>& tetIds,
                     std::vector<std::array<int32_t, K>>& ids, std::vector<int64_t>& start, std::vector<int32_t>& list,
                     Progress& progress) {
  std::vector<uint32_t> offset(nP + 1, 0);
  LoopCancel countCancel(progress);
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < n; ++t) {
    if (countCancel.skip(t)) continue;
    for (int k = 0; k < Per; ++k)
      std::atomic_ref<uint32_t>(offset[static_cast<size_t>(verts(t, k)[0]) + 1]).fetch_add(1, std::memory_order_relaxed);
  }
  countCancel.rethrow();
  for (size_t p = 0; p < nP; ++p) offset[p + 1] += offset[p];
  // Not value-initialised: the fill writes every slot (its threads touch the pages first).
  const auto slots = std::make_unique_for_overwrite<uint32_t[]>(static_cast<size_t>(n) * Per);
  std::vector<uint32_t> count(offset.begin(), offset.end() - 1); // the fill's positions, then distinct counts
  LoopCancel fillCancel(progress);
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < n; ++t) {
    if (fillCancel.skip(t)) continue;
    for (int k = 0; k < Per; ++k) {
      const uint32_t at = std::atomic_ref<uint32_t>(count[static_cast<size_t>(verts(t, k)[0])])
                              .fetch_add(1, std::memory_order_relaxed);
      slots[at] = static_cast<uint32_t>(Per * t + k);
    }
  }
  fillCancel.rethrow();
  // The other vertices of a slot's simplex as one key.
  auto rest = [&](uint32_t slot) {
    const auto v = verts(int64_t(slot / Per), int(slot % Per));
    return K == 2 ? uint64_t(uint32_t(v[1])) : (uint64_t(uint32_t(v[1])) << 32) | uint32_t(v[K - 1]);
  };
  // Each bucket sorted (slots in that order), and its distinct simplices counted.
  LoopCancel sortCancel(progress);
#pragma omp parallel
  {
    std::vector<std::pair<uint64_t, uint32_t>> bucket;
#pragma omp for schedule(dynamic, 4096)
    for (int64_t p = 0; p < static_cast<int64_t>(nP); ++p) {
      if (sortCancel.skip(p)) continue;
      bucket.clear();
      for (uint32_t i = offset[size_t(p)]; i < offset[size_t(p) + 1]; ++i) bucket.push_back({rest(slots[i]), slots[i]});
      std::sort(bucket.begin(), bucket.end());
      uint32_t distinct = 0;
      for (size_t i = 0; i < bucket.size(); ++i) {
        slots[offset[size_t(p)] + i] = bucket[i].second;
        distinct += i == 0 || bucket[i].first != bucket[i - 1].first ? 1 : 0;
      }
      count[size_t(p)] = distinct;
    }
  }
  sortCancel.rethrow();
  std::vector<uint32_t> first(nP + 1, 0); // the id of each bucket's first simplex
  for (size_t p = 0; p < nP; ++p) first[p + 1] = first[p] + count[p];
  std::vector<uint32_t>().swap(count);
  ids.resize(first[nP]);
  start.resize(size_t(first[nP]) + 1);
  start[first[nP]] = n * Per;
  list.resize(static_cast<size_t>(n) * Per);
  LoopCancel idCancel(progress);
#pragma omp parallel for schedule(dynamic, 4096)
  for (int64_t p = 0; p < static_cast<int64_t>(nP); ++p) {
    if (idCancel.skip(p)) continue;
    int64_t id = int64_t(first[size_t(p)]) - 1;
    uint64_t last = 0;
    for (uint32_t i = offset[size_t(p)]; i < offset[size_t(p) + 1]; ++i) {
      const uint32_t slot = slots[i];
      const uint64_t r = rest(slot);
      if (i == offset[size_t(p)] || r != last) {
        ++id;
        ids[size_t(id)] = verts(int64_t(slot / Per), int(slot % Per));
        start[size_t(id)] = i;
        last = r;
      }
      tetIds[slot / Per][slot % Per] = static_cast<int32_t>(id);
      list[i] = static_cast<int32_t>(slot / Per);
    }
  }
  idCancel.rethrow();
}
} // namespace

void Cleaver::buildInterfaces() {
  progress_.beginStage("interfaces");
  const int64_t nt = static_cast<int64_t>(m_.tets.size());
  bgToInterface_.assign(static_cast<size_t>(nt), -1);
  for (int64_t t = 0; t < nt; ++t) {
    const auto& q = m_.tets[t];
    const int32_t l0 = label_[q[0]];
    if (label_[q[1]] != l0 || label_[q[2]] != l0 || label_[q[3]] != l0) {
      bgToInterface_[t] = static_cast<int32_t>(itet_.size());
      itet_.push_back(static_cast<int32_t>(t));
    }
  }
  progress_.checkCancel();
  const int64_t ni = static_cast<int64_t>(itet_.size());
  stats_.interfaceTets = ni;
  // Unique edges and faces of interface tets, numbered in the order of their sorted vertex ids.
  if (ni > int64_t(std::numeric_limits<uint32_t>::max() / 6))
    throw ProcessingError("cleaving: too many interface tets (" + std::to_string(ni) + ")");
  tetEdge_.resize(static_cast<size_t>(ni));
  tetFace_.resize(static_cast<size_t>(ni));
  numberSimplices<2, 6>(
      ni, m_.points.size(),
      [&](int64_t t, int e) {
        const auto& q = tv(static_cast<int32_t>(t));
        const int32_t a = q[kEdgeVerts[e][0]], b = q[kEdgeVerts[e][1]];
        return a < b ? std::array<int32_t, 2>{a, b} : std::array<int32_t, 2>{b, a};
      },
      tetEdge_, edgeV_, etStart_, etList_, progress_);
  numberSimplices<3, 4>(
      ni, m_.points.size(),
      [&](int64_t t, int f) {
        const auto& q = tv(static_cast<int32_t>(t));
        std::array<int32_t, 3> k = {q[kFaceVerts[f][0]], q[kFaceVerts[f][1]], q[kFaceVerts[f][2]]};
        if (k[0] > k[1]) std::swap(k[0], k[1]);
        if (k[1] > k[2]) std::swap(k[1], k[2]);
        if (k[0] > k[1]) std::swap(k[0], k[1]);
        return k;
      },
      tetFace_, faceV_, ftStart_, ftList_, progress_);

  tetsAroundVertices(
      ni, m_.points.size(), [&](int64_t t) -> const TetMesh::Tet& { return tv(static_cast<int32_t>(t)); },
      [](int32_t) { return true; }, vtStart_, vtList_, progress_);
  progress_.checkCancel();
  // Real interface points.
  const int64_t ne = static_cast<int64_t>(edgeV_.size()), nf = static_cast<int64_t>(faceV_.size());
  cutT_.assign(static_cast<size_t>(ne), 0.5f);
  cutAlias_.assign(static_cast<size_t>(ne), Ref{});
  cutReal_.assign(static_cast<size_t>(ne), 0);
  triB_.assign(static_cast<size_t>(nf), {1.0f / 3, 1.0f / 3, 1.0f / 3});
  triAlias_.assign(static_cast<size_t>(nf), Ref{});
  triReal_.assign(static_cast<size_t>(nf), 0);
  triOverride_.assign(static_cast<size_t>(ni), {-1, -1, -1, -1});
  quadB_.assign(static_cast<size_t>(ni), {0.25f, 0.25f, 0.25f, 0.25f});
  quadAlias_.assign(static_cast<size_t>(ni), Ref{});
  quadReal_.assign(static_cast<size_t>(ni), 0);
  int64_t nc = 0, ntr = 0, nq = 0;
#pragma omp parallel for schedule(static) reduction(+ : nc)
  for (int64_t e = 0; e < ne; ++e)
    if (label_[edgeV_[e][0]] != label_[edgeV_[e][1]]) {
      cutReal_[e] = 1;
      computeCut(static_cast<int32_t>(e));
      ++nc;
    }
  progress_.checkCancel();
#pragma omp parallel for schedule(static) reduction(+ : ntr)
  for (int64_t f = 0; f < nf; ++f) {
    const auto& v = faceV_[f];
    const int32_t a = label_[v[0]], b = label_[v[1]], c = label_[v[2]];
    if (a != b && a != c && b != c) {
      triReal_[f] = 1;
      computeTriple(static_cast<int32_t>(f));
      ++ntr;
    }
  }
  progress_.checkCancel();
#pragma omp parallel for schedule(static) reduction(+ : nq)
  for (int64_t t = 0; t < ni; ++t) {
    const auto& q = tv(static_cast<int32_t>(t));
    const int32_t l[4] = {label_[q[0]], label_[q[1]], label_[q[2]], label_[q[3]]};
    if (l[0] != l[1] && l[0] != l[2] && l[0] != l[3] && l[1] != l[2] && l[1] != l[3] && l[2] != l[3]) {
      quadReal_[t] = 1;
      computeQuad(static_cast<int32_t>(t));
      ++nq;
    }
  }
  stats_.cuts = nc;
  stats_.triples = ntr;
  stats_.quadruples = nq;
  progress_.checkCancel();
}

void Cleaver::buildWarpStars() {
  // Only vertices of interface tets are ever warped (their points are the only ones that can
  // violate them): the background tets around those, not around every vertex.
  const int64_t nv = static_cast<int64_t>(m_.points.size());
  const int64_t nt = static_cast<int64_t>(m_.tets.size());
  auto warpable = [&](int32_t v) { return vtStart_[v + 1] > vtStart_[v]; };
  tetsAroundVertices(
      nt, static_cast<size_t>(nv), [&](int64_t t) -> const TetMesh::Tet& { return m_.tets[static_cast<size_t>(t)]; },
      warpable, allStart_, allList_, progress_);
}

void Cleaver::cullExterior() {
  if (!p_.cull_exterior) return;
  const auto& labels = mats_.labels();
  const auto found = std::find(labels.begin(), labels.end(), *p_.cull_exterior);
  if (found == labels.end()) return;
  progress_.beginStage("cull exterior");
  const int32_t S = static_cast<int32_t>(found - labels.begin());
  const int64_t nv = static_cast<int64_t>(m_.points.size());
  const int64_t nt = static_cast<int64_t>(m_.tets.size());
  // Bit 0: a vertex of another label or one sharing a tet with one; bit 1: sharing a tet with such.
  std::vector<uint8_t> near(static_cast<size_t>(nv), 0);
  for (int ring = 0; ring < 2; ++ring) {
    LoopCancel cancel(progress_);
#pragma omp parallel for schedule(static)
    for (int64_t t = 0; t < nt; ++t) {
      if (cancel.skip(t)) continue;
      const auto& q = m_.tets[t];
      bool mark = false;
      // Ring 1 reads bit 0 while other threads set bit 1 of the same bytes: an atomic load.
      for (int32_t v : q)
        mark = mark || (ring == 0 ? label_[v] != S
                                  : (std::atomic_ref<uint8_t>(near[v]).load(std::memory_order_relaxed) & 1) != 0);
      if (mark)
        for (int32_t v : q)
          std::atomic_ref<uint8_t>(near[v]).fetch_or(static_cast<uint8_t>(1u << ring), std::memory_order_relaxed);
    }
    cancel.rethrow();
  }
  // Deep vertices in the exterior: 1, others 0.
  std::vector<uint8_t> deep(static_cast<size_t>(nv), 0);
  LoopCancel testCancel(progress_);
#pragma omp parallel for schedule(dynamic, 4096)
  for (int64_t v = 0; v < nv; ++v) {
    if (testCancel.skip(v)) continue;
    deep[v] = near[v] == 0 && (!p_.cull_exterior_at || p_.cull_exterior_at(m_.points[v]));
  }
  testCancel.rethrow();
  cull_.assign(static_cast<size_t>(nt), 0);
  // Volumes summed in fixed chunks, then in order: the same sum for any number of threads.
  constexpr int64_t kChunk = 1 << 16;
  const int64_t chunks = (nt + kChunk - 1) / kChunk;
  std::vector<double> chunkVolume(static_cast<size_t>(chunks), 0.0);
  int64_t culled = 0;
#pragma omp parallel for schedule(static) reduction(+ : culled)
  for (int64_t c = 0; c < chunks; ++c)
    for (int64_t t = c * kChunk; t < std::min(nt, (c + 1) * kChunk); ++t) {
      const auto& q = m_.tets[t];
      if (deep[q[0]] && deep[q[1]] && deep[q[2]] && deep[q[3]]) {
        cull_[t] = 1;
        ++culled;
        chunkVolume[c] += std::abs(signedTetVolume(m_.points[q[0]], m_.points[q[1]], m_.points[q[2]], m_.points[q[3]]));
      }
    }
  progress_.checkCancel();
  double volume = 0.0;
  for (double v : chunkVolume) volume += v;
  stats_.culledTets = culled;
  stats_.culledVolume = volume;
  if (culled == 0) cull_.clear();
}

void Cleaver::releaseInterfaces() {
  // What the stencil needed and the angle optimisation does not: freed before it allocates.
  auto drop = [](auto& v) { std::remove_reference_t<decltype(v)>().swap(v); };
  drop(pos_);
  drop(label_);
  drop(cull_);
  drop(sampleStart_);
  drop(samples_);
  resampled_.clear();
  drop(vertexAlpha_);
  drop(allStart_);
  drop(allList_);
  drop(itet_);
  drop(bgToInterface_);
  drop(tetEdge_);
  drop(tetFace_);
  drop(edgeV_);
  drop(faceV_);
  drop(cutT_);
  drop(cutAlias_);
  drop(cutReal_);
  drop(triB_);
  drop(triAlias_);
  drop(triReal_);
  drop(triOverride_);
  drop(quadB_);
  drop(quadAlias_);
  drop(quadReal_);
  drop(vtStart_);
  drop(etStart_);
  drop(ftStart_);
  drop(vtList_);
  drop(etList_);
  drop(ftList_);
  drop(faceQueued_);
  drop(tetQueued_);
}

} // namespace tetflow::cleaving_detail
