// Which tet holds each voxel centre of a label image (the certificate's voxel agreement and
// coverage), without an array of one tet per voxel: two bits per voxel say whether no tet, one tet
// or several tets hold its centre, and only the voxels several tets hold (centres on shared faces,
// edges or vertices, or in overlapping tets) are listed with their tets.
#pragma once

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <vector>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Geometry.h"
#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/Core/Volume.h"

namespace tetflow {

class VoxelOwners {
public:
  // A voxel centre x (voxel-index coordinates) is held by tet t when each of the four volumes of t
  // with x in place of one of its vertices, signed like t's own, is at least -1e-9 |vol(t)| (its
  // closed region, a little widened); its owner is the smallest tet that holds it. Tets of zero
  // volume hold nothing.
  //
  // One pass over the tets (on every thread) calls hold(thread, voxel, tet, +1) for every voxel
  // and tet that holds it; then, for each voxel that more than one tet holds, hold(0, voxel, tet,
  // -1) for each of its holders that is not the owner (found from the first pass's claims near
  // faces, or by a second pass when tets overlap).
  // So the sum of weight * f(voxel, tet) over the calls is the sum of f over the voxels the mesh
  // holds, each with its owner. thread is omp_get_thread_num() (< omp_get_max_threads()), and calls
  // of one thread never overlap. Throws Cancelled when progress asks.
  template <class Hold>
  VoxelOwners(const TetMesh& mesh, const GridGeometry& g, Progress& progress, Hold&& hold);

  // visit(thread, voxel, tet) once for every voxel the mesh holds, with its owner, from the thread
  // that scans that tet (so a tet's own entries may be written without atomics). One pass.
  template <class Visit>
  void forEachOwned(Visit&& visit) const;

  // The mesh's points in voxel-index coordinates (IndexFrame).
  const std::vector<Vec3>& indexPoints() const { return ip_; }

  // Voxels that more than one tet holds.
  int64_t sharedVoxels() const { return static_cast<int64_t>(shared_.size()); }

private:
  struct Held {
    int64_t voxel;
    int32_t tet;
    bool operator<(const Held& o) const { return voxel != o.voxel ? voxel < o.voxel : tet < o.tet; }
  };
  // emit(voxel, tet, deep) for every voxel centre every tet holds, in parallel over the tets; deep:
  // its four volumes are all at least 1e-6 of the tet's (far from every face).
  template <class Emit>
  void scan(Emit&& emit) const;
  VoxelOwners(const TetMesh& mesh, const GridGeometry& g, Progress& progress); // ip_, words_
  // Read only after the constructor's marking (no writer left).
  uint32_t state(int64_t v) const { return (words_[size_t(v >> 4)] >> (2 * (v & 15))) & 3u; }
  int32_t sharedOwner(int64_t v) const {
    const auto it = std::lower_bound(shared_.begin(), shared_.end(), Held{v, -1});
    return it != shared_.end() && it->voxel == v ? it->tet : -1;
  }

  const TetMesh& mesh_;
  GridGeometry g_;
  Progress& progress_;
  std::vector<Vec3> ip_;        // mesh points in voxel-index coordinates
  std::vector<uint32_t> words_; // 2 bits per voxel: 1 or 2 held once, 3 held more than once
  std::vector<Held> shared_;    // voxels held more than once, with their owners, by voxel
};

template <class Emit>
void VoxelOwners::scan(Emit&& emit) const {
  const int64_t nx = g_.dims[0], ny = g_.dims[1];
  const int64_t nTets = static_cast<int64_t>(mesh_.numTets());
  LoopCancel cancel(progress_);
#pragma omp parallel for schedule(dynamic, 4096)
  for (int64_t t = 0; t < nTets; ++t) {
    if (cancel.skip(t)) continue;
    const auto& q = mesh_.tets[static_cast<size_t>(t)];
    const Vec3 P[4] = {ip_[size_t(q[0])], ip_[size_t(q[1])], ip_[size_t(q[2])], ip_[size_t(q[3])]};
    int64_t lo[3], hi[3];
    bool empty = false;
    double reach = 1.0; // largest coordinate magnitude (for rounding bounds)
    for (int a = 0; a < 3; ++a) {
      const double mn = std::min({P[0][a], P[1][a], P[2][a], P[3][a]});
      const double mx = std::max({P[0][a], P[1][a], P[2][a], P[3][a]});
      lo[a] = std::max<int64_t>(0, static_cast<int64_t>(std::ceil(mn - 1e-9)));
      hi[a] = std::min<int64_t>(g_.dims[a] - 1, static_cast<int64_t>(std::floor(mx + 1e-9)));
      if (lo[a] > hi[a]) empty = true;
      reach = std::max({reach, std::abs(mn), std::abs(mx)});
    }
    if (empty) continue;
    const double vol = signedTetVolume(P[0], P[1], P[2], P[3]);
    if (vol == 0.0) continue;
    const double tol = -1e-9 * std::abs(vol);
    const double deep = 1e-6 * std::abs(vol); // all four at least this: far from every face
    const double s = vol > 0 ? 1.0 : -1.0;
    // The test that decides: the four volumes with x in a vertex's place; emits whether x is deep.
    auto test = [&](int64_t i, int64_t j, int64_t k) {
      const Vec3 x{double(i), double(j), double(k)};
      const double least = std::min({s * signedTetVolume(x, P[1], P[2], P[3]), s * signedTetVolume(P[0], x, P[2], P[3]),
                                     s * signedTetVolume(P[0], P[1], x, P[3]), s * signedTetVolume(P[0], P[1], P[2], x)});
      if (least >= tol) emit(i + nx * (j + ny * k), static_cast<int32_t>(t), least >= deep);
    };
    if ((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1) <= 16) { // few voxels: test each
      for (int64_t k = lo[2]; k <= hi[2]; ++k)
        for (int64_t j = lo[1]; j <= hi[1]; ++j)
          for (int64_t i = lo[0]; i <= hi[0]; ++i) test(i, j, k);
      continue;
    }
    // Each volume is affine in x: n_f . (x - a_f), a_f one of the other three vertices (x moved
    // from place f to the last place takes 3 - f swaps). Along a row (j, k fixed) the planes bound
    // i, and a voxel whose four plane values clear tol by more than the two forms' rounding is
    // decided without the test.
    Vec3 n[4], a[4];
    for (int f = 0; f < 4; ++f) {
      const Vec3& p0 = P[f == 0 ? 1 : 0];
      const Vec3& p1 = P[f <= 1 ? 2 : 1];
      const Vec3& p2 = P[f <= 2 ? 3 : 2];
      n[f] = ((f % 2 == 1 ? 1.0 : -1.0) * s / 6.0) * cross(p1 - p0, p2 - p0);
      a[f] = p0;
    }
    double extent = 1.0;
    for (int ax = 0; ax < 3; ++ax) extent = std::max(extent, double(hi[ax] - lo[ax] + 2));
    const double margin = 1e-9 * std::abs(vol) + 1e-12 * (reach + extent) * extent * extent;
    const double outer = tol - margin, inner = tol + margin;
    for (int64_t k = lo[2]; k <= hi[2]; ++k)
      for (int64_t j = lo[1]; j <= hi[1]; ++j) {
        const Vec3 X{double(lo[0]), double(j), double(k)};
        double v0[4];
        double from = double(lo[0]), to = double(hi[0]);
        bool none = false;
        for (int f = 0; f < 4; ++f) {
          v0[f] = dot(n[f], X - a[f]);
          const double gx = n[f][0];
          if (gx > 0) from = std::max(from, double(lo[0]) + (outer - v0[f]) / gx);
          else if (gx < 0) to = std::min(to, double(lo[0]) + (outer - v0[f]) / gx);
          else if (v0[f] < outer) none = true;
        }
        if (none || !(from <= to + 2.0)) continue;
        const int64_t i0 = std::max<int64_t>(lo[0], static_cast<int64_t>(std::ceil(from)) - 1);
        const int64_t i1 = std::min<int64_t>(hi[0], static_cast<int64_t>(std::floor(to)) + 1);
        for (int64_t i = i0; i <= i1; ++i) {
          const double di = double(i - lo[0]);
          double least = v0[0] + n[0][0] * di;
          for (int f = 1; f < 4; ++f) least = std::min(least, v0[f] + n[f][0] * di);
          if (least < outer) continue;
          if (least < inner) test(i, j, k);
          else emit(i + nx * (j + ny * k), static_cast<int32_t>(t), least >= deep);
        }
      }
  }
  cancel.rethrow();
}

template <class Hold>
VoxelOwners::VoxelOwners(const TetMesh& mesh, const GridGeometry& g, Progress& progress, Hold&& hold)
    : VoxelOwners(mesh, g, progress) {
  // Two bits per voxel: 0 not held, 1 held once and near a face of its tet, 2 held once and deep
  // inside, 3 held more than once. In a mesh whose tets do not overlap, a voxel two tets hold is
  // near a face of both, so the claims near faces (listed as they come) are all the claims of the
  // voxels held more than once; only when a deep claim meets another does a second pass find them.
  std::atomic<bool> deepMet{false};
  std::vector<std::vector<Held>> held(static_cast<size_t>(omp_get_max_threads()));
  scan([&](int64_t v, int32_t t, bool deep) {
    std::atomic_ref<uint32_t> w(words_[size_t(v >> 4)]);
    const int shift = int(2 * (v & 15));
    uint32_t old = w.load(std::memory_order_relaxed);
    for (;;) {
      const uint32_t was = (old >> shift) & 3u, now = was == 0u ? (deep ? 2u : 1u) : 3u;
      if (was != 0u && (deep || was == 2u)) deepMet.store(true, std::memory_order_relaxed);
      if (was == now || w.compare_exchange_weak(old, (old & ~(3u << shift)) | (now << shift), std::memory_order_relaxed))
        break;
    }
    const int me = omp_get_thread_num();
    if (!deep) held[size_t(me)].push_back({v, t});
    hold(me, v, t, 1);
  });
  if (deepMet.load()) {
    for (auto& h : held) std::vector<Held>().swap(h);
    scan([&](int64_t v, int32_t t, bool) {
      if (state(v) == 3u) held[size_t(omp_get_thread_num())].push_back({v, t});
    });
  } else {
    for (auto& h : held) std::erase_if(h, [&](const Held& x) { return state(x.voxel) != 3u; });
  }
  size_t total = 0;
  for (const auto& h : held) total += h.size();
  std::vector<Held> all;
  all.reserve(total);
  for (auto& h : held) {
    all.insert(all.end(), h.begin(), h.end());
    std::vector<Held>().swap(h);
  }
  std::sort(all.begin(), all.end());
  for (size_t i = 0; i < all.size(); ++i) {
    if (i == 0 || all[i].voxel != all[i - 1].voxel) shared_.push_back(all[i]);
    else hold(0, all[i].voxel, all[i].tet, -1);
  }
}

template <class Visit>
void VoxelOwners::forEachOwned(Visit&& visit) const {
  scan([&](int64_t v, int32_t t, bool) {
    if (state(v) != 3u || sharedOwner(v) == t) visit(omp_get_thread_num(), v, t);
  });
}

} // namespace tetflow
