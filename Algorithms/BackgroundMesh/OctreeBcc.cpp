#include "OctreeBcc.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include "Algorithms/Core/CancellableSort.h"
#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/MemoryBudget.h"
#include "ThinLayers.h"

namespace tetflow {

namespace {

constexpr int kMaxLevels = 12; // levels below the roots
constexpr int kThinRounds = 2; // mesh rounds of the thin-layer refinement (graded tets only)
constexpr int64_t kMaxTets = (int64_t(1) << 31) - 1;
constexpr double kOctreeBytesPerLeaf = 16 * kBccBytesPerTet + 64;

std::string formatNumber(double x) {
  std::ostringstream o;
  o << x;
  return o.str();
}

// Leaf key: level (4 bits) and the cell index at that level (20 bits per axis).
uint64_t leafKey(int level, int64_t i, int64_t j, int64_t k) {
  return uint64_t(level) << 60 | uint64_t(k) << 40 | uint64_t(j) << 20 | uint64_t(i);
}
int keyLevel(uint64_t key) { return int(key >> 60); }
std::array<int64_t, 3> keyIndex(uint64_t key) {
  const uint64_t m = (uint64_t(1) << 20) - 1;
  return {int64_t(key & m), int64_t((key >> 20) & m), int64_t((key >> 40) & m)};
}
// Child q (bits: x, y, z) of a cell.
uint64_t childKey(uint64_t key, int q) {
  const int l = keyLevel(key);
  const auto idx = keyIndex(key);
  return leafKey(l + 1, 2 * idx[0] + (q & 1), 2 * idx[1] + ((q >> 1) & 1), 2 * idx[2] + ((q >> 2) & 1));
}
// The finest cell just outside a leaf (index idx, s finest cells per edge) in direction
// d = 0..26 (offsets -1/0/+1 per axis, x fastest; 13 is the leaf itself).
std::array<int64_t, 3> neighbourProbe(const std::array<int64_t, 3>& idx, int64_t s, int d) {
  const int dd[3] = {d % 3 - 1, (d / 3) % 3 - 1, d / 9 - 1};
  std::array<int64_t, 3> f;
  for (int a = 0; a < 3; ++a)
    f[size_t(a)] = dd[a] < 0 ? idx[size_t(a)] * s - 1 : dd[a] > 0 ? (idx[size_t(a)] + 1) * s : idx[size_t(a)] * s;
  return f;
}
// Vertex key: half-finest-cell coordinates (21 bits per axis).
uint64_t vertexKey(int64_t x, int64_t y, int64_t z) { return uint64_t(z) << 42 | uint64_t(y) << 21 | uint64_t(x); }

// Smallest sizing value over the physical box spanned by `corners` (mm).
class SizingOracle {
public:
  explicit SizingOracle(const ScalarVolume& v) : v_(v) {
    const Mat3& d = v.grid.direction;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) inv_[r][c] = d[c][r] / v.grid.spacing[r];
  }
  float minOver(const std::array<Vec3, 8>& corners) const {
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    for (const Vec3& p : corners) {
      const Vec3 q = mul(inv_, p - v_.grid.origin);
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], q[a]);
        hi[a] = std::max(hi[a], q[a]);
      }
    }
    int64_t b[3], e[3];
    for (int a = 0; a < 3; ++a) {
      const int64_t n = v_.grid.dims[size_t(a)];
      b[a] = std::clamp<int64_t>(int64_t(std::ceil(lo[a] - 1e-9)), 0, n - 1);
      e[a] = std::clamp<int64_t>(int64_t(std::floor(hi[a] + 1e-9)), 0, n - 1);
      if (e[a] < b[a]) { // no sample inside along this axis: the nearest one
        const int64_t c = std::clamp<int64_t>(std::llround(0.5 * (lo[a] + hi[a])), 0, n - 1);
        b[a] = e[a] = c;
      }
    }
    float m = std::numeric_limits<float>::max();
    for (int64_t k = b[2]; k <= e[2]; ++k)
      for (int64_t j = b[1]; j <= e[1]; ++j)
        for (int64_t i = b[0]; i <= e[0]; ++i) m = std::min(m, v_.at(i, j, k));
    return m;
  }

private:
  const ScalarVolume& v_;
  Mat3 inv_;
};

} // namespace

int SizingOctree::levelAt(const std::array<int64_t, 3>& f, int near) const {
  for (int a = 0; a < 3; ++a)
    if (f[size_t(a)] < 0 || f[size_t(a)] >= (roots[size_t(a)] << finestLevel)) return -1;
  auto holds = [&](int l) {
    if (l < 0 || l > finestLevel) return false;
    const int sh = finestLevel - l;
    return leafSet.count(leafKey(l, f[0] >> sh, f[1] >> sh, f[2] >> sh)) > 0;
  };
  // Exactly one leaf holds f, so the order of the tries changes nothing but their number.
  if (near >= 0)
    for (int l : {near, near - 1, near + 1})
      if (holds(l)) return l;
  for (int l = 0; l <= finestLevel; ++l)
    if (holds(l)) return l;
  return -1; // unreachable: the leaves tile the box
}

void SizingOctree::split(uint64_t key, std::vector<uint64_t>* touched) {
  leafSet.erase(key);
  for (int q = 0; q < 8; ++q) {
    const uint64_t child = childKey(key, q);
    leafSet.insert(child);
    if (touched) touched->push_back(child);
  }
}

int64_t SizingOctree::balance(std::vector<uint64_t> queue, const Progress* progress, std::vector<uint64_t>* created) {
  int64_t splits = 0, popped = 0;
  const int L = finestLevel;
  while (!queue.empty()) {
    if (progress) progress->checkCancelEvery(++popped, 16);
    const uint64_t key = queue.back();
    queue.pop_back();
    if (!leafSet.count(key)) continue;
    const int l = keyLevel(key);
    if (l < 2) continue;
    const auto idx = keyIndex(key);
    const int64_t s = int64_t(1) << (L - l);
    for (int d = 0; d < 27; ++d) {
      if (d == 13) continue;
      const std::array<int64_t, 3> f = neighbourProbe(idx, s, d);
      for (int m = levelAt(f); m >= 0 && m < l - 1; m = levelAt(f)) {
        const int sh = L - m;
        const size_t before = queue.size();
        split(leafKey(m, f[0] >> sh, f[1] >> sh, f[2] >> sh), &queue);
        if (created) created->insert(created->end(), queue.begin() + std::ptrdiff_t(before), queue.end());
        ++splits;
      }
    }
  }
  return splits;
}

void SizingOctree::finish(OctreeBccStats& st, const Progress* progress) {
  leaves.assign(leafSet.begin(), leafSet.end());
  if (progress) cancellableSort(leaves, *progress);
  else std::sort(leaves.begin(), leaves.end());
  st.leavesPerLevel.assign(size_t(finestLevel + 1), 0);
  int deepest = 0;
  for (uint64_t key : leaves) {
    ++st.leavesPerLevel[size_t(keyLevel(key))];
    deepest = std::max(deepest, keyLevel(key));
  }
  while (!st.leavesPerLevel.empty() && st.leavesPerLevel.back() == 0) st.leavesPerLevel.pop_back();
  const double rootLongest = std::max({rootSize[0], rootSize[1], rootSize[2]});
  st.levels = deepest + 1;
  st.rootCellSize = rootLongest;
  st.finestCellSize = rootLongest / double(int64_t(1) << deepest);
}

int SizingOctree::leafLevel(size_t i) const { return keyLevel(leaves[i]); }
std::array<int64_t, 3> SizingOctree::leafIndex(size_t i) const { return keyIndex(leaves[i]); }

Vec3 SizingOctree::halfToLocal(int64_t x, int64_t y, int64_t z) const {
  const double fine = 2.0 * double(int64_t(1) << finestLevel);
  return {lo[0] + double(x) * rootSize[0] / fine, lo[1] + double(y) * rootSize[1] / fine,
          lo[2] + double(z) * rootSize[2] / fine};
}

namespace {

// Does one of the leaf's BCC edges miss a material? Its 12 cube edges, the 8 from its centre to
// its corners, and the 6 from its centre to the centres of same-size neighbours (to the face centre
// on the box), as if every neighbour were of its size.
bool leafMissesMaterial(const SizingOctree& tree, uint64_t key, const GridGeometry& grid, const EdgeTopology& topo) {
  if (topo.nothingMisses()) return false;
  const int L = tree.finestLevel;
  const auto idx = keyIndex(key);
  const int64_t s = int64_t(1) << (L - keyLevel(key));
  auto at = [&](int64_t x, int64_t y, int64_t z) { return grid.origin + mul(grid.direction, tree.halfToLocal(x, y, z)); };
  Vec3 corner[8];
  for (int q = 0; q < 8; ++q)
    corner[q] = at(2 * s * (idx[0] + (q & 1)), 2 * s * (idx[1] + ((q >> 1) & 1)), 2 * s * (idx[2] + ((q >> 2) & 1)));
  const std::array<int64_t, 3> c{2 * s * idx[0] + s, 2 * s * idx[1] + s, 2 * s * idx[2] + s};
  const Vec3 centre = at(c[0], c[1], c[2]);
  {
    // Every edge below lies within the cell grown by half a cell on each side (the neighbours'
    // centres): when one label covers that, none misses anything.
    Vec3 reach[8];
    for (int q = 0; q < 8; ++q)
      reach[q] = at(2 * s * idx[0] + s * (4 * (q & 1) - 1), 2 * s * idx[1] + s * (4 * ((q >> 1) & 1) - 1),
                    2 * s * idx[2] + s * (4 * ((q >> 2) & 1) - 1));
    if (topo.uniformOver(reach, 8)) return false;
  }
  for (int q = 0; q < 8; ++q)
    if (topo.missesMaterial(centre, corner[q])) return true;
  for (int q = 0; q < 8; ++q)
    for (int bit = 1; bit < 8; bit <<= 1)
      if (!(q & bit) && topo.missesMaterial(corner[q], corner[q | bit])) return true;
  for (int a = 0; a < 3; ++a)
    for (int sign = -1; sign <= 1; sign += 2) {
      std::array<int64_t, 3> o = c;
      const int64_t end = 2 * (tree.roots[size_t(a)] << L);
      o[size_t(a)] += sign * 2 * s;
      if (o[size_t(a)] >= 0 && o[size_t(a)] <= end) {
        if (topo.missesMaterial(centre, at(o[0], o[1], o[2]))) return true;
        continue;
      }
      // On the box: the face centre, joined to the centre and to the face's corners.
      o[size_t(a)] = c[size_t(a)] + sign * s;
      const Vec3 fc = at(o[0], o[1], o[2]);
      if (topo.missesMaterial(centre, fc)) return true;
      const int bit = 1 << a;
      for (int q = 0; q < 8; ++q)
        if (((q & bit) != 0) == (sign > 0) && topo.missesMaterial(fc, corner[q])) return true;
    }
  return false;
}

// Splits the candidate leaves above tree.thinLevel while an edge of theirs misses a material
// (children are tested in turn), then restores the balance, and tests the leaves the balance made
// in turn, until nothing splits. Leaves are visited in key order, so the tree does not depend on
// the thread count. Returns the leaves split for thin layers.
int64_t splitThinLayerLeaves(SizingOctree& tree, const GridGeometry& grid, const EdgeTopology& topo, Progress& progress,
                             std::vector<uint64_t> cand, OctreeBccStats& st) {
  int64_t splits = 0;
  std::vector<uint64_t> touched;
  auto keep = [&](std::vector<uint64_t>& v) {
    v.erase(std::remove_if(v.begin(), v.end(),
                           [&](uint64_t k) { return keyLevel(k) >= tree.thinLevel || !tree.leafSet.count(k); }),
            v.end());
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  };
  keep(cand);
  while (!cand.empty()) {
    while (!cand.empty()) {
      std::vector<uint8_t> flag(cand.size(), 0);
      const int64_t nc = int64_t(cand.size());
      LoopCancel cancel(progress);
#pragma omp parallel for schedule(dynamic, 256)
      for (int64_t c = 0; c < nc; ++c) {
        if (cancel.skip(c)) continue;
        flag[size_t(c)] = leafMissesMaterial(tree, cand[size_t(c)], grid, topo) ? 1 : 0;
      }
      cancel.rethrow();
      std::vector<uint64_t> next;
      for (size_t c = 0; c < cand.size(); ++c) {
        if (!flag[c]) continue;
        tree.split(cand[c], &next);
        ++splits;
      }
      touched.insert(touched.end(), next.begin(), next.end());
      const double leaves = double(tree.leafSet.size());
      // Leaves at thin layers go as the thin-layer cell size^-2.
      requireMemory(kOctreeBytesPerLeaf * leaves,
                    "the octree refined at thin layers (" + std::to_string(tree.leafSet.size()) + " leaves)",
                    [&](double avail) {
                      const double need = st.thinLayerCellSize * std::sqrt(kOctreeBytesPerLeaf * leaves / std::max(avail, 1.0)) * 1.05;
                      return "raise thin_layer_cell_size to >= " + formatNumber(roundUpForAdvice(need)) +
                             " mm, or set refine_thin_layers to none";
                    });
      if (leaves * 24 > double(kMaxTets))
        throw InputError("refining the background at thin layers asks for more than " + std::to_string(kMaxTets / 24) +
                         " octree leaves; raise thin_layer_cell_size or cell_size");
      keep(next);
      cand.swap(next);
      progress.checkCancel();
    }
    // The balance splits leaves whose new edges have not been tested yet.
    std::vector<uint64_t> created;
    st.balanceSplits += tree.balance(std::move(touched), &progress, &created);
    touched.clear();
    keep(created);
    cand.swap(created);
  }
  return splits;
}

// The level whose leaves first have a longest edge <= cell (mm); 0 when the roots do.
int levelFor(double rootLongest, double cell) {
  int l = 0;
  while (l <= kMaxLevels && rootLongest / double(int64_t(1) << l) > cell * (1 + 1e-9)) ++l;
  return l;
}

double thinCellSize(const OctreeBccParams& p, const EdgeTopology& topo) {
  if (!(p.thin_layer_cell_size >= 0.0) || !std::isfinite(p.thin_layer_cell_size))
    throw InputError("thin_layer_cell_size must be >= 0 mm (0 = the voxel size, within a factor sqrt 2)");
  // By default the level whose cells are nearest the voxel size: at most sqrt(2) voxels, so that
  // halving gives no less than 1 / sqrt(2) voxels.
  return p.thin_layer_cell_size > 0 ? p.thin_layer_cell_size : std::sqrt(2.0) * topo.voxelSize();
}

void requireLevels(int L, const std::array<int64_t, 3>& n, double rootLongest, double thinCell) {
  if (L > kMaxLevels) {
    std::ostringstream m;
    m << "thin_layer_cell_size " << thinCell << " mm needs more than " << kMaxLevels
      << " octree levels below cells of " << rootLongest << " mm; raise thin_layer_cell_size";
    throw InputError(m.str());
  }
  for (int a = 0; a < 3; ++a)
    if ((n[size_t(a)] << L) >= (int64_t(1) << 20)) {
      std::ostringstream m;
      m << "refining at thin layers would give " << (n[size_t(a)] << L) << " finest cells along axis " << a
        << "; raise thin_layer_cell_size";
      throw InputError(m.str());
    }
}

} // namespace

SizingOctree buildSizingOctree(const GridGeometry& grid, const ScalarVolume& sizing, const OctreeBccParams& p,
                               OctreeBccStats& st, Progress& progress, const EdgeTopology* thin) {
  grid.validate("background mesh: volume");
  if (!(p.padding >= 0.0) || !std::isfinite(p.padding)) throw InputError("padding must be >= 0 mm");
  if (!(p.min_cell_size >= 0.0) || !std::isfinite(p.min_cell_size))
    throw InputError("min_cell_size must be >= 0 mm (0 = the sizing field's minimum)");
  if (!(p.max_cell_size >= 0.0) || !std::isfinite(p.max_cell_size))
    throw InputError("max_cell_size must be >= 0 mm (0 = the sizing field's maximum)");
  const SizeRange range = checkSizingField(sizing);
  const float smin = range.min, smax = range.max;
  // A defaulted bound follows the one that was given (min_size 4 with max_cell_size 2 asks for a
  // uniform 2 mm lattice, not for an error about a parameter left at 0).
  double minCell = p.min_cell_size > 0 ? p.min_cell_size : double(smin);
  double maxCell = p.max_cell_size > 0 ? p.max_cell_size : double(smax);
  if (p.min_cell_size <= 0) minCell = std::min(minCell, maxCell);
  if (p.max_cell_size <= 0) maxCell = std::max(maxCell, minCell);
  if (minCell > maxCell) {
    std::ostringstream m;
    m << "min_cell_size " << minCell << " mm is larger than max_cell_size " << maxCell << " mm";
    throw InputError(m.str());
  }

  progress.beginStage("octree");
  // Root cells.
  Vec3 lo, len, h;
  int64_t n[3];
  double rootLongest = 0;
  // With thin layers, root cells of a power of two times the voxel (OctreeBcc.h): every level
  // falls on the same sizes whatever maximum was asked for (a 6 mm root on 1 mm voxels would
  // otherwise refine to 0.75 mm, a 5.5 mm one to 1.375 mm).
  BccParams roots;
  roots.cell_size = maxCell;
  if (thin && !thin->nothingMisses() && p.snap_roots) roots.snap_voxel = thin->voxelSize();
  const double rootTarget = bccSnappedCell(roots);
  for (int a = 0; a < 3; ++a) {
    lo[a] = -0.5 * grid.spacing[a] - p.padding;
    len[a] = double(grid.dims[a]) * grid.spacing[a] + 2.0 * p.padding;
    // (Whole cells no larger than the target: every level then stays at or below its power of two.)
    const double cells = std::ceil(len[a] / rootTarget - 1e-9);
    if (!(cells < double(int64_t(1) << 20))) {
      std::ostringstream m;
      m << "root cells of " << maxCell << " mm give " << cells << " cells along axis " << a
        << "; raise max_cell_size (or the sizing field's max_size)";
      throw InputError(m.str());
    }
    n[a] = std::max<int64_t>(1, int64_t(cells));
    h[a] = len[a] / double(n[a]);
    rootLongest = std::max(rootLongest, h[a]);
  }
  int L = 0;
  // Levels until a leaf is no larger than min_cell_size (the finest leaves lie in
  // (min_cell_size / 2, min_cell_size]).
  while (L < kMaxLevels + 1 && rootLongest / double(int64_t(1) << L) > minCell * (1 + 1e-9)) ++L;
  if (L > kMaxLevels) {
    std::ostringstream m;
    m << "min_cell_size " << minCell << " mm needs more than " << kMaxLevels
      << " octree levels below root cells of " << rootLongest << " mm; raise min_cell_size (or the "
      << "sizing field's min_size) or lower max_cell_size";
    throw InputError(m.str());
  }
  for (int a = 0; a < 3; ++a)
    if ((n[a] << L) >= (int64_t(1) << 20)) {
      std::ostringstream m;
      m << "the octree would be " << (n[a] << L) << " finest cells along axis " << a
        << "; raise min_cell_size or max_cell_size";
      throw InputError(m.str());
    }
  int thinLevel = 0;
  if (thin) {
    const double thinCell = thinCellSize(p, *thin);
    thinLevel = levelFor(rootLongest, thinCell);
    requireLevels(thinLevel, {n[0], n[1], n[2]}, rootLongest, thinCell);
    L = std::max(L, thinLevel);
    st.thinLayerCellSize = rootLongest / double(int64_t(1) << thinLevel);
  }
  SizingOctree tree;
  tree.finestLevel = L;
  tree.thinLevel = thinLevel;
  tree.roots = {n[0], n[1], n[2]};
  tree.lo = lo;
  tree.boxLength = len;
  tree.rootSize = h;
  const SizingOracle oracle(sizing);
  auto halfToPhysical = [&](int64_t x, int64_t y, int64_t z) {
    return grid.origin + mul(grid.direction, tree.halfToLocal(x, y, z));
  };

  if (n[0] * n[1] * n[2] * 24 > kMaxTets) {
    std::ostringstream m;
    m << n[0] << " x " << n[1] << " x " << n[2] << " root cells of " << rootLongest
      << " mm are too many for one mesh; raise max_cell_size (or the sizing field's max_size)";
    throw InputError(m.str());
  }
  // 1. Refinement, level by level.
  std::unordered_set<uint64_t> leaves;
  std::vector<uint64_t> current;
  for (int64_t k = 0; k < n[2]; ++k)
    for (int64_t j = 0; j < n[1]; ++j)
      for (int64_t i = 0; i < n[0]; ++i) current.push_back(leafKey(0, i, j, k));
  for (int level = 0; !current.empty(); ++level) {
    std::vector<uint8_t> split(current.size(), 0);
    const double longest = rootLongest / double(int64_t(1) << level);
    if (level < L) {
      const int64_t nc = int64_t(current.size());
      const int64_t s = int64_t(1) << (L - level);
#pragma omp parallel for schedule(dynamic, 64)
      for (int64_t c = 0; c < nc; ++c) {
        const auto idx = keyIndex(current[size_t(c)]);
        std::array<Vec3, 8> corners;
        for (int q = 0; q < 8; ++q)
          corners[size_t(q)] = halfToPhysical(2 * s * (idx[0] + (q & 1)), 2 * s * (idx[1] + ((q >> 1) & 1)),
                                              2 * s * (idx[2] + ((q >> 2) & 1)));
        split[size_t(c)] = longest > minCell * (1 + 1e-9) && double(oracle.minOver(corners)) < longest * (1 - 1e-9) ? 1 : 0;
      }
    }
    // Every leaf gives at most 24 tets (6 faces x 4 edges, bisected), and tets are int32-indexed:
    // refuse before allocating a tree that could not be meshed.
    int64_t splits = 0;
    for (uint8_t f : split) splits += f;
    const int64_t leavesNext = int64_t(leaves.size()) + int64_t(current.size()) + 7 * splits;
    // Memory of the mesh these leaves will give: kOctreeBytesPerLeaf (16 tets of kBccBytesPerTet
    // -- 12 per leaf plus bisections, 24 at most -- and the leaf's hash-set entry). Leaves near
    // interfaces go as min_cell_size^-2.
    requireMemory(kOctreeBytesPerLeaf * double(leavesNext),
                  "the octree at level " + std::to_string(level + 1) + " (" + std::to_string(leavesNext) +
                      " leaves, min_cell_size " + formatNumber(minCell) + " mm)",
                  [&](double avail) {
                    const double need = minCell * std::sqrt(kOctreeBytesPerLeaf * double(leavesNext) / std::max(avail, 1.0)) * 1.05;
                    return "raise min_cell_size (or the sizing field's min_size) to >= " + formatNumber(roundUpForAdvice(need)) + " mm";
                  });
    if (leavesNext * 24 > kMaxTets) {
      std::ostringstream m;
      m << "the sizing field asks for more than " << kMaxTets / 24 << " octree leaves (" << kMaxTets
        << " tets) at level " << level + 1 << "; raise min_size / min_cell_size or lower the "
        << "sizing field's resolution";
      throw InputError(m.str());
    }
    std::vector<uint64_t> next;
    for (size_t c = 0; c < current.size(); ++c) {
      if (!split[c]) {
        leaves.insert(current[c]);
        continue;
      }
      for (int q = 0; q < 8; ++q) next.push_back(childKey(current[c], q));
    }
    current.swap(next);
    progress.checkCancel();
  }

  // 2. Balance: leaves touching by a face, edge or corner differ by at most one level.
  tree.leafSet = std::move(leaves);
  std::vector<uint64_t> all(tree.leafSet.begin(), tree.leafSet.end());
  cancellableSort(all, progress);
  st.balanceSplits += tree.balance(all, &progress);
  if (thin) {
    progress.beginStage("thin layers");
    all.assign(tree.leafSet.begin(), tree.leafSet.end());
    st.thinLayerSplits += splitThinLayerLeaves(tree, grid, *thin, progress, std::move(all), st);
  }
  progress.checkCancel();
  tree.finish(st, &progress);
  progress.endStage();
  progress.checkCancel();
  return tree;
}

namespace {

// The tets of a balanced tree, with for each tet the leaves on either side of its piece (indices
// into tree.leaves; the second is -1 on the box) and whether it is a transition or bisected tet.
struct TreeMesh {
  BackgroundMesh bg;
  std::vector<uint64_t> vertexKeys;          // per vertex
  std::vector<std::array<int32_t, 2>> owner; // per tet
  std::vector<uint8_t> graded;               // per tet: transition or bisected
  int64_t transitionTets = 0, bisectedTets = 0;
};

// The tree's tets, or with `emit` only those of the leaves i with (*emit)[i] (their vertices from
// the leaves with (*around)[i], which must include every leaf touching an emitting one: the tets
// are then the whole mesh's tets of those leaves, with their own vertex numbering).
TreeMesh meshFromTree(const SizingOctree& tree, const GridGeometry& grid, Progress& progress,
                      const std::vector<uint8_t>* emit = nullptr, const std::vector<uint8_t>* around = nullptr) {
  TreeMesh tm;
  BackgroundMesh& bg = tm.bg;
  const int L = tree.finestLevel;
  const std::vector<uint64_t>& sorted = tree.leaves;
  auto halfToPhysical = [&](int64_t x, int64_t y, int64_t z) {
    return grid.origin + mul(grid.direction, tree.halfToLocal(x, y, z));
  };
  auto vertexLeaf = [&](size_t i) { return !around || (*around)[i]; };

  TetMesh& mesh = bg.mesh;
  std::unordered_map<uint64_t, int32_t> vid;
  vid.reserve((around ? size_t(std::count(around->begin(), around->end(), uint8_t(1))) : sorted.size()) * 3);
  auto addVertex = [&](int64_t x, int64_t y, int64_t z, LatticeVertexKind kind) {
    const auto [it, fresh] = vid.try_emplace(vertexKey(x, y, z), int32_t(mesh.points.size()));
    if (fresh) {
      if (mesh.points.size() >= size_t(std::numeric_limits<int32_t>::max()))
        throw InputError("the octree background mesh would have more than 2^31 vertices; raise min_cell_size");
      mesh.points.push_back(halfToPhysical(x, y, z));
      bg.kind.push_back(kind);
      tm.vertexKeys.push_back(vertexKey(x, y, z));
    }
    return it->second;
  };
  int64_t visited = 0;
  for (size_t i = 0; i < sorted.size(); ++i) {
    if (!vertexLeaf(i)) continue;
    const uint64_t key = sorted[i];
    progress.checkCancelEvery(++visited, 16);
    const auto idx = keyIndex(key);
    const int64_t s = int64_t(1) << (L - keyLevel(key));
    for (int q = 0; q < 8; ++q)
      addVertex(2 * s * (idx[0] + (q & 1)), 2 * s * (idx[1] + ((q >> 1) & 1)), 2 * s * (idx[2] + ((q >> 2) & 1)),
                LatticeVertexKind::Primal);
    addVertex(2 * s * idx[0] + s, 2 * s * idx[1] + s, 2 * s * idx[2] + s, LatticeVertexKind::Dual);
  }
  const size_t cornerAndCentreCount = mesh.points.size();
  auto existing = [&](int64_t x, int64_t y, int64_t z) -> int32_t {
    const auto it = vid.find(vertexKey(x, y, z));
    return it == vid.end() || size_t(it->second) >= cornerAndCentreCount ? -1 : it->second;
  };

  // Face-centre vertices of the leaf faces on the box (before the tets, so that the tet pass
  // only reads the vertex map and can run in parallel).
  const int64_t finest[3] = {tree.roots[0] << L, tree.roots[1] << L, tree.roots[2] << L};
  for (size_t i = 0; i < sorted.size(); ++i) {
    if (!vertexLeaf(i)) continue;
    const uint64_t key = sorted[i];
    progress.checkCancelEvery(++visited, 16);
    const auto idx = keyIndex(key);
    const int64_t s = int64_t(1) << (L - keyLevel(key));
    for (int face = 0; face < 6; ++face) {
      const int a = face / 2;
      const bool plus = face % 2 == 1;
      if (plus ? (idx[size_t(a)] + 1) * s < finest[a] : idx[size_t(a)] > 0) continue;
      std::array<int64_t, 3> fc{2 * s * idx[0] + s, 2 * s * idx[1] + s, 2 * s * idx[2] + s};
      fc[size_t(a)] = 2 * s * (idx[size_t(a)] + (plus ? 1 : 0));
      addVertex(fc[0], fc[1], fc[2], LatticeVertexKind::FaceCentre);
    }
  }
  auto faceCentreId = [&](const std::array<int64_t, 3>& x) { return vid.find(vertexKey(x[0], x[1], x[2]))->second; };

  // Tets, piece by piece, in parallel over blocks of leaves; blocks are joined in leaf order, so
  // the mesh does not depend on the thread count.
  // `next`: the leaf after the asking one, which is its +x neighbour at the same level more often
  // than not (the keys sort by level, z, y, x).
  auto leafIndexOf = [&](int level, int64_t i, int64_t j, int64_t k, int64_t next) {
    const uint64_t key = leafKey(level, i, j, k);
    if (next < int64_t(sorted.size()) && sorted[size_t(next)] == key) return int32_t(next);
    return int32_t(std::lower_bound(sorted.begin(), sorted.end(), key) - sorted.begin());
  };
  struct Block {
    std::vector<TetMesh::Tet> tets;
    std::vector<std::array<int32_t, 2>> owner;
    std::vector<uint8_t> graded;
    int64_t transition = 0, bisected = 0;
  };
  const int64_t nLeaves = int64_t(sorted.size());
  const int64_t blockSize = 4096;
  const int64_t nBlocks = (nLeaves + blockSize - 1) / blockSize;
  std::vector<Block> blocks(static_cast<size_t>(nBlocks));
  LoopCancel cancel(progress);
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t bi = 0; bi < nBlocks; ++bi) {
   if (cancel.skip()) continue;
   Block& out = blocks[size_t(bi)];
   {
     // About 12 tets per leaf in a uniform region (3 faces of 4 tets each); more where graded.
     const size_t leavesHere =
         emit ? size_t(std::count(emit->begin() + bi * blockSize, emit->begin() + std::min(nLeaves, (bi + 1) * blockSize),
                                  uint8_t(1)))
              : size_t(std::min(nLeaves, (bi + 1) * blockSize) - bi * blockSize);
     out.tets.reserve(14 * leavesHere);
     out.owner.reserve(14 * leavesHere);
     out.graded.reserve(14 * leavesHere);
   }
   for (int64_t li = bi * blockSize; li < std::min(nLeaves, (bi + 1) * blockSize); ++li) {
    if (emit && !(*emit)[size_t(li)]) continue;
    const uint64_t key = sorted[size_t(li)];
    const int l = keyLevel(key);
    const auto idx = keyIndex(key);
    const int64_t s = int64_t(1) << (L - l);
    const int32_t centre = existing(2 * s * idx[0] + s, 2 * s * idx[1] + s, 2 * s * idx[2] + s);
    for (int face = 0; face < 6; ++face) {
      const int a = face / 2, b = (a + 1) % 3, c = (a + 2) % 3;
      const bool plus = face % 2 == 1;
      std::array<int64_t, 3> probe{idx[0] * s, idx[1] * s, idx[2] * s};
      probe[size_t(a)] = plus ? (idx[size_t(a)] + 1) * s : idx[size_t(a)] * s - 1;
      const int m = tree.levelAt(probe, l); // balanced: the neighbour is at l - 1, l or l + 1
      int32_t other;
      int32_t otherLeaf = -1;
      bool onBox = false;
      // Face plane and corner coordinates (half units).
      const int64_t plane = 2 * s * (idx[size_t(a)] + (plus ? 1 : 0));
      auto at = [&](int64_t u, int64_t v) { // u along b, v along c (half units)
        std::array<int64_t, 3> x;
        x[size_t(a)] = plane;
        x[size_t(b)] = u;
        x[size_t(c)] = v;
        return x;
      };
      const int64_t u0 = 2 * s * idx[size_t(b)], v0 = 2 * s * idx[size_t(c)];
      if (m < 0) {
        other = faceCentreId(at(u0 + s, v0 + s));
        onBox = true;
      } else if (m > l || (m == l && !plus)) {
        continue; // the smaller leaf, or the leaf on the low side, emits this piece
      } else {
        const int sh = L - m;
        const int64_t sm = int64_t(1) << sh;
        other = existing(2 * sm * (probe[0] >> sh) + sm, 2 * sm * (probe[1] >> sh) + sm, 2 * sm * (probe[2] >> sh) + sm);
        otherLeaf = leafIndexOf(m, probe[0] >> sh, probe[1] >> sh, probe[2] >> sh, li + 1);
      }
      const std::array<int32_t, 2> owners{int32_t(li), otherLeaf};
      const bool transition = !onBox && m != l;
      const std::array<int64_t, 2> ring[4] = {{u0, v0}, {u0 + 2 * s, v0}, {u0 + 2 * s, v0 + 2 * s}, {u0, v0 + 2 * s}};
      for (int e = 0; e < 4; ++e) {
        const auto pa = at(ring[e][0], ring[e][1]);
        const auto pb = at(ring[(e + 1) % 4][0], ring[(e + 1) % 4][1]);
        const int32_t va = existing(pa[0], pa[1], pa[2]), vb = existing(pb[0], pb[1], pb[2]);
        const int32_t mid = existing((pa[0] + pb[0]) / 2, (pa[1] + pb[1]) / 2, (pa[2] + pb[2]) / 2);
        if (mid >= 0) {
          out.tets.push_back({centre, other, va, mid});
          out.tets.push_back({centre, other, mid, vb});
          out.bisected += 2;
          if (transition) out.transition += 2;
          out.owner.insert(out.owner.end(), 2, owners);
          out.graded.insert(out.graded.end(), 2, uint8_t(1));
        } else {
          out.tets.push_back({centre, other, va, vb});
          if (transition) ++out.transition;
          out.owner.push_back(owners);
          out.graded.push_back(transition ? 1 : 0);
        }
      }
    }
   }
  }
  size_t total = 0;
  for (const Block& blk : blocks) total += blk.tets.size();
  if (total > size_t(kMaxTets))
    throw InputError("the octree background mesh would have more than 2^31 - 1 tets; raise min_cell_size "
                     "(or the sizing field's min_size)");
  cancel.rethrow();
  // Joined in leaf order, each block freed once copied (the mesh's pages are touched as the
  // blocks' are let go).
  mesh.tets.reserve(total);
  tm.owner.reserve(total);
  tm.graded.reserve(total);
  for (Block& blk : blocks) {
    progress.checkCancel();
    mesh.tets.insert(mesh.tets.end(), blk.tets.begin(), blk.tets.end());
    tm.owner.insert(tm.owner.end(), blk.owner.begin(), blk.owner.end());
    tm.graded.insert(tm.graded.end(), blk.graded.begin(), blk.graded.end());
    std::vector<TetMesh::Tet>().swap(blk.tets);
    std::vector<std::array<int32_t, 2>>().swap(blk.owner);
    std::vector<uint8_t>().swap(blk.graded);
    tm.transitionTets += blk.transition;
    tm.bisectedTets += blk.bisected;
  }
  progress.checkCancel();
  const int64_t nt = int64_t(mesh.tets.size());
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < nt; ++t)
    if (mesh.tetVolume(size_t(t)) < 0) std::swap(mesh.tets[size_t(t)][2], mesh.tets[size_t(t)][3]);
  mesh.materials.assign(mesh.tets.size(), 0);
  bg.cells = tree.roots;
  bg.cellSize = tree.rootSize;
  bg.boxVolume = tree.boxLength[0] * tree.boxLength[1] * tree.boxLength[2];
  return tm;
}

} // namespace

namespace {

// Marks on a grid of cells of one level (the finest whose grid has at most 2^26 cells) over the
// tree's box: markAround(leaf) marks the cells the leaf's box overlaps and one more on every side;
// meets(leaf) says whether the leaf's box overlaps a marked cell. So a leaf whose closed box
// touches a marked leaf's meets it (and some others may: a superset).
class CellMarks {
public:
  explicit CellMarks(const SizingOctree& tree) : L_(tree.finestLevel) {
    int k = 0;
    auto cells = [&](int level) {
      return double(tree.roots[0]) * double(tree.roots[1]) * double(tree.roots[2]) * std::pow(8.0, level);
    };
    while (k < L_ && cells(k + 1) <= double(int64_t(1) << 26)) ++k;
    shift_ = L_ - k;
    for (int a = 0; a < 3; ++a) dims_[size_t(a)] = tree.roots[size_t(a)] << k;
    marks_.assign(size_t(dims_[0] * dims_[1] * dims_[2]), 0);
  }
  void markAround(uint64_t key) {
    int64_t lo[3], hi[3];
    range(key, lo, hi);
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::max<int64_t>(0, lo[a] - 1);
      hi[a] = std::min<int64_t>(dims_[size_t(a)] - 1, hi[a] + 1);
    }
    for (int64_t z = lo[2]; z <= hi[2]; ++z)
      for (int64_t y = lo[1]; y <= hi[1]; ++y)
        for (int64_t x = lo[0]; x <= hi[0]; ++x) marks_[size_t((z * dims_[1] + y) * dims_[0] + x)] = 1;
  }
  bool meets(uint64_t key) const {
    int64_t lo[3], hi[3];
    range(key, lo, hi);
    for (int64_t z = lo[2]; z <= hi[2]; ++z)
      for (int64_t y = lo[1]; y <= hi[1]; ++y)
        for (int64_t x = lo[0]; x <= hi[0]; ++x)
          if (marks_[size_t((z * dims_[1] + y) * dims_[0] + x)]) return true;
    return false;
  }

private:
  // The cells the leaf's box overlaps (inclusive).
  void range(uint64_t key, int64_t lo[3], int64_t hi[3]) const {
    const auto idx = keyIndex(key);
    const int64_t s = int64_t(1) << (L_ - keyLevel(key)); // finest cells per edge
    for (int a = 0; a < 3; ++a) {
      lo[a] = (idx[size_t(a)] * s) >> shift_;
      hi[a] = ((idx[size_t(a)] + 1) * s - 1) >> shift_;
    }
  }
  int L_ = 0, shift_ = 0;
  std::array<int64_t, 3> dims_{0, 0, 0};
  std::vector<uint8_t> marks_;
};

// Meshes a balanced tree; with `thin`, splits the leaves of tets whose edges miss a material and
// meshes again; with `materials`, keeps graded tets off the interfaces (see the header).
// `splitRoots` (sorted keys), when given: the root cells that were split, every other root being a
// leaf (the thin-layer lattice): only the leaves touching them can have graded tets, so the first
// round too meshes and tests those alone.
void meshOctree(OctreeBccResult& result, SizingOctree& tree, const GridGeometry& grid, Progress& progress,
                const MaterialSet* materials, const EdgeTopology* thin, bool partialRounds,
                const std::vector<uint64_t>* splitRoots = nullptr) {
  OctreeBccStats& st = result.stats;
  std::vector<uint8_t> emit; // the leaves meshed in a partial round
  // The tets of the leaves touching one of `gone` (the leaves split since the last meshing, gone
  // from the tree: among those leaves are all the new ones), with the vertices of the leaves
  // touching those; `emit` marks the former.
  auto meshAround = [&](const std::vector<uint64_t>& gone) {
    const int64_t nLeaves = int64_t(tree.leaves.size());
    CellMarks changed(tree);
    for (uint64_t key : gone) changed.markAround(key);
    emit.assign(size_t(nLeaves), 0);
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < nLeaves; ++i) emit[size_t(i)] = changed.meets(tree.leaves[size_t(i)]) ? 1 : 0;
    CellMarks near(tree);
    for (int64_t i = 0; i < nLeaves; ++i)
      if (emit[size_t(i)]) near.markAround(tree.leaves[size_t(i)]);
    std::vector<uint8_t> around(size_t(nLeaves), 0);
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < nLeaves; ++i) around[size_t(i)] = near.meets(tree.leaves[size_t(i)]) ? 1 : 0;
    progress.checkCancel();
    return meshFromTree(tree, grid, progress, &emit, &around);
  };
  const bool partialFirst = thin && tree.thinLevel > 0 && partialRounds && splitRoots;
  progress.beginStage("tets");
  TreeMesh tm = partialFirst ? meshAround(*splitRoots) : meshFromTree(tree, grid, progress);
  progress.endStage();
  if (thin && tree.thinLevel > 0) {
    progress.beginStage("thin layer rounds");
    // After the first round only the leaves whose surroundings changed (a leaf was split next to
    // them) have new tets: the rounds after it mesh and test those leaves' tets alone, and the
    // whole tree is meshed once at the end. The tets of every other leaf are the ones the last
    // test saw (a tet depends on its leaf and the leaves touching it), so the splits and the
    // count of tets left are those of meshing and testing the whole tree each round.
    std::unordered_map<uint64_t, int64_t> leftBy; // emitting leaf -> its tets left missing a material
    bool partial = partialFirst;                  // tm holds the tets of the `emit` leaves only
    for (int round = 0;; ++round) {
      // Only the graded tets have edges the leaves' own test did not see.
      const std::vector<uint8_t> miss = tetsMissingMaterials(tm.bg.mesh, *thin, progress, &tm.graded);
      if (partial)
        for (size_t i = 0; i < emit.size(); ++i)
          if (emit[i]) leftBy.erase(tree.leaves[i]);
      std::vector<uint64_t> toSplit;
      for (size_t t = 0; t < miss.size(); ++t) {
        if (!miss[t]) continue;
        const auto [a, b] = tm.owner[t];
        const int la = tree.leafLevel(size_t(a)), lb = b >= 0 ? tree.leafLevel(size_t(b)) : la;
        bool split = false;
        if (la < tree.thinLevel && la <= lb) {
          toSplit.push_back(tree.leaves[size_t(a)]);
          split = true;
        }
        if (b >= 0 && lb < tree.thinLevel && lb <= la) {
          toSplit.push_back(tree.leaves[size_t(b)]);
          split = true;
        }
        if (!split) ++leftBy[tree.leaves[size_t(a)]]; // a: the leaf that emitted it
      }
      int64_t left = 0;
      for (const auto& [key, count] : leftBy) left += count;
      st.thinLayerTetsLeft = left;
      st.thinLayerRounds = round;
      std::sort(toSplit.begin(), toSplit.end());
      toSplit.erase(std::unique(toSplit.begin(), toSplit.end()), toSplit.end());
      if (toSplit.empty() || round == kThinRounds) break;
      const std::vector<uint64_t> before = tree.leaves;
      std::vector<uint64_t> touched;
      for (uint64_t key : toSplit) tree.split(key, &touched);
      st.thinLayerSplits += int64_t(toSplit.size());
      std::vector<uint64_t> created;
      st.balanceSplits += tree.balance(touched, &progress, &created);
      touched.insert(touched.end(), created.begin(), created.end());
      st.thinLayerSplits += splitThinLayerLeaves(tree, grid, *thin, progress, std::move(touched), st);
      tree.finish(st, &progress);
      // The leaves split this round (gone from the tree); the leaves touching one of them (among
      // them all the new ones) emit the changed tets; their vertices come from the leaves
      // touching those.
      std::vector<uint64_t> gone;
      std::set_difference(before.begin(), before.end(), tree.leaves.begin(), tree.leaves.end(), std::back_inserter(gone));
      for (uint64_t key : gone) leftBy.erase(key);
      if (partialRounds) {
        tm = meshAround(gone);
      } else {
        tm = meshFromTree(tree, grid, progress);
        emit.assign(tree.leaves.size(), 1); // every leaf's tets tested again
      }
      partial = true;
      progress.checkCancel();
    }
    if (partial) tm = meshFromTree(tree, grid, progress);
    progress.endStage();
  }
  if (materials) {
    // Keep the graded tets away from the material interfaces (seed §4.8.1): a transition or
    // bisected tet whose vertices do not all carry the same dominant material has its coarser
    // leaf split (both leaves when they are equal and the tet is bisected because of a finer
    // leaf nearby); then the tree is rebalanced and meshed again, until no graded tet is cut.
    progress.beginStage("uniform interfaces");
    std::unordered_map<uint64_t, int32_t> labelOf; // by vertex key, kept across rounds
    std::vector<MaterialSample> buf;
    for (int round = 0;; ++round) {
      const TetMesh& m = tm.bg.mesh;
      const int64_t nv = int64_t(m.numPoints());
      std::vector<int32_t> label(size_t(nv), -1);
      std::vector<int64_t> fresh;
      for (int64_t v = 0; v < nv; ++v) {
        const auto it = labelOf.find(tm.vertexKeys[size_t(v)]);
        if (it != labelOf.end()) label[size_t(v)] = it->second;
        else fresh.push_back(v);
      }
#pragma omp parallel
      {
        std::vector<MaterialSample> smp;
#pragma omp for schedule(dynamic, 1024)
        for (int64_t f = 0; f < int64_t(fresh.size()); ++f) {
          const int64_t v = fresh[size_t(f)];
          materials->sample(m.points[size_t(v)], smp);
          label[size_t(v)] = dominantMaterial(smp);
        }
      }
      for (int64_t v : fresh) labelOf[tm.vertexKeys[size_t(v)]] = label[size_t(v)];
      std::vector<uint64_t> toSplit;
      int64_t cut = 0;
      for (size_t t = 0; t < m.numTets(); ++t) {
        if (!tm.graded[t]) continue;
        const auto& q = m.tets[t];
        const int32_t l0 = label[size_t(q[0])];
        if (label[size_t(q[1])] == l0 && label[size_t(q[2])] == l0 && label[size_t(q[3])] == l0) continue;
        ++cut;
        const auto [a, b] = tm.owner[t];
        const int la = tree.leafLevel(size_t(a)), lb = b >= 0 ? tree.leafLevel(size_t(b)) : la;
        if (la < tree.finestLevel && la <= lb) toSplit.push_back(tree.leaves[size_t(a)]);
        if (b >= 0 && lb < tree.finestLevel && lb <= la) toSplit.push_back(tree.leaves[size_t(b)]);
      }
      std::sort(toSplit.begin(), toSplit.end());
      toSplit.erase(std::unique(toSplit.begin(), toSplit.end()), toSplit.end());
      st.gradedInterfaceTets = cut;
      st.interfaceRounds = round;
      if (toSplit.empty() || round == 100) break;
      // Spread along the interface in this round: a leaf of the same level touching a marked leaf
      // (face, edge or corner) whose corners and centre do not all carry one material would be
      // marked in a later round anyway (its graded tets become cut once its neighbour is split).
      {
        const int L = tree.finestLevel;
        auto mixed = [&](uint64_t key) {
          const auto idx = keyIndex(key);
          const int64_t sz = int64_t(1) << (L - keyLevel(key));
          const auto centre = labelOf.find(vertexKey(2 * sz * idx[0] + sz, 2 * sz * idx[1] + sz, 2 * sz * idx[2] + sz));
          if (centre == labelOf.end()) return false;
          for (int q = 0; q < 8; ++q) {
            const auto c = labelOf.find(vertexKey(2 * sz * (idx[0] + (q & 1)), 2 * sz * (idx[1] + ((q >> 1) & 1)),
                                                  2 * sz * (idx[2] + ((q >> 2) & 1))));
            if (c != labelOf.end() && c->second != centre->second) return true;
          }
          return false;
        };
        std::unordered_set<uint64_t> marked(toSplit.begin(), toSplit.end());
        std::vector<uint64_t> queue = toSplit;
        while (!queue.empty()) {
          const uint64_t key = queue.back();
          queue.pop_back();
          const int l = keyLevel(key);
          const auto idx = keyIndex(key);
          const int64_t sz = int64_t(1) << (L - l);
          for (int d = 0; d < 27; ++d) {
            if (d == 13) continue;
            const std::array<int64_t, 3> f = neighbourProbe(idx, sz, d);
            if (tree.levelAt(f) != l) continue;
            const int sh = L - l;
            const uint64_t nb = leafKey(l, f[0] >> sh, f[1] >> sh, f[2] >> sh);
            if (marked.count(nb) || !mixed(nb)) continue;
            marked.insert(nb);
            queue.push_back(nb);
            toSplit.push_back(nb);
          }
        }
      }
      std::vector<uint64_t> touched;
      for (uint64_t key : toSplit) tree.split(key, &touched);
      st.interfaceSplits += int64_t(toSplit.size());
      st.balanceSplits += tree.balance(std::move(touched), &progress);
      tree.finish(st, &progress);
      tm = meshFromTree(tree, grid, progress);
      progress.checkCancel();
    }
    progress.endStage();
  }
  st.transitionTets = tm.transitionTets;
  st.bisectedTets = tm.bisectedTets;
  result.background = std::move(tm.bg);
  result.graded = std::move(tm.graded);
}

} // namespace

OctreeBccResult generateOctreeBcc(const GridGeometry& grid, const ScalarVolume& sizing, const OctreeBccParams& p,
                                  Progress& progress, const MaterialSet* materials, const EdgeTopology* thin) {
  OctreeBccResult result;
  SizingOctree tree = buildSizingOctree(grid, sizing, p, result.stats, progress, thin);
  meshOctree(result, tree, grid, progress, materials, thin, p.partial_thin_rounds);
  return result;
}

OctreeBccResult generateThinLayerBcc(const GridGeometry& grid, const BccParams& bcc, const OctreeBccParams& p,
                                     const EdgeTopology& thin, Progress& progress, const MaterialSet* materials) {
  grid.validate("background mesh: volume");
  if (!(bcc.cell_size > 0.0) || !std::isfinite(bcc.cell_size)) throw InputError("cell_size must be a positive number of mm");
  if (!(bcc.padding >= 0.0) || !std::isfinite(bcc.padding)) throw InputError("padding must be >= 0 mm");
  OctreeBccResult result;
  OctreeBccStats& st = result.stats;
  // The regular lattice's cells (BccLattice.cpp) as the roots.
  SizingOctree tree;
  double rootLongest = 0;
  BccParams snapped = bcc; // the cells as the thin-layer levels need them (bccSnappedCell)
  if (!thin.nothingMisses() && p.snap_roots) snapped.snap_voxel = thin.voxelSize();
  const double rootTarget = bccSnappedCell(snapped);
  for (int a = 0; a < 3; ++a) {
    tree.lo[a] = -0.5 * grid.spacing[a] - bcc.padding;
    tree.boxLength[a] = double(grid.dims[size_t(a)]) * grid.spacing[a] + 2.0 * bcc.padding;
    tree.roots[size_t(a)] = std::max<int64_t>(1, std::llround(tree.boxLength[a] / rootTarget));
    tree.rootSize[a] = tree.boxLength[a] / double(tree.roots[size_t(a)]);
    rootLongest = std::max(rootLongest, tree.rootSize[a]);
  }
  const double thinCell = thinCellSize(p, thin);
  tree.thinLevel = levelFor(rootLongest, thinCell);
  if (tree.thinLevel == 0 || thin.nothingMisses()) { // cells already as fine as asked, or nothing
    // to find (EdgeTopology::nothingMisses): the regular lattice, of the cells asked for
    result.background = generateRegularBcc(grid, bcc, progress);
    return result;
  }
  requireLevels(tree.thinLevel, tree.roots, rootLongest, thinCell);
  tree.finestLevel = tree.thinLevel;
  st.thinLayerCellSize = rootLongest / double(int64_t(1) << tree.thinLevel);
  if (double(tree.roots[0]) * double(tree.roots[1]) * double(tree.roots[2]) * 12.0 > double(kMaxTets))
    throw InputError("cell_size " + formatNumber(bcc.cell_size) + " mm gives too many cells for one mesh; use a larger cell_size");
  progress.beginStage("thin layers");
  for (int64_t k = 0; k < tree.roots[2]; ++k)
    for (int64_t j = 0; j < tree.roots[1]; ++j)
      for (int64_t i = 0; i < tree.roots[0]; ++i) tree.leafSet.insert(leafKey(0, i, j, k));
  std::vector<uint64_t> all(tree.leafSet.begin(), tree.leafSet.end());
  st.thinLayerSplits = splitThinLayerLeaves(tree, grid, thin, progress, std::move(all), st);
  if (st.thinLayerSplits == 0) {
    result.background = generateRegularBcc(grid, snapped, progress);
    return result;
  }
  tree.finish(st, &progress);
  progress.endStage();
  std::vector<uint64_t> splitRoots; // the roots that are no leaves
  for (uint64_t key : tree.leaves)
    if (keyLevel(key) > 0) {
      const auto idx = keyIndex(key);
      const int sh = keyLevel(key);
      splitRoots.push_back(leafKey(0, idx[0] >> sh, idx[1] >> sh, idx[2] >> sh));
    }
  std::sort(splitRoots.begin(), splitRoots.end());
  splitRoots.erase(std::unique(splitRoots.begin(), splitRoots.end()), splitRoots.end());
  meshOctree(result, tree, grid, progress, materials, &thin, p.partial_thin_rounds, &splitRoots);
  return result;
}

void reportOctreeBcc(const OctreeBccStats& s, Report& r) {
  r.set("levels", ReportValue(int64_t(s.levels)));
  std::string per;
  for (size_t l = 0; l < s.leavesPerLevel.size(); ++l) {
    if (!per.empty()) per += " ";
    per += std::to_string(s.leavesPerLevel[l]);
  }
  r.set("leaves_per_level", per);
  r.set("balance_splits", ReportValue(s.balanceSplits));
  r.set("interface_splits", ReportValue(s.interfaceSplits));
  r.set("interface_rounds", ReportValue(int64_t(s.interfaceRounds)));
  r.set("graded_tets_on_interfaces", ReportValue(s.gradedInterfaceTets));
  r.set("transition_tets", ReportValue(s.transitionTets));
  r.set("bisected_tets", ReportValue(s.bisectedTets));
  r.set("root_cell_size_mm", ReportValue(s.rootCellSize));
  r.set("finest_cell_size_mm", ReportValue(s.finestCellSize));
  reportThinLayers(s, r);
}

void reportThinLayers(const OctreeBccStats& s, Report& r) {
  if (s.thinLayerCellSize <= 0) return;
  r.set("thin_layer_cell_size_mm", ReportValue(s.thinLayerCellSize));
  r.set("thin_layer_splits", ReportValue(s.thinLayerSplits));
  r.set("thin_layer_rounds", ReportValue(int64_t(s.thinLayerRounds)));
  r.set("thin_layer_tets_left", ReportValue(s.thinLayerTetsLeft));
}

} // namespace tetflow
