#include "LabelTopology.h"

#include <unordered_map>

#include <algorithm>
#include <atomic>
#include <memory>
#include <cmath>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Quality/LabelRuns.h"

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
  // Everything on the runs along x (LabelRuns.h): components are joined runs, cores are joined
  // runs of core voxels, contacts are where runs end or neighbouring rows differ.
  const LabelRows rows = labelRows(v);
  DisjointSets sets(rows.runs.size());
  joinRuns(rows, sets, progress);
  const LabelRows cores = coreRows(v);
  DisjointSets coreSets(cores.runs.size());
  joinRuns(cores, coreSets, progress);
  progress.checkCancel();

  LabelImageTopology s;
  int32_t count = 0;
  const std::vector<int32_t> compOfRun = runComponents(rows, sets, count); // in scan order
  s.comps.resize(size_t(count));
  // Labels, sizes, places and box contact; each core component counted once, in the component of
  // the run that holds its first core run.
  for (int64_t r = 0; r < rows.rows(); ++r) {
    const int64_t j = r % ny, k = r / ny;
    const bool rowOnBox = j == 0 || k == 0 || j == ny - 1 || k == nz - 1;
    for (int64_t q = rows.start[size_t(r)]; q < rows.start[size_t(r) + 1]; ++q) {
      const LabelRun& x = rows.runs[size_t(q)];
      ImageComponent& ic = s.comps[size_t(compOfRun[size_t(q)])];
      const int64_t len = x.i1 - x.i0 + 1;
      ic.label = x.label;
      ic.voxels += len;
      ic.where.addRun(g.indexToPhysical(x.i0, double(j), double(k)), g.indexToPhysical(x.i1, double(j), double(k)),
                      double(len), 1.0);
      ic.touchesBox = ic.touchesBox || rowOnBox || x.i0 == 0 || x.i1 == nx - 1;
    }
  }
  std::vector<uint8_t> coreCounted(cores.runs.size(), 0);
  forEachCoreRun(rows, cores, [&](int64_t c, int64_t q) {
    const int32_t root = coreSets.find(int32_t(c));
    if (coreCounted[size_t(root)]) return;
    coreCounted[size_t(root)] = 1;
    ++s.comps[size_t(compOfRun[size_t(q)])].cores;
  });
  progress.checkCancel();
  s.comp.resize(static_cast<size_t>(n));
  paintRuns(rows, compOfRun, s.comp);
  progress.checkCancel();

  // Contacts across voxel faces: where a row's runs end (x), and where a row and the next one in
  // y or z differ; per z plane, merged in plane order (the same sums whatever the thread count).
  const double faceArea[3] = {g.spacing[1] * g.spacing[2], g.spacing[0] * g.spacing[2],
                              g.spacing[0] * g.spacing[1]};
  std::vector<std::map<uint64_t, std::pair<double, PlaceAcc>>> cpart(static_cast<size_t>(nz));
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t k = 0; k < nz; ++k) {
    auto& part = cpart[size_t(k)];
    for (int64_t j = 0; j < ny; ++j) {
      const int64_t r = j + ny * k;
      const int64_t b0 = rows.start[size_t(r)], b1 = rows.start[size_t(r) + 1];
      for (int64_t q = b0; q + 1 < b1; ++q) {
        const LabelRun &x = rows.runs[size_t(q)], &y = rows.runs[size_t(q) + 1];
        auto& e = part[labelPairKey(x.label, y.label)];
        e.first += faceArea[0];
        e.second.add(g.indexToPhysical(x.i1 + 0.5, double(j), double(k)), faceArea[0]);
      }
      // Row r against row r2, one step along axis a (1: y, 2: z).
      auto across = [&](int64_t r2, int a) {
        int64_t p = b0, q = rows.start[size_t(r2)];
        const int64_t q1 = rows.start[size_t(r2) + 1];
        const double dj = a == 1 ? 0.5 : 0.0, dk = a == 2 ? 0.5 : 0.0;
        while (p < b1 && q < q1) {
          const LabelRun &x = rows.runs[size_t(p)], &y = rows.runs[size_t(q)];
          const int32_t lo = std::max(x.i0, y.i0), hi = std::min(x.i1, y.i1);
          if (x.label != y.label) {
            auto& e = part[labelPairKey(x.label, y.label)];
            const double len = hi - lo + 1;
            e.first += len * faceArea[a];
            e.second.addRun(g.indexToPhysical(lo, j + dj, k + dk), g.indexToPhysical(hi, j + dj, k + dk), len,
                            faceArea[a]);
          }
          if (x.i1 <= y.i1) ++p;
          if (y.i1 <= x.i1) ++q;
        }
      };
      if (j + 1 < ny) across(r + 1, 1);
      if (k + 1 < nz) across(r + ny, 2);
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
      // Three plain comparison loops (the compiler vectorises them); a pair is looked up only where
      // the labels differ.
      auto add = [&](int32_t a, int32_t b) {
        const std::pair<int32_t, int32_t> pr{std::min(a, b), std::max(a, b)};
        if (std::find(out.begin(), out.end(), pr) == out.end()) out.push_back(pr);
      };
      auto against = [&](const int32_t* other, int64_t n) {
        for (int64_t i = 0; i < n;) {
          constexpr int64_t kBlock = 64;
          const int64_t e = std::min(n, i + kBlock);
          bool differ = false;
          for (int64_t x = i; x < e; ++x) differ |= row[x] != other[x];
          if (differ)
            for (int64_t x = i; x < e; ++x)
              if (row[x] != other[x]) add(row[x], other[x]);
          i = e;
        }
      };
      against(row + 1, d[0] - 1);
      if (j + 1 < d[1]) against(v.data.data() + v.index(0, j + 1, k), d[0]);
      if (k + 1 < d[2]) against(v.data.data() + v.index(0, j, k + 1), d[0]);
    }
  }
  std::vector<std::pair<int32_t, int32_t>> pairs;
  for (const auto& pt : part) pairs.insert(pairs.end(), pt.begin(), pt.end());
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

bool labelsTouchInBox(const LabelVolume& v, int32_t a, int32_t b, const int64_t lo[3], const int64_t hi[3]) {
  const auto& d = v.grid.dims;
  for (int64_t k = lo[2]; k <= hi[2]; ++k)
    for (int64_t j = lo[1]; j <= hi[1]; ++j) {
      const int32_t* row = v.data.data() + v.index(0, j, k);
      const int32_t* up = j < hi[1] ? row + d[0] : nullptr;
      const int32_t* above = k < hi[2] ? row + d[0] * d[1] : nullptr;
      for (int64_t i = lo[0]; i <= hi[0]; ++i) {
        const int32_t L = row[i];
        if (L != a && L != b) continue;
        const int32_t other = L == a ? b : a;
        if ((i < hi[0] && row[i + 1] == other) || (up && up[i] == other) || (above && above[i] == other)) return true;
      }
    }
  return false;
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

std::array<int32_t, 3> sortedTetFace(const TetMesh& mesh, int64_t t, int f) {
  const auto& q = mesh.tets[static_cast<size_t>(t)];
  std::array<int32_t, 3> v{q[kTetFaceVertices[f][0]], q[kTetFaceVertices[f][1]], q[kTetFaceVertices[f][2]]};
  if (v[0] > v[1]) std::swap(v[0], v[1]);
  if (v[1] > v[2]) std::swap(v[1], v[2]);
  if (v[0] > v[1]) std::swap(v[0], v[1]);
  return v;
}

// The smallest vertex of each face f of a tet (face f omits vertex f).
std::array<int32_t, 4> smallestFaceVertices(const TetMesh::Tet& q) {
  const int32_t lo01 = std::min(q[0], q[1]), lo23 = std::min(q[2], q[3]);
  return {std::min(q[1], lo23), std::min(q[0], lo23), std::min(lo01, q[3]), std::min(lo01, q[2])};
}

// The buckets hold only 4 * tet + face (Index: 4 bytes while 4 n fits in 32 bits); a bucket's
// other two vertices are read back from the tets when it is matched. Writing 16 bytes per face
// took more time (fresh pages) than reading the tets again, and four times the memory.
template <class Index>
std::vector<int32_t> matchFaces(const TetMesh& mesh, Progress& progress) {
  const int64_t n = static_cast<int64_t>(mesh.numTets());
  const size_t nP = mesh.numPoints();
  std::vector<int64_t> offset(nP + 1, 0);
  LoopCancel countCancel(progress);
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < n; ++t) {
    if (countCancel.skip(t)) continue;
    const auto& q = mesh.tets[static_cast<size_t>(t)];
    const auto smallest = smallestFaceVertices(q);
    for (int f = 0; f < 4; ++f)
      std::atomic_ref<int64_t>(offset[static_cast<size_t>(smallest[f]) + 1]).fetch_add(1, std::memory_order_relaxed);
  }
  countCancel.rethrow();
  for (size_t p = 0; p < nP; ++p) offset[p + 1] += offset[p];
  progress.checkCancel();
  // Not value-initialised: every slot is written by the fill below, whose threads then touch the
  // pages first.
  const auto faces = std::make_unique_for_overwrite<Index[]>(static_cast<size_t>(4 * n));
  {
    // Filled in any order; every bucket is sorted completely below, so the result is the same.
    std::vector<int64_t> pos(offset.begin(), offset.end() - 1);
    LoopCancel fillCancel(progress);
#pragma omp parallel for schedule(static)
    for (int64_t t = 0; t < n; ++t) {
      if (fillCancel.skip(t)) continue;
      const auto& q = mesh.tets[static_cast<size_t>(t)];
      const auto smallest = smallestFaceVertices(q);
      for (int f = 0; f < 4; ++f) {
        const int64_t at =
            std::atomic_ref<int64_t>(pos[static_cast<size_t>(smallest[f])]).fetch_add(1, std::memory_order_relaxed);
        faces[static_cast<size_t>(at)] = static_cast<Index>(4 * t + f);
      }
    }
    fillCancel.rethrow();
  }
  progress.checkCancel();
  std::vector<int32_t> nb(static_cast<size_t>(4 * n), kNoNeighbour);
  LoopCancel matchCancel(progress);
#pragma omp parallel
  {
    std::vector<BucketFace> bucket;
#pragma omp for schedule(dynamic, 4096)
    for (int64_t p = 0; p < static_cast<int64_t>(nP); ++p) {
      if (matchCancel.skip(p)) continue;
      bucket.clear();
      for (int64_t i = offset[static_cast<size_t>(p)]; i < offset[static_cast<size_t>(p) + 1]; ++i) {
        const int64_t tf = static_cast<int64_t>(faces[static_cast<size_t>(i)]);
        const auto v = sortedTetFace(mesh, tf / 4, static_cast<int>(tf % 4));
        bucket.push_back({v[1], v[2], tf});
      }
      std::sort(bucket.begin(), bucket.end());
      for (auto i = bucket.begin(); i != bucket.end();) {
        auto j = i + 1;
        while (j != bucket.end() && j->b == i->b && j->c == i->c) ++j;
        if (j - i == 2) {
          nb[static_cast<size_t>(i->tf)] = static_cast<int32_t>((i + 1)->tf / 4);
          nb[static_cast<size_t>((i + 1)->tf)] = static_cast<int32_t>(i->tf / 4);
        } else if (j - i > 2) {
          for (auto a = i; a != j; ++a) nb[static_cast<size_t>(a->tf)] = kCrowdedFace;
        }
        i = j;
      }
    }
  }
  matchCancel.rethrow();
  return nb;
}

} // namespace

std::vector<int32_t> tetFaceNeighbours(const TetMesh& mesh, Progress& progress) {
  // Faces bucketed by their smallest vertex (a counting sort, linear), then each small bucket
  // sorted and scanned: O(n) apart from the buckets' own sorts.
  if (4 * static_cast<uint64_t>(mesh.numTets()) <= std::numeric_limits<uint32_t>::max())
    return matchFaces<uint32_t>(mesh, progress);
  return matchFaces<uint64_t>(mesh, progress);
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
  VertexStars s;
  const NullProgress never;
  tetsAroundVertices(
      static_cast<int64_t>(mesh.numTets()), mesh.numPoints(),
      [&](int64_t t) -> const TetMesh::Tet& { return mesh.tets[size_t(t)]; }, [](int32_t) { return true; }, s.offset,
      s.tets, never);
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

DisjointSets sameLabelPieces(const TetMesh& mesh, const std::vector<int32_t>& nb, const TetJoins* joins) {
  // Both threads join tets at once; every set's root is its smallest tet either way, so the sets
  // (and every find() on them) are those of a serial union-find.
  ConcurrentSets sets(mesh.numTets());
  const int64_t n = static_cast<int64_t>(mesh.numTets());
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < n; ++t)
    for (int f = 0; f < 4; ++f) {
      const int32_t o = nb[4 * size_t(t) + size_t(f)];
      if (o > int32_t(t) && mesh.materials[size_t(o)] == mesh.materials[size_t(t)]) sets.unite(int32_t(t), o);
    }
  if (joins)
    for (const auto& [a, b] : *joins)
      if (mesh.materials[size_t(a)] == mesh.materials[size_t(b)]) sets.unite(a, b);
  // Every parent is at most its child (the smaller root wins), so one pass in order points each
  // tet at its root: later finds take one step.
  DisjointSets out(0);
  out.parent = std::move(sets.parent);
  for (int64_t t = 0; t < n; ++t) out.parent[size_t(t)] = out.parent[size_t(out.parent[size_t(t)])];
  return out;
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
