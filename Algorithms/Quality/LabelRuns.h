#pragma once
// A label volume as runs along x: each row (j, k) is cut where its label changes. Components,
// cores and contacts of the image are found on the runs (a few per row on real segmentations)
// instead of on every voxel; the voxel data are read once per scan.
#include <algorithm>
#include <cstdint>
#include <optional>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Volume.h"

namespace tetflow {

struct DisjointSets;

struct LabelRun {
  int32_t i0 = 0, i1 = 0; // first and last voxel, inclusive
  int32_t label = 0;
};

// Runs of rows r = j + ny k: runs[start[r] .. start[r + 1]), ascending in x.
struct LabelRows {
  int64_t nx = 0, ny = 0, nz = 0;
  std::vector<int64_t> start;
  std::vector<LabelRun> runs;
  int64_t rows() const { return ny * nz; }
};

// Every label's runs (they tile each row), or only label `only`'s. Both cores.
LabelRows labelRows(const LabelVolume& v, std::optional<int32_t> only = std::nullopt);

// The runs of core voxels (voxels whose six face neighbours carry their label; outside the volume
// counts as the same label). Both cores.
LabelRows coreRows(const LabelVolume& v);

// Joins (sets over run indices) the runs of equal labels that are 26-connected: in the same row when
// they abut, in the 8 rows around when they overlap in x with one voxel of slack.
void joinRuns(const LabelRows& rows, DisjointSets& sets, Progress& progress);

// The component of every run (its set in `sets`, after joinRuns), numbered in the scan order of
// the components' first runs; `count` receives the number of components.
std::vector<int32_t> runComponents(const LabelRows& rows, DisjointSets& sets, int32_t& count);

// For every core run c (coreRows of the same volume): fn(c, q), q the run of `rows` (labelRows of
// every label) that holds it.
template <class F>
void forEachCoreRun(const LabelRows& rows, const LabelRows& cores, F&& fn) {
  for (int64_t r = 0; r < rows.rows(); ++r) {
    int64_t q = rows.start[size_t(r)];
    for (int64_t c = cores.start[size_t(r)]; c < cores.start[size_t(r) + 1]; ++c) {
      while (rows.runs[size_t(q)].i1 < cores.runs[size_t(c)].i0) ++q;
      fn(c, q);
    }
  }
}

// out[voxel] = perRun[run] over the voxels of every run (others untouched); out has one entry per
// voxel of the volume the rows were made from. Both cores.
template <class T>
void paintRuns(const LabelRows& rows, const std::vector<T>& perRun, std::vector<T>& out) {
#pragma omp parallel for schedule(dynamic, 64)
  for (int64_t r = 0; r < rows.rows(); ++r) {
    T* row = out.data() + rows.nx * r;
    for (int64_t q = rows.start[size_t(r)]; q < rows.start[size_t(r) + 1]; ++q)
      std::fill(row + rows.runs[size_t(q)].i0, row + rows.runs[size_t(q)].i1 + 1, perRun[size_t(q)]);
  }
}

// Per voxel, 1 when its component (26-connected, equal labels) has no core voxel (a one- or
// two-voxel sheet, rod or speck); empty when every component has one. Memory: the runs, and the
// flags only when there is such a component.
std::vector<uint8_t> corelessVoxels(const LabelVolume& v, Progress& progress);

} // namespace tetflow
