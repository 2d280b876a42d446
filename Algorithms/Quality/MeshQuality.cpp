#include "MeshQuality.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include "Algorithms/Core/CancellableSort.h"

#include "Algorithms/Core/Errors.h"
#include "TetQuality.h"

namespace tetflow {

namespace {

__extension__ typedef unsigned __int128 U128;

constexpr int64_t kBlock = 16384; // tets per work unit (cancellation / progress granularity)

bool repeatsVertex(const TetMesh::Tet& q) {
  return q[0] == q[1] || q[0] == q[2] || q[0] == q[3] || q[1] == q[2] || q[1] == q[3] ||
         q[2] == q[3];
}

// Median of `v` (reordered); mean of the two middle values for an even count.
double median(std::vector<double>& v) {
  if (v.empty()) return 0.0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  const double hi = v[mid];
  if (v.size() % 2 == 1) return hi;
  const double lo = *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid));
  return 0.5 * (lo + hi);
}

// The first half of a counting sort over [0, n) in `parts` fixed blocks (one per thread): each item
// i names its buckets (bucketsOf(i, add) calls add(bucket) once per entry it files); the counts per
// block become, in `at`, where each block writes a bucket's entries. Returns each bucket's start
// (buckets + 1 values, the last the total). Cancellable.
template <class BucketsOf>
std::vector<int64_t> countingStarts(int64_t n, size_t buckets, int64_t parts, const BucketsOf& bucketsOf,
                                    std::vector<std::vector<int64_t>>& at, const Progress& progress) {
  auto block = [&](int64_t c) { return std::pair{n * c / parts, n * (c + 1) / parts}; };
  at.assign(static_cast<size_t>(parts), {});
  {
    LoopCancel cancel(progress);
#pragma omp parallel for schedule(static, 1)
    for (int64_t c = 0; c < parts; ++c) {
      auto& cnt = at[size_t(c)];
      cnt.assign(buckets, 0);
      const auto [lo, hi] = block(c);
      for (int64_t i = lo; i < hi; ++i) {
        if (cancel.skip(i)) break;
        bucketsOf(i, [&cnt](size_t b) { ++cnt[b]; });
      }
    }
    cancel.rethrow();
  }
  std::vector<int64_t> start(buckets + 1, 0);
  int64_t pos = 0;
  for (size_t v = 0; v < buckets; ++v) {
    start[v] = pos;
    for (auto& cnt : at) {
      const int64_t k = cnt[v];
      cnt[v] = pos; // where this block writes the bucket's entries
      pos += k;
    }
  }
  start[buckets] = pos;
  return start;
}

// The second half: each block's items again, in order; emit(i, slot) files item i's entries, slot(b)
// giving the next position of bucket b for this block.
template <class Emit>
void countingScatter(int64_t n, int64_t parts, std::vector<std::vector<int64_t>>& at, const Emit& emit,
                     const Progress& progress) {
  LoopCancel cancel(progress);
#pragma omp parallel for schedule(static, 1)
  for (int64_t c = 0; c < parts; ++c) {
    auto& pos = at[size_t(c)];
    const int64_t lo = n * c / parts, hi = n * (c + 1) / parts;
    for (int64_t i = lo; i < hi; ++i) {
      if (cancel.skip(i)) break;
      emit(i, [&pos](size_t b) { return size_t(pos[b]++); });
    }
  }
  cancel.rethrow();
}

// Sorts keys whose top bits (key >> shift) are a vertex index below nP, `none` last: a counting
// sort on the vertex (linear, both threads, each thread a fixed block of the input) and then each
// vertex's keys, a few dozen, sorted on their own. The same order as sorting the keys whole (the
// keys are integers), in a fraction of the comparisons. Cancellable between blocks.
template <class Key>
void sortByLeadingVertex(std::vector<Key>& keys, size_t nP, int shift, Key none, const Progress& progress) {
  const int64_t n = static_cast<int64_t>(keys.size());
  auto vertexOf = [&](const Key& k) { return k == none ? nP : static_cast<size_t>(k >> shift); };
  // One fixed block of the input per thread (memory: a count per vertex per thread).
  const int64_t parts = std::max(1, omp_get_max_threads());
  std::vector<std::vector<int64_t>> count;
  const std::vector<int64_t> start = countingStarts(
      n, nP + 1, parts, [&](int64_t i, const auto& add) { add(vertexOf(keys[size_t(i)])); }, count, progress);
  const auto sorted = std::make_unique_for_overwrite<Key[]>(size_t(n));
  countingScatter(
      n, parts, count,
      [&](int64_t i, const auto& slot) { sorted[slot(vertexOf(keys[size_t(i)]))] = keys[size_t(i)]; }, progress);
  std::vector<std::vector<int64_t>>().swap(count);
  LoopCancel cancel(progress);
#pragma omp parallel for schedule(dynamic, 4096)
  for (int64_t v = 0; v <= static_cast<int64_t>(nP); ++v) {
    if (cancel.skip(v)) continue;
    std::sort(sorted.get() + start[size_t(v)], sorted.get() + start[size_t(v) + 1]);
  }
  cancel.rethrow();
  std::copy(sorted.get(), sorted.get() + n, keys.begin());
}

// ---------------------------------------------------------------------------------------------
// Face analysis. Every face of a tet (tets repeating a vertex have none) is filed under its smallest
// vertex a, by a counting sort over the tets (both threads, each a fixed block of tets), as the
// 8-byte key (b << 32) | (c << 1) | parity, where a < b < c are its sorted vertices and the parity
// is that of the permutation sorting the face as seen from outside its tet: the two copies of an
// interior face of a consistently oriented mesh differ only in that bit. Each vertex's keys, a few
// dozen, are then sorted on their own. Memory: 8 bytes per face, written once (no key array and
// sorted copy of 16-byte keys, whose fresh pages cost the kernel as much as the sort).
// ---------------------------------------------------------------------------------------------

// Outward-oriented faces of a positively oriented tet (a,b,c,d): (a,c,b) (a,b,d) (a,d,c) (b,c,d).
constexpr int kOutwardFaces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};

// The sorted vertices of face f of q and the parity of the sorting permutation.
struct SortedFace {
  int32_t a, b, c;
  unsigned parity;
};
SortedFace sortedFace(const TetMesh::Tet& q, int f) {
  int32_t x = q[kOutwardFaces[f][0]], y = q[kOutwardFaces[f][1]], z = q[kOutwardFaces[f][2]];
  unsigned parity = 0;
  auto order = [&parity](int32_t& lo, int32_t& hi) {
    if (lo > hi) {
      std::swap(lo, hi);
      parity ^= 1u;
    }
  };
  order(x, y);
  order(y, z);
  order(x, y);
  return {x, y, z, parity};
}

void analyzeFaces(const TetMesh& mesh, QualityResult& r, Progress& progress) {
  const int64_t n = static_cast<int64_t>(mesh.numTets());
  const size_t nP = mesh.numPoints();
  const int64_t parts = std::max(1, omp_get_max_threads());
  std::vector<std::vector<int64_t>> at;
  const std::vector<int64_t> start = countingStarts(
      n, nP, parts,
      [&](int64_t t, const auto& add) {
        const auto& q = mesh.tets[size_t(t)];
        if (!repeatsVertex(q))
          for (int f = 0; f < 4; ++f) add(size_t(sortedFace(q, f).a));
      },
      at, progress);
  const auto keys = std::make_unique_for_overwrite<uint64_t[]>(size_t(start[nP]));
  countingScatter(
      n, parts, at,
      [&](int64_t t, const auto& slot) {
        const auto& q = mesh.tets[size_t(t)];
        if (repeatsVertex(q)) return;
        for (int f = 0; f < 4; ++f) {
          const SortedFace sf = sortedFace(q, f);
          keys[slot(size_t(sf.a))] =
              (uint64_t(uint32_t(sf.b)) << 32) | (uint64_t(uint32_t(sf.c)) << 1) | uint64_t(sf.parity);
        }
      },
      progress);
  std::vector<std::vector<int64_t>>().swap(at);
  sortEachBucket(keys.get(), start, progress);
  progress.report(0.5);

  // Scan groups of equal faces (keys equal up to the parity bit), vertex by vertex.
  std::vector<uint64_t> edges; // boundary-face edges, (lo << 32) | hi
  auto edge = [](uint64_t x, uint64_t y) { return (std::min(x, y) << 32) | std::max(x, y); };
  for (size_t v = 0; v < nP; ++v) {
    if ((v & 0xFFFF) == 0) progress.checkCancel();
    for (int64_t i = start[v], end = start[v + 1]; i < end;) {
      const uint64_t face = keys[size_t(i)] >> 1;
      int64_t j = i;
      int parity1 = 0;
      while (j < end && (keys[size_t(j)] >> 1) == face) {
        parity1 += static_cast<int>(keys[size_t(j)] & 1u);
        ++j;
      }
      const int64_t count = j - i;
      if (count == 1) {
        ++r.boundaryFaces;
        const uint64_t a = v, b = face >> 31, c = face & 0x7FFFFFFFu;
        edges.push_back(edge(a, b));
        edges.push_back(edge(b, c));
        edges.push_back(edge(a, c));
      } else if (count == 2) {
        ++r.interiorFaces;
        if (parity1 != 1) ++r.foldedFaces;
      } else {
        ++r.nonmanifoldFaces;
      }
      i = j;
    }
  }
  progress.checkCancel();

  cancellableSort(edges, progress);
  for (size_t a = 0; a < edges.size();) {
    size_t b = a;
    while (b < edges.size() && edges[b] == edges[a]) ++b;
    ++r.boundaryEdges;
    if (b - a == 1) ++r.openBoundaryEdges;
    else if (b - a > 2) ++r.nonmanifoldBoundaryEdges;
    a = b;
  }
  r.boundaryClosed = r.openBoundaryEdges == 0 && r.nonmanifoldBoundaryEdges == 0;
}

void countDuplicates(const TetMesh& mesh, QualityResult& r, Progress& progress) {
  const int64_t n = static_cast<int64_t>(mesh.numTets());
  std::vector<U128> keys(static_cast<size_t>(n));
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < n; ++t) {
    auto q = mesh.tets[static_cast<size_t>(t)];
    std::sort(q.begin(), q.end());
    U128 k = 0;
    for (int32_t v : q) k = (k << 32) | static_cast<U128>(static_cast<uint32_t>(v));
    keys[static_cast<size_t>(t)] = k;
  }
  sortByLeadingVertex(keys, mesh.numPoints(), 96, ~U128(0), progress); // checks for cancellation itself
  const auto unique = std::unique(keys.begin(), keys.end()) - keys.begin();
  r.duplicateTets = n - static_cast<int64_t>(unique);
}

std::string formatNumber(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

} // namespace

QualityResult evaluateQuality(const TetMesh& mesh, const QualityParams& params, Progress& progress) {
  mesh.validateStructure("EvaluateQuality: mesh");
  if (mesh.tets.empty()) throw InputError("EvaluateQuality: the mesh has no tetrahedra");
  const double w = params.bin_width_deg;
  if (!(std::isfinite(w) && w >= kMinBinWidthDeg && w <= 90.0)) {
    std::string msg = "EvaluateQuality: bin width ";
    msg += formatNumber(w);
    msg += " deg is outside [";
    msg += formatNumber(kMinBinWidthDeg);
    msg += ", 90] (the histogram range is 0..180 deg)";
    throw InputError(msg);
  }
  for (const auto& [label, ref] : params.referenceVolumes)
    if (!(std::isfinite(ref) && ref > 0.0)) {
      std::string msg = "EvaluateQuality: reference volume of material ";
      msg += std::to_string(label);
      msg += " is ";
      msg += formatNumber(ref);
      msg += " mm^3; it must be a finite number > 0";
      throw InputError(msg);
    }

  QualityResult r;
  const int64_t n = static_cast<int64_t>(mesh.numTets());
  r.vertices = static_cast<int64_t>(mesh.numPoints());
  r.tets = n;
  r.binWidth = w;
  const size_t nbins = static_cast<size_t>(std::ceil(180.0 / w - 1e-9));
  r.histogram.assign(nbins, 0);

  // ---- per-tet metrics (parallel) ------------------------------------------------------------
  progress.beginStage("metrics");
  std::vector<double> fMin(static_cast<size_t>(n)), fMax(static_cast<size_t>(n)),
      fAspect(static_cast<size_t>(n)), fRadius(static_cast<size_t>(n)), fVol(static_cast<size_t>(n));
  const int64_t blocks = (n + kBlock - 1) / kBlock;
  std::atomic<int64_t> blocksDone{0};
  std::atomic<bool> stop{false};
  double minDih = 180.0, maxDih = 0.0;
  int64_t inverted = 0, zeroVolume = 0, repeated = 0;
  int64_t below0 = 0, below1 = 0, below2 = 0;
#pragma omp parallel reduction(min : minDih) reduction(max : maxDih) \
    reduction(+ : inverted, zeroVolume, repeated, below0, below1, below2)
  {
    std::vector<int64_t> hist(nbins, 0);
#pragma omp for schedule(dynamic, 1)
    for (int64_t blk = 0; blk < blocks; ++blk) {
      if (stop.load(std::memory_order_relaxed)) continue;
      if (progress.cancelRequested()) {
        stop.store(true);
        continue;
      }
      const int64_t end = std::min(n, (blk + 1) * kBlock);
      for (int64_t t = blk * kBlock; t < end; ++t) {
        const size_t ti = static_cast<size_t>(t);
        const auto& q = mesh.tets[ti];
        const TetMetrics m = tetMetrics(mesh.points[static_cast<size_t>(q[0])],
                                        mesh.points[static_cast<size_t>(q[1])],
                                        mesh.points[static_cast<size_t>(q[2])],
                                        mesh.points[static_cast<size_t>(q[3])]);
        fMin[ti] = m.minDihedral;
        fMax[ti] = m.maxDihedral;
        fAspect[ti] = m.aspectRatio;
        fRadius[ti] = m.radiusRatio;
        fVol[ti] = m.volume;
        minDih = std::min(minDih, m.minDihedral);
        maxDih = std::max(maxDih, m.maxDihedral);
        if (m.zeroVolume) ++zeroVolume;
        else if (m.volume < 0.0) ++inverted;
        if (repeatsVertex(q)) ++repeated;
        if (m.minDihedral < kMinDihedralThresholds[0]) ++below0;
        if (m.minDihedral < kMinDihedralThresholds[1]) ++below1;
        if (m.minDihedral < kMinDihedralThresholds[2]) ++below2;
        const size_t bin = std::min(nbins - 1, static_cast<size_t>(m.minDihedral / w));
        ++hist[bin];
      }
      const int64_t done = ++blocksDone;
      if (omp_get_thread_num() == 0) progress.report(double(done) / double(blocks));
    }
#pragma omp critical(tetflow_quality_hist)
    for (size_t b = 0; b < nbins; ++b) r.histogram[b] += hist[b];
  }
  progress.checkCancel();
  r.minDihedral = minDih;
  r.maxDihedral = maxDih;
  r.inverted = inverted;
  r.zeroVolume = zeroVolume;
  r.repeatedVertexTets = repeated;
  r.tetsBelow = {below0, below1, below2};

  // ---- topology: duplicates, faces, boundary, unreferenced vertices -------------------------
  progress.beginStage("topology");
  countDuplicates(mesh, r, progress);
  progress.checkCancel();
  analyzeFaces(mesh, r, progress);
  {
    progress.checkCancel();
    std::vector<uint8_t> used(mesh.numPoints(), 0);
    for (const auto& q : mesh.tets)
      for (int32_t v : q) used[static_cast<size_t>(v)] = 1;
    r.unreferencedVertices =
        static_cast<int64_t>(std::count(used.begin(), used.end(), uint8_t(0)));
  }
  r.valid = r.inverted == 0 && r.zeroVolume == 0 && r.duplicateTets == 0 && r.nonmanifoldFaces == 0;
  progress.checkCancel();

  // ---- statistics: volumes (serial, so sums do not depend on the thread count), medians -----
  progress.beginStage("statistics");
  {
    MaterialQuality* last = nullptr;
    int32_t lastLabel = 0;
    for (size_t t = 0; t < fVol.size(); ++t) {
      const int32_t label = mesh.materials[t];
      if (!last || label != lastLabel) {
        last = &r.materials[label];
        lastLabel = label;
      }
      ++last->tets;
      last->volume += fVol[t];
      r.volume += fVol[t];
    }
  }
  for (const auto& [label, ref] : params.referenceVolumes) {
    auto it = r.materials.find(label);
    if (it == r.materials.end()) {
      r.referenceLabelsMissing.push_back(label);
      continue;
    }
    it->second.hasReference = true;
    it->second.reference = ref;
    it->second.relError = (it->second.volume - ref) / ref;
  }
  {
    std::vector<double> tmp = fAspect;
    r.aspectRatioMin = *std::min_element(tmp.begin(), tmp.end());
    r.aspectRatioMedian = median(tmp);
    tmp = fRadius;
    r.radiusRatioMin = *std::min_element(tmp.begin(), tmp.end());
    r.radiusRatioMedian = median(tmp);
  }
  r.cellFields["min_dihedral"] = Field{1, std::move(fMin)};
  r.cellFields["max_dihedral"] = Field{1, std::move(fMax)};
  r.cellFields["aspect_ratio"] = Field{1, std::move(fAspect)};
  r.cellFields["radius_ratio"] = Field{1, std::move(fRadius)};
  r.cellFields["volume"] = Field{1, std::move(fVol)};
  progress.endStage();
  return r;
}

std::string histogramBinLabel(const QualityResult& r, size_t bin) {
  const double lo = static_cast<double>(bin) * r.binWidth;
  const double hi = std::min(180.0, static_cast<double>(bin + 1) * r.binWidth);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g-%g", lo, hi);
  return buf;
}

void writeQualityReport(const QualityResult& r, Report& report) {
  auto i64 = [](int64_t v) { return ReportValue(v); };
  report.set("tets", i64(r.tets));
  report.set("vertices", i64(r.vertices));
  report.set("valid", ReportValue(r.valid));
  report.set("inverted", i64(r.inverted));
  report.set("zero_volume", i64(r.zeroVolume));
  report.set("repeated_vertex_tets", i64(r.repeatedVertexTets));
  report.set("duplicate_tets", i64(r.duplicateTets));
  report.set("nonmanifold_faces", i64(r.nonmanifoldFaces));
  report.set("interior_faces", i64(r.interiorFaces));
  report.set("boundary_faces", i64(r.boundaryFaces));
  report.set("folded_faces", i64(r.foldedFaces));
  report.set("boundary_edges", i64(r.boundaryEdges));
  report.set("open_boundary_edges", i64(r.openBoundaryEdges));
  report.set("nonmanifold_boundary_edges", i64(r.nonmanifoldBoundaryEdges));
  report.set("boundary_closed", ReportValue(r.boundaryClosed));
  report.set("unreferenced_vertices", i64(r.unreferencedVertices));
  report.set("min_dihedral_deg", ReportValue(r.minDihedral));
  report.set("max_dihedral_deg", ReportValue(r.maxDihedral));
  for (size_t k = 0; k < kMinDihedralThresholds.size(); ++k) {
    std::string key = "tets_below_";
    key += formatNumber(kMinDihedralThresholds[k]);
    key += "deg";
    report.set(key, i64(r.tetsBelow[k]));
  }
  report.set("aspect_ratio_min", ReportValue(r.aspectRatioMin));
  report.set("aspect_ratio_median", ReportValue(r.aspectRatioMedian));
  report.set("radius_ratio_min", ReportValue(r.radiusRatioMin));
  report.set("radius_ratio_median", ReportValue(r.radiusRatioMedian));
  report.set("volume_mm3", ReportValue(r.volume));
  bool anyReference = !r.referenceLabelsMissing.empty();
  for (const auto& [label, mq] : r.materials) {
    std::string key = "material_";
    key += std::to_string(label);
    report.set(key + "_tets", i64(mq.tets));
    report.set(key + "_volume_mm3", ReportValue(mq.volume));
    if (mq.hasReference) {
      anyReference = true;
      report.set(key + "_reference_mm3", ReportValue(mq.reference));
      report.set(key + "_volume_rel_error", ReportValue(mq.relError));
    }
  }
  if (anyReference) {
    std::string missing;
    for (int32_t label : r.referenceLabelsMissing) {
      if (!missing.empty()) missing += ' ';
      missing += std::to_string(label);
    }
    report.set("reference_labels_missing", missing);
  }
  report.set("histogram_bin_deg", ReportValue(r.binWidth));
  std::string hist;
  for (size_t b = 0; b < r.histogram.size(); ++b) {
    if (!hist.empty()) hist += ' ';
    hist += histogramBinLabel(r, b);
    hist += ':';
    hist += std::to_string(r.histogram[b]);
  }
  report.set("min_dihedral_histogram", hist);
}

} // namespace tetflow
