#include "ThinLayers.h"

#include "Algorithms/Quality/LabelRuns.h"
#include "Algorithms/Quality/LabelTopology.h"

#include <algorithm>
#include <map>
#include <cmath>

namespace tetflow {

EdgeTopology::EdgeTopology(const LabelVolume& labels, Mode mode) : labels_(labels), mode_(mode) {
  const GridGeometry& g = labels.grid;
  contacts_ = labelContactPairs(labels);
  // Separating: the voxels of components without a core voxel (one- or two-voxel sheets, rods,
  // specks): a layer of those is lost entirely where an edge misses it, whatever its ends carry.
  if (mode == Mode::Separating) {
    NullProgress np;
    coreless_ = corelessVoxels(labels, np);
    // Components (26-connected, as the certificate counts them) when a label has several: a
    // segment between two of them crosses what keeps them apart (the septum between the
    // ventricles), and missing that merges them.
    LabelImageTopology topo = analyzeLabelImage(labels, np);
    std::map<int32_t, int> perLabel;
    bool several = false;
    for (const auto& c : topo.comps) several = several || ++perLabel[c.label] > 1;
    if (several) comp_ = std::move(topo.comp);
  }
  // Labels in the image: those that touch another (in a box of voxels, every label does when
  // there are two or more), else one.
  std::vector<int32_t> present;
  for (const auto& [a, b] : contacts_) present.insert(present.end(), {a, b});
  std::sort(present.begin(), present.end());
  present.erase(std::unique(present.begin(), present.end()), present.end());
  nothingMisses_ = mode == Mode::Separating && present.size() <= 2 && coreless_.empty() && comp_.empty();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) toIndex_[r][c] = g.direction[c][r] / g.spacing[r];
  voxelSize_ = std::max({g.spacing[0], g.spacing[1], g.spacing[2]});
  for (int a = 0; a < 3; ++a) blocks_[size_t(a)] = (g.dims[size_t(a)] + kBlock - 1) / kBlock;
  const int64_t nb = blocks_[0] * blocks_[1] * blocks_[2];
  uniform_.assign(size_t(nb), 0);
  if (nothingMisses_) return; // no segment needs the blocks
  if (!coreless_.empty()) corelessBlock_.assign(size_t(nb), 0);
  const auto& d = g.dims;
#pragma omp parallel for schedule(dynamic, 64)
  for (int64_t b = 0; b < nb; ++b) {
    const int64_t bi = b % blocks_[0], bj = (b / blocks_[0]) % blocks_[1], bk = b / (blocks_[0] * blocks_[1]);
    const int64_t i0 = std::max<int64_t>(0, bi * kBlock - 1), i1 = std::min(d[0] - 1, (bi + 1) * kBlock);
    const int64_t j0 = std::max<int64_t>(0, bj * kBlock - 1), j1 = std::min(d[1] - 1, (bj + 1) * kBlock);
    const int64_t k0 = std::max<int64_t>(0, bk * kBlock - 1), k1 = std::min(d[2] - 1, (bk + 1) * kBlock);
    const int32_t first = labels.at(i0, j0, k0);
    bool same = true;
    for (int64_t k = k0; k <= k1 && same; ++k)
      for (int64_t j = j0; j <= j1 && same; ++j) {
        const int32_t* row = labels.data.data() + labels.index(0, j, k);
        for (int64_t i = i0; i <= i1; ++i)
          if (row[i] != first) {
            same = false;
            break;
          }
      }
    uniform_[size_t(b)] = same ? 1 : 0;
    if (!coreless_.empty()) {
      bool any = false;
      for (int64_t k = k0; k <= k1 && !any; ++k)
        for (int64_t j = j0; j <= j1 && !any; ++j)
          for (int64_t i = i0; i <= i1 && !any; ++i) any = coreless_[size_t(labels.index(i, j, k))] != 0;
      corelessBlock_[size_t(b)] = any ? 1 : 0;
    }
  }
}

Vec3 EdgeTopology::index(const Vec3& p) const { return mul(toIndex_, p - labels_.grid.origin); }

bool EdgeTopology::touch(int32_t a, int32_t b) const {
  return a == b || std::binary_search(contacts_.begin(), contacts_.end(), std::pair{std::min(a, b), std::max(a, b)});
}

bool EdgeTopology::anyBlock(const std::vector<uint8_t>& flags, const int64_t lo[3], const int64_t hi[3],
                            uint8_t value) const {
  for (int64_t bk = lo[2] / kBlock; bk <= hi[2] / kBlock; ++bk)
    for (int64_t bj = lo[1] / kBlock; bj <= hi[1] / kBlock; ++bj)
      for (int64_t bi = lo[0] / kBlock; bi <= hi[0] / kBlock; ++bi)
        if (flags[size_t(bi + blocks_[0] * (bj + blocks_[1] * bk))] == value) return true;
  return false;
}

void EdgeTopology::voxelBox(const double mn[3], const double mx[3], int64_t lo[3], int64_t hi[3]) const {
  const auto& dims = labels_.grid.dims;
  for (int x = 0; x < 3; ++x) {
    lo[x] = std::clamp<int64_t>(int64_t(std::floor(std::max(mn[x], -1e15) + 0.5 - kTieWidth)), 0, dims[size_t(x)] - 1);
    hi[x] = std::clamp<int64_t>(int64_t(std::floor(std::min(mx[x], 1e15) + 0.5 + kTieWidth)), 0, dims[size_t(x)] - 1);
  }
}

bool EdgeTopology::uniformOver(const Vec3* points, int n) const {
  double mn[3] = {1e300, 1e300, 1e300}, mx[3] = {-1e300, -1e300, -1e300};
  for (int q = 0; q < n; ++q) {
    const Vec3 u = index(points[q]);
    for (int x = 0; x < 3; ++x) {
      mn[x] = std::min(mn[x], u[x]);
      mx[x] = std::max(mx[x], u[x]);
    }
  }
  for (int x = 0; x < 3; ++x)
    if (!(mn[x] <= mx[x])) return false; // NaN, or no points
  int64_t lo[3], hi[3]; // as missesMaterial widens a segment's voxel range
  voxelBox(mn, mx, lo, hi);
  // Uniform blocks next to each other share their halos, so all of them carry the same label.
  return !anyBlock(uniform_, lo, hi, 0);
}

bool EdgeTopology::touchNear(int32_t A, int32_t B, const int64_t lo[3], const int64_t hi[3]) const {
  const auto& d = labels_.grid.dims;
  int64_t b0[3], b1[3];
  int64_t count = 1;
  for (int x = 0; x < 3; ++x) {
    b0[x] = std::max<int64_t>(0, lo[x] - 1);
    b1[x] = std::min<int64_t>(d[size_t(x)] - 1, hi[x] + 1);
    count *= b1[x] - b0[x] + 1;
  }
  if (count > kNearVoxels) return true; // a long edge: the image-wide answer (they touch)
  return labelsTouchInBox(labels_, A, B, b0, b1);
}

namespace {
struct Touch {
  double t0, t1;
  int32_t label;
  bool coreless; // a voxel of a component without a core voxel
};
} // namespace

bool EdgeTopology::missesMaterial(const Vec3& pa, const Vec3& pb) const {
  if (nothingMisses_) return false;
  const Vec3 a = index(pa), b = index(pb);
  const auto& dims = labels_.grid.dims;
  auto voxelIndex = [&](const Vec3& u) {
    int64_t i[3];
    for (int x = 0; x < 3; ++x) i[x] = std::clamp<int64_t>(std::llround(u[x]), 0, dims[size_t(x)] - 1);
    return labels_.index(i[0], i[1], i[2]);
  };
  auto voxelAt = [&](const Vec3& u) { return labels_.data[size_t(voxelIndex(u))]; };
  constexpr double eps = kTieWidth;
  // Voxel range touched (clamped: outside, the boundary voxels continue).
  int64_t lo[3], hi[3];
  {
    const double mn[3] = {std::min(a[0], b[0]), std::min(a[1], b[1]), std::min(a[2], b[2])};
    const double mx[3] = {std::max(a[0], b[0]), std::max(a[1], b[1]), std::max(a[2], b[2])};
    voxelBox(mn, mx, lo, hi);
  }
  bool separated = false; // the ends carry labels kept apart by what lies between them
  if (mode_ == Mode::Separating) {
    const int32_t A = voxelAt(a), B = voxelAt(b);
    separated = A != B ? !touch(A, B) || !touchNear(A, B, lo, hi)
                       : !comp_.empty() && comp_[size_t(voxelIndex(a))] != comp_[size_t(voxelIndex(b))];
    if (separated && splitRatio_ <= 1.0) return true; // every miss counts: no need to measure it
    // Otherwise only a coreless layer (below) counts.
    if (!separated && (corelessBlock_.empty() || !anyBlock(corelessBlock_, lo, hi, 1))) return false;
  }
  // Blocks: all uniform means one label throughout (adjacent uniform blocks share their halos).
  if (!anyBlock(uniform_, lo, hi, 0)) return false;
  // The t-interval of [0, 1] where coordinate x lies in voxel i's slab widened by eps.
  const Vec3 d = b - a;
  auto slab = [&](int x, int64_t i, double& t0, double& t1) {
    // Voxels clamped at the grid's ends extend to infinity.
    const double s0 = i == 0 ? -1e300 : double(i) - 0.5 - eps;
    const double s1 = i == dims[size_t(x)] - 1 ? 1e300 : double(i) + 0.5 + eps;
    if (std::abs(d[x]) < 1e-12) {
      if (a[x] < s0 || a[x] > s1) return false;
      t0 = 0.0;
      t1 = 1.0;
      return true;
    }
    double u = (s0 - a[x]) / d[x], v = (s1 - a[x]) / d[x];
    if (u > v) std::swap(u, v);
    t0 = std::max(0.0, u);
    t1 = std::min(1.0, v);
    return t0 <= t1;
  };
  // Along the longest axis, slab by slab; in each, the few voxels of the other two axes.
  int m = 0;
  for (int x = 1; x < 3; ++x)
    if (std::abs(d[x]) > std::abs(d[m])) m = x;
  const int p = (m + 1) % 3, q = (m + 2) % 3;
  Touch touches[256];
  int n = 0;
  bool overflow = false;
  for (int64_t i = lo[m]; i <= hi[m] && !overflow; ++i) {
    double ta, tb;
    if (!slab(m, i, ta, tb)) continue;
    // Range of the other axes over [ta, tb].
    int64_t r[2][2];
    const int ax[2] = {p, q};
    for (int w = 0; w < 2; ++w) {
      const int x = ax[w];
      const double u = a[x] + ta * d[x], v = a[x] + tb * d[x];
      r[w][0] = std::clamp<int64_t>(int64_t(std::floor(std::min(u, v) + 0.5 - eps)), 0, dims[size_t(x)] - 1);
      r[w][1] = std::clamp<int64_t>(int64_t(std::floor(std::max(u, v) + 0.5 + eps)), 0, dims[size_t(x)] - 1);
    }
    for (int64_t j = r[0][0]; j <= r[0][1] && !overflow; ++j) {
      double ja, jb;
      if (!slab(p, j, ja, jb)) continue;
      for (int64_t k = r[1][0]; k <= r[1][1]; ++k) {
        double ka, kb;
        if (!slab(q, k, ka, kb)) continue;
        const double t0 = std::max({ta, ja, ka}), t1 = std::min({tb, jb, kb});
        if (t0 > t1) continue;
        std::array<int64_t, 3> v;
        v[size_t(m)] = i;
        v[size_t(p)] = j;
        v[size_t(q)] = k;
        if (n == 256) {
          overflow = true;
          break;
        }
        const int64_t at = labels_.index(v[0], v[1], v[2]);
        touches[n++] = {t0, t1, labels_.data[size_t(at)], !coreless_.empty() && coreless_[size_t(at)] != 0};
      }
    }
  }
  if (overflow) return true; // a segment across more than 256 voxels near an interface: split it
  {
    int s = 1;
    while (s < n && touches[s].label == touches[0].label) ++s;
    if (s == n) return false; // one label
  }
  // Per label, the stretches of the segment it covers (touches merged); stretches shorter than
  // kMinStretch voxels (a corner grazed) do not count, except the end's own: the label of the
  // voxel holding each end is the one cleaving sees there, however close it is to another.
  const double minT = kMinStretch / std::max(norm(d), 1e-12);
  const int32_t endLabel[2] = {voxelAt(a), voxelAt(b)};
  // A miss that counts: with splitRatio_ > 1, only when the segment is longer than splitRatio_
  // times what lies between its ends' own stretches (the missed layer's extent along it).
  auto worthSplitting = [&]() {
    if (splitRatio_ <= 1.0) return true;
    std::sort(touches, touches + n, [](const Touch& x, const Touch& y) { return x.t0 < y.t0; });
    double fromA = 0.0; // the end of the stretch of a's label that starts at a
    for (int s = 0; s < n; ++s)
      if (touches[s].label == endLabel[0] && touches[s].t0 <= fromA + minT) fromA = std::max(fromA, touches[s].t1);
    double toB = 1.0; // the start of the stretch of b's label that ends at b
    for (int s = n - 1; s >= 0; --s)
      if (touches[s].label == endLabel[1] && touches[s].t1 >= toB - minT) toB = std::min(toB, touches[s].t0);
    const double extent = std::max(0.0, toB - fromA) * norm(pb - pa); // mm
    return norm(pb - pa) > splitRatio_ * extent;
  };
  if (separated) return worthSplitting();
  if (mode_ == Mode::Separating &&
      std::none_of(touches, touches + n, [&](const Touch& x) {
        return x.coreless && x.label != endLabel[0] && x.label != endLabel[1];
      }))
    return false; // no coreless layer between the ends
  auto counts = [&](int32_t label, double t0, double t1) {
    return t1 - t0 >= minT || (t0 <= 0.0 && label == endLabel[0]) || (t1 >= 1.0 && label == endLabel[1]);
  };
  std::sort(touches, touches + n, [](const Touch& x, const Touch& y) {
    return x.label != y.label ? x.label < y.label : x.t0 < y.t0;
  });
  int nl = 0; // labels with a stretch
  for (int s = 0; s < n;) {
    const int32_t label = touches[s].label;
    int stretches = 0;
    double t0 = touches[s].t0, t1 = touches[s].t1;
    for (; s < n && touches[s].label == label; ++s) {
      if (touches[s].t0 <= t1 + minT) { // a gap shorter than kMinStretch (a corner grazed) does not count
        t1 = std::max(t1, touches[s].t1);
        continue;
      }
      if (counts(label, t0, t1)) ++stretches;
      t0 = touches[s].t0;
      t1 = touches[s].t1;
    }
    if (counts(label, t0, t1)) ++stretches;
    if (stretches == 0) continue;
    if (stretches > 1 || ++nl == 3) // it comes back after a stretch of something else, or a third label
      return worthSplitting();
  }
  return false;
}

std::vector<uint8_t> tetsMissingMaterials(const TetMesh& mesh, const EdgeTopology& topology, Progress& progress,
                                          const std::vector<uint8_t>* only) {
  static constexpr int kEdge[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  const int64_t n = int64_t(mesh.numTets());
  std::vector<uint8_t> out(size_t(n), 0);
  if (topology.nothingMisses()) return out;
  LoopCancel cancel(progress);
#pragma omp parallel for schedule(dynamic, 4096)
  for (int64_t t = 0; t < n; ++t) {
    if (cancel.skip(t) || (only && !(*only)[size_t(t)])) continue;
    const auto& q = mesh.tets[size_t(t)];
    const Vec3 corners[4] = {mesh.points[size_t(q[0])], mesh.points[size_t(q[1])], mesh.points[size_t(q[2])],
                             mesh.points[size_t(q[3])]};
    if (topology.uniformOver(corners, 4)) continue; // one label around: no edge misses anything
    for (const auto& e : kEdge)
      if (topology.missesMaterial(mesh.points[size_t(q[e[0]])], mesh.points[size_t(q[e[1]])])) {
        out[size_t(t)] = 1;
        break;
      }
  }
  cancel.rethrow();
  return out;
}

} // namespace tetflow
