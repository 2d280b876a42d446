#include "LabelTopology.h"

#include <unordered_map>

#include <algorithm>
#include <atomic>
#include <memory>
#include <cmath>

#include "Algorithms/Core/Errors.h"

namespace tetflow {

uint64_t labelPairKey(int32_t a, int32_t b) {
  if (a > b) std::swap(a, b);
  return (static_cast<uint64_t>(static_cast<uint32_t>(a)) << 32) | static_cast<uint32_t>(b);
}
std::pair<int32_t, int32_t> labelPairOf(uint64_t k) {
  return {static_cast<int32_t>(static_cast<uint32_t>(k >> 32)), static_cast<int32_t>(static_cast<uint32_t>(k))};
}

LabelImageTopology analyzeLabelImage(const LabelVolume& v, Progress& progress) {
  const auto& g = v.grid;
  const int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const int64_t n = g.voxelCount();
  if (n >= std::numeric_limits<int32_t>::max())
    throw InputError("label volume of " + std::to_string(n) + " voxels is too large for the certificate (limit 2^31)");
  const auto& lab = v.data;
  auto idx = [&](int64_t i, int64_t j, int64_t k) { return i + nx * (j + ny * k); };
  // Work goes in fixed slabs of z planes (not one per thread), so every sum below is made in the
  // same order whatever the thread count.
  constexpr int64_t kSlab = 8;
  const int64_t slabs = (nz + kSlab - 1) / kSlab;

  // 26-connected components of equal labels; cores and their 26-connected components.
  DisjointSets all(static_cast<size_t>(n)), cores(static_cast<size_t>(n));
  std::vector<uint8_t> isCore(static_cast<size_t>(n), 0);
#pragma omp parallel for schedule(static)
  for (int64_t k = 0; k < nz; ++k)
    for (int64_t j = 0; j < ny; ++j)
      for (int64_t i = 0; i < nx; ++i) {
        const int32_t L = lab[static_cast<size_t>(idx(i, j, k))];
        auto same = [&](int64_t a, int64_t b, int64_t c) {
          if (a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz) return true;
          return lab[static_cast<size_t>(idx(a, b, c))] == L;
        };
        isCore[static_cast<size_t>(idx(i, j, k))] =
            same(i - 1, j, k) && same(i + 1, j, k) && same(i, j - 1, k) && same(i, j + 1, k) &&
            same(i, j, k - 1) && same(i, j, k + 1);
      }
  progress.checkCancel();
  // Unions with the 13 neighbours before each voxel in scan order: within each slab in parallel
  // (a set's root is its smallest index, so the sets of one slab stay in it), then across the
  // first plane of every slab, in order.
  auto unitePlane = [&](int64_t k, int64_t kMin) {
    for (int64_t j = 0; j < ny; ++j)
      for (int64_t i = 0; i < nx; ++i) {
        const int64_t p = idx(i, j, k);
        const int32_t L = lab[static_cast<size_t>(p)];
        for (int dk = -1; dk <= 0; ++dk) {
          if (k + dk < kMin) continue;
          for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di) {
              if (dk == 0 && (dj > 0 || (dj == 0 && di >= 0))) continue;
              const int64_t a = i + di, b = j + dj, c = k + dk;
              if (a < 0 || b < 0 || a >= nx || b >= ny) continue;
              const int64_t q = idx(a, b, c);
              if (lab[static_cast<size_t>(q)] != L) continue;
              all.unite(static_cast<int32_t>(p), static_cast<int32_t>(q));
              if (isCore[static_cast<size_t>(p)] && isCore[static_cast<size_t>(q)])
                cores.unite(static_cast<int32_t>(p), static_cast<int32_t>(q));
            }
        }
      }
  };
  LoopCancel cancel(progress);
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t sl = 0; sl < slabs; ++sl) {
    if (cancel.skip()) continue;
    for (int64_t k = sl * kSlab; k < std::min(nz, (sl + 1) * kSlab); ++k) unitePlane(k, sl * kSlab);
  }
  cancel.rethrow();
  for (int64_t sl = 1; sl < slabs; ++sl) { // the dk = -1 neighbours of each slab's first plane
    const int64_t k = sl * kSlab;
    for (int64_t j = 0; j < ny; ++j)
      for (int64_t i = 0; i < nx; ++i) {
        const int64_t p = idx(i, j, k);
        const int32_t L = lab[static_cast<size_t>(p)];
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) {
            const int64_t a = i + di, b = j + dj;
            if (a < 0 || b < 0 || a >= nx || b >= ny) continue;
            const int64_t q = idx(a, b, k - 1);
            if (lab[static_cast<size_t>(q)] != L) continue;
            all.unite(static_cast<int32_t>(p), static_cast<int32_t>(q));
            if (isCore[static_cast<size_t>(p)] && isCore[static_cast<size_t>(q)])
              cores.unite(static_cast<int32_t>(p), static_cast<int32_t>(q));
          }
      }
  }
  progress.checkCancel();
  // Roots (read only: no path compression while threads share the arrays).
  auto rootOf = [](const DisjointSets& d, int32_t x) {
    while (d.parent[static_cast<size_t>(x)] != x) x = d.parent[static_cast<size_t>(x)];
    return x;
  };
  std::vector<int32_t> root(static_cast<size_t>(n)), coreRoot(static_cast<size_t>(n), -1);
#pragma omp parallel for schedule(static)
  for (int64_t p = 0; p < n; ++p) {
    root[size_t(p)] = rootOf(all, int32_t(p));
    if (isCore[size_t(p)]) coreRoot[size_t(p)] = rootOf(cores, int32_t(p));
  }
  progress.checkCancel();

  LabelImageTopology s;
  s.comp.assign(static_cast<size_t>(n), -1);
  {
    std::vector<int32_t> rootComp(static_cast<size_t>(n), -1);
    std::vector<uint8_t> coreCounted(static_cast<size_t>(n), 0);
    for (int64_t p = 0; p < n; ++p) { // component numbers in scan order
      int32_t& c = rootComp[size_t(root[size_t(p)])];
      if (c < 0) {
        c = static_cast<int32_t>(s.comps.size());
        s.comps.push_back({});
        s.comps.back().label = lab[static_cast<size_t>(p)];
      }
      s.comp[size_t(p)] = c;
      ImageComponent& ic = s.comps[static_cast<size_t>(c)];
      ++ic.voxels;
      const int32_t cr = coreRoot[size_t(p)];
      if (cr >= 0 && !coreCounted[size_t(cr)]) {
        coreCounted[size_t(cr)] = 1;
        ++ic.cores;
      }
    }
  }
  progress.checkCancel();
  // Places and box contact of the components, per slab, merged in slab order.
  {
    std::vector<std::vector<std::pair<int32_t, PlaceAcc>>> part(static_cast<size_t>(slabs));
    std::vector<std::vector<int32_t>> touching(static_cast<size_t>(slabs));
#pragma omp parallel for schedule(dynamic, 1)
    for (int64_t sl = 0; sl < slabs; ++sl) {
      std::unordered_map<int32_t, size_t> at;
      auto& out = part[size_t(sl)];
      for (int64_t k = sl * kSlab; k < std::min(nz, (sl + 1) * kSlab); ++k)
        for (int64_t j = 0; j < ny; ++j)
          for (int64_t i = 0; i < nx; ++i) {
            const int32_t c = s.comp[size_t(idx(i, j, k))];
            auto [it, fresh] = at.try_emplace(c, out.size());
            if (fresh) out.push_back({c, PlaceAcc{}});
            out[it->second].second.add(g.indexToPhysical(double(i), double(j), double(k)), 1.0);
            if (i == 0 || j == 0 || k == 0 || i == nx - 1 || j == ny - 1 || k == nz - 1) touching[size_t(sl)].push_back(c);
          }
    }
    for (int64_t sl = 0; sl < slabs; ++sl) {
      for (const auto& [c, acc] : part[size_t(sl)]) s.comps[size_t(c)].where.merge(acc);
      for (int32_t c : touching[size_t(sl)]) s.comps[size_t(c)].touchesBox = true;
    }
  }
  progress.checkCancel();

  // Contacts across voxel faces, per slab, merged in slab order.
  const double faceArea[3] = {g.spacing[1] * g.spacing[2], g.spacing[0] * g.spacing[2],
                              g.spacing[0] * g.spacing[1]};
  std::vector<std::map<uint64_t, std::pair<double, PlaceAcc>>> cpart(static_cast<size_t>(slabs));
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t sl = 0; sl < slabs; ++sl)
    for (int64_t k = sl * kSlab; k < std::min(nz, (sl + 1) * kSlab); ++k)
      for (int64_t j = 0; j < ny; ++j)
        for (int64_t i = 0; i < nx; ++i) {
          const int32_t L = lab[static_cast<size_t>(idx(i, j, k))];
          const int64_t nb[3][3] = {{i + 1, j, k}, {i, j + 1, k}, {i, j, k + 1}};
          for (int a = 0; a < 3; ++a) {
            if (nb[a][0] >= nx || nb[a][1] >= ny || nb[a][2] >= nz) continue;
            const int32_t M = lab[static_cast<size_t>(idx(nb[a][0], nb[a][1], nb[a][2]))];
            if (M == L) continue;
            auto& e = cpart[size_t(sl)][labelPairKey(L, M)];
            e.first += faceArea[a];
            const double h[3] = {a == 0 ? 0.5 : 0.0, a == 1 ? 0.5 : 0.0, a == 2 ? 0.5 : 0.0};
            e.second.add(g.indexToPhysical(double(i) + h[0], double(j) + h[1], double(k) + h[2]), faceArea[a]);
          }
        }
  for (const auto& m : cpart)
    for (const auto& [key, e] : m) {
      auto& d = s.contacts[key];
      d.first += e.first;
      d.second.merge(e.second);
    }
  return s;
}

std::vector<std::pair<int32_t, int32_t>> labelContactPairs(const LabelVolume& v) {
  const auto& d = v.grid.dims;
  std::vector<std::vector<std::pair<int32_t, int32_t>>> part(static_cast<size_t>(d[2]));
#pragma omp parallel for schedule(dynamic, 4)
  for (int64_t k = 0; k < d[2]; ++k) {
    auto& out = part[size_t(k)];
    for (int64_t j = 0; j < d[1]; ++j) {
      const int32_t* row = v.data.data() + v.index(0, j, k);
      const int32_t* up = j + 1 < d[1] ? v.data.data() + v.index(0, j + 1, k) : nullptr;
      const int32_t* above = k + 1 < d[2] ? v.data.data() + v.index(0, j, k + 1) : nullptr;
      for (int64_t i = 0; i < d[0]; ++i) {
        const int32_t a = row[i];
        const int32_t nbs[3] = {i + 1 < d[0] ? row[i + 1] : a, up ? up[i] : a, above ? above[i] : a};
        for (int32_t b : nbs)
          if (b != a) {
            const std::pair<int32_t, int32_t> pr{std::min(a, b), std::max(a, b)};
            if (std::find(out.begin(), out.end(), pr) == out.end()) out.push_back(pr);
          }
      }
    }
  }
  std::vector<std::pair<int32_t, int32_t>> pairs;
  for (const auto& pt : part) pairs.insert(pairs.end(), pt.begin(), pt.end());
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

namespace {
// A face in the bucket of its smallest vertex: the other two vertices and 4 * tet + face.
struct BucketFace {
  int32_t b, c;
  int64_t tf;
  bool operator<(const BucketFace& o) const {
    return b != o.b ? b < o.b : (c != o.c ? c < o.c : tf < o.tf);
  }
};

} // namespace

std::vector<int32_t> tetFaceNeighbours(const TetMesh& mesh, Progress& progress) {
  // Faces bucketed by their smallest vertex (a counting sort, linear), then each small bucket
  // sorted and scanned: O(n) apart from the buckets' own sorts.
  const int64_t n = static_cast<int64_t>(mesh.numTets());
  const size_t nP = mesh.numPoints();
  auto sortedFace = [&](int64_t t, int f) {
    const auto& q = mesh.tets[static_cast<size_t>(t)];
    std::array<int32_t, 3> v{q[kTetFaceVertices[f][0]], q[kTetFaceVertices[f][1]], q[kTetFaceVertices[f][2]]};
    std::sort(v.begin(), v.end());
    return v;
  };
  std::vector<int64_t> offset(nP + 1, 0);
  LoopCancel countCancel(progress);
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < n; ++t) {
    if (countCancel.skip(t)) continue;
    for (int f = 0; f < 4; ++f)
      std::atomic_ref<int64_t>(offset[static_cast<size_t>(sortedFace(t, f)[0]) + 1]).fetch_add(1, std::memory_order_relaxed);
  }
  countCancel.rethrow();
  for (size_t p = 0; p < nP; ++p) offset[p + 1] += offset[p];
  progress.checkCancel();
  // Not value-initialised: every slot is written by the fill below, whose threads then touch the
  // pages first (zeroing 16 bytes per face up front took longer than the whole fill).
  const auto faces = std::make_unique_for_overwrite<BucketFace[]>(static_cast<size_t>(4 * n));
  {
    // Filled in any order; every bucket is sorted completely below, so the result is the same.
    std::vector<int64_t> pos(offset.begin(), offset.end() - 1);
    LoopCancel fillCancel(progress);
#pragma omp parallel for schedule(static)
    for (int64_t t = 0; t < n; ++t) {
      if (fillCancel.skip(t)) continue;
      for (int f = 0; f < 4; ++f) {
        const auto v = sortedFace(t, f);
        const int64_t at =
            std::atomic_ref<int64_t>(pos[static_cast<size_t>(v[0])]).fetch_add(1, std::memory_order_relaxed);
        faces[static_cast<size_t>(at)] = {v[1], v[2], 4 * t + f};
      }
    }
    fillCancel.rethrow();
  }
  progress.checkCancel();
  std::vector<int32_t> nb(static_cast<size_t>(4 * n), kNoNeighbour);
  LoopCancel matchCancel(progress);
#pragma omp parallel for schedule(dynamic, 4096)
  for (int64_t p = 0; p < static_cast<int64_t>(nP); ++p) {
    if (matchCancel.skip(p)) continue;
    BucketFace* const first = faces.get() + offset[static_cast<size_t>(p)];
    BucketFace* const last = faces.get() + offset[static_cast<size_t>(p) + 1];
    std::sort(first, last);
    for (auto i = first; i != last;) {
      auto j = i + 1;
      while (j != last && j->b == i->b && j->c == i->c) ++j;
      if (j - i == 2) {
        nb[static_cast<size_t>(i->tf)] = static_cast<int32_t>((i + 1)->tf / 4);
        nb[static_cast<size_t>((i + 1)->tf)] = static_cast<int32_t>(i->tf / 4);
      } else if (j - i > 2) {
        for (auto a = i; a != j; ++a) nb[static_cast<size_t>(a->tf)] = kCrowdedFace;
      }
      i = j;
    }
  }
  matchCancel.rethrow();
  return nb;
}

Vec3 tetCentroid(const TetMesh& m, size_t t) {
  const auto& q = m.tets[t];
  return 0.25 * (m.points[static_cast<size_t>(q[0])] + m.points[static_cast<size_t>(q[1])] +
                 m.points[static_cast<size_t>(q[2])] + m.points[static_cast<size_t>(q[3])]);
}

double tetFaceArea(const TetMesh& m, size_t t, int f, Vec3* centre) {
  const auto& q = m.tets[t];
  const Vec3& a = m.points[static_cast<size_t>(q[kTetFaceVertices[f][0]])];
  const Vec3& b = m.points[static_cast<size_t>(q[kTetFaceVertices[f][1]])];
  const Vec3& c = m.points[static_cast<size_t>(q[kTetFaceVertices[f][2]])];
  if (centre) *centre = (1.0 / 3.0) * (a + b + c);
  return 0.5 * norm(cross(b - a, c - a));
}

VertexStars vertexStars(const TetMesh& mesh) {
  const size_t nP = mesh.numPoints();
  VertexStars s;
  s.offset.assign(nP + 1, 0);
  for (const auto& q : mesh.tets)
    for (int a = 0; a < 4; ++a) ++s.offset[size_t(q[size_t(a)]) + 1];
  for (size_t p = 0; p < nP; ++p) s.offset[p + 1] += s.offset[p];
  s.tets.resize(static_cast<size_t>(s.offset[nP]));
  std::vector<int64_t> pos(s.offset.begin(), s.offset.end() - 1);
  for (size_t t = 0; t < mesh.numTets(); ++t)
    for (int a = 0; a < 4; ++a) s.tets[size_t(pos[size_t(mesh.tets[t][size_t(a)])]++)] = static_cast<int32_t>(t);
  return s;
}

// Continuous voxel-index coordinates of a physical point.
int32_t voteImageComponent(const LabelVolume& labels, const std::vector<int32_t>& comp, const Vec3& c, int32_t L) {
  const auto& g = labels.grid;
  const int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  int64_t r[3];
  for (int a = 0; a < 3; ++a) r[a] = std::clamp<int64_t>(static_cast<int64_t>(std::llround(c[a])), 0, g.dims[a] - 1);
  const int64_t v = r[0] + nx * (r[1] + ny * r[2]);
  if (labels.data[static_cast<size_t>(v)] == L) return comp[static_cast<size_t>(v)];
  double best = std::numeric_limits<double>::infinity();
  int32_t vote = -1;
  for (int dk = -1; dk <= 1; ++dk)
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di) {
        const int64_t a = r[0] + di, b = r[1] + dj, e = r[2] + dk;
        if (a < 0 || b < 0 || e < 0 || a >= nx || b >= ny || e >= nz) continue;
        const int64_t w = a + nx * (b + ny * e);
        if (labels.data[static_cast<size_t>(w)] != L) continue;
        const double dx = (double(a) - c[0]) * g.spacing[0], dy = (double(b) - c[1]) * g.spacing[1],
                     dz = (double(e) - c[2]) * g.spacing[2];
        const double d2 = dx * dx + dy * dy + dz * dz;
        if (d2 < best) {
          best = d2;
          vote = comp[static_cast<size_t>(w)];
        }
      }
  return vote;
}

DisjointSets sameLabelPieces(const TetMesh& mesh, const std::vector<int32_t>& nb) {
  DisjointSets sets(mesh.numTets());
  for (size_t t = 0; t < mesh.numTets(); ++t)
    for (int f = 0; f < 4; ++f) {
      const int32_t o = nb[4 * t + size_t(f)];
      if (o > int32_t(t) && mesh.materials[size_t(o)] == mesh.materials[t]) sets.unite(int32_t(t), o);
    }
  return sets;
}

std::vector<int32_t> tetVotes(const TetMesh& mesh, const LabelVolume& labels, const std::vector<int32_t>& comp) {
  const IndexFrame frame{labels.grid};
  std::vector<int32_t> vote(mesh.numTets());
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < static_cast<int64_t>(mesh.numTets()); ++t)
    vote[size_t(t)] = voteImageComponent(labels, comp, frame.toIndex(tetCentroid(mesh, size_t(t))),
                                         mesh.materials[size_t(t)]);
  return vote;
}

} // namespace tetflow
