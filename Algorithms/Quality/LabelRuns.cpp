#include "LabelRuns.h"

#include "Algorithms/Quality/LabelTopology.h"

#include <algorithm>
#include <vector>

namespace tetflow {

namespace {
// c[i] &= (a[i] == b[i]): restrict, since a uint8_t store may otherwise alias the labels and keep
// the loop from being vectorised.
void andEqual(uint8_t* __restrict c, const int32_t* __restrict a, const int32_t* __restrict b, int64_t n) {
  for (int64_t i = 0; i < n; ++i) c[i] &= uint8_t(a[i] == b[i]);
}

// Count, prefix-sum and fill: `scan(r, out)` returns the number of runs of row r and writes them
// when out is not null.
template <class Scan>
LabelRows collect(const GridGeometry& g, Scan scan) {
  LabelRows out;
  out.nx = g.dims[0];
  out.ny = g.dims[1];
  out.nz = g.dims[2];
  const int64_t rows = out.rows();
  out.start.assign(size_t(rows) + 1, 0);
#pragma omp parallel for schedule(dynamic, 64)
  for (int64_t r = 0; r < rows; ++r) out.start[size_t(r) + 1] = scan(r, nullptr);
  for (int64_t r = 0; r < rows; ++r) out.start[size_t(r) + 1] += out.start[size_t(r)];
  out.runs.resize(size_t(out.start[size_t(rows)]));
#pragma omp parallel for schedule(dynamic, 64)
  for (int64_t r = 0; r < rows; ++r) scan(r, out.runs.data() + out.start[size_t(r)]);
  return out;
}
} // namespace

LabelRows labelRows(const LabelVolume& v, std::optional<int32_t> only) {
  const int64_t nx = v.grid.dims[0], ny = v.grid.dims[1];
  return collect(v.grid, [&](int64_t r, LabelRun* out) {
    const int32_t* row = v.data.data() + v.index(0, r % ny, r / ny);
    int64_t n = 0;
    for (int64_t i = 0; i < nx;) {
      const int32_t L = row[i];
      const int64_t i0 = i;
      while (i < nx && row[i] == L) ++i;
      if (only && L != *only) continue;
      if (out) out[n] = {int32_t(i0), int32_t(i - 1), L};
      ++n;
    }
    return n;
  });
}

LabelRows coreRows(const LabelVolume& v) {
  const int64_t nx = v.grid.dims[0], ny = v.grid.dims[1], nz = v.grid.dims[2];
  return collect(v.grid, [&](int64_t r, LabelRun* out) {
    const int64_t j = r % ny, k = r / ny;
    const int32_t* row = v.data.data() + v.index(0, j, k);
    const int32_t* around[4] = {j > 0 ? row - nx : nullptr, j + 1 < ny ? row + nx : nullptr,
                                k > 0 ? row - nx * ny : nullptr, k + 1 < nz ? row + nx * ny : nullptr};
    // Per voxel, whether it is a core voxel: plain loops over the row (vectorised), then its runs.
    thread_local std::vector<uint8_t> core;
    core.assign(size_t(nx), 1);
    uint8_t* c = core.data();
    andEqual(c, row, row + 1, nx - 1);     // the voxel after
    andEqual(c + 1, row + 1, row, nx - 1); // the voxel before
    for (const int32_t* o : around)
      if (o) andEqual(c, row, o, nx);
    int64_t n = 0;
    for (int64_t i = 0; i < nx;) {
      if (!c[i]) {
        ++i;
        continue;
      }
      const int64_t i0 = i; // neighbouring core voxels of a row carry one label
      while (i < nx && c[i]) ++i;
      if (out) out[n] = {int32_t(i0), int32_t(i - 1), row[i0]};
      ++n;
    }
    return n;
  });
}

void joinRuns(const LabelRows& rows, DisjointSets& sets, Progress& progress) {
  // Runs of one row with equal labels never abut (they would be one run); across rows, every pair
  // that overlaps with one voxel of slack is visited once: `from` is the first run of the other row
  // that can reach the current one, and only moves forward.
  static constexpr int kForward[4][2] = {{1, 0}, {-1, 1}, {0, 1}, {1, 1}}; // (dy, dz): half of the 8 rows around
  const int64_t ny = rows.ny, nz = rows.nz;
  for (int64_t r = 0; r < rows.rows(); ++r) {
    progress.checkCancelEvery(r);
    const int64_t j = r % ny, k = r / ny;
    for (const auto& f : kForward) {
      const int64_t j2 = j + f[0], k2 = k + f[1];
      if (j2 < 0 || j2 >= ny || k2 >= nz) continue;
      const int64_t r2 = j2 + ny * k2;
      int64_t from = rows.start[size_t(r2)];
      const int64_t end2 = rows.start[size_t(r2) + 1];
      for (int64_t a = rows.start[size_t(r)]; a < rows.start[size_t(r) + 1]; ++a) {
        const LabelRun& x = rows.runs[size_t(a)];
        while (from < end2 && rows.runs[size_t(from)].i1 + 1 < x.i0) ++from;
        for (int64_t b = from; b < end2 && rows.runs[size_t(b)].i0 <= x.i1 + 1; ++b)
          if (rows.runs[size_t(b)].label == x.label) sets.unite(int32_t(a), int32_t(b));
      }
    }
  }
}

std::vector<int32_t> runComponents(const LabelRows& rows, DisjointSets& sets, int32_t& count) {
  std::vector<int32_t> comp(rows.runs.size()), rootComp(rows.runs.size(), -1);
  count = 0;
  for (size_t q = 0; q < rows.runs.size(); ++q) {
    int32_t& c = rootComp[size_t(sets.find(int32_t(q)))];
    if (c < 0) c = count++;
    comp[q] = c;
  }
  return comp;
}

std::vector<uint8_t> corelessVoxels(const LabelVolume& v, Progress& progress) {
  const LabelRows rows = labelRows(v);
  DisjointSets sets(rows.runs.size());
  joinRuns(rows, sets, progress);
  int32_t n = 0;
  const std::vector<int32_t> comp = runComponents(rows, sets, n);
  std::vector<uint8_t> cored(size_t(n), 0);
  forEachCoreRun(rows, coreRows(v), [&](int64_t, int64_t q) { cored[size_t(comp[size_t(q)])] = 1; });
  if (std::all_of(cored.begin(), cored.end(), [](uint8_t c) { return c != 0; })) return {};
  std::vector<uint8_t> perRun(rows.runs.size());
  for (size_t q = 0; q < perRun.size(); ++q) perRun[q] = !cored[size_t(comp[q])];
  std::vector<uint8_t> out(v.data.size());
  paintRuns(rows, perRun, out);
  return out;
}

} // namespace tetflow
