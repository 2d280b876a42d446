#pragma once
// Building blocks shared by the mesh certificate (Certificate.h) and the label repair of cleaving
// (Algorithms/Cleaving/LabelRepair.h): face adjacency of a tet mesh, the components, cores and
// contacts of a label image, and the vote of a tet for the image component it lies in.
#include <algorithm>
#include <array>
#include <atomic>
#include <cstdint>
#include <limits>
#include <map>
#include <numeric>
#include <utility>
#include <vector>

#include "Algorithms/Core/CancellableSort.h"
#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/Core/Volume.h"

namespace tetflow {

// Faces of tet (a,b,c,d) by the index of the vertex they omit: face f omits vertex f.
inline constexpr int kTetFaceVertices[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
inline constexpr int32_t kNoNeighbour = -1;  // across a boundary face
inline constexpr int32_t kCrowdedFace = -2;  // across a face of more than two tets

// nb[4 t + f] = the tet across face f of tet t, or kNoNeighbour / kCrowdedFace. Faces are bucketed
// by their smallest vertex and matched within buckets (in parallel): O(n), 4 bytes per face (8 from
// 2^30 tets on) while it runs. Checks cancellation.
std::vector<int32_t> tetFaceNeighbours(const TetMesh& mesh, Progress& progress);

Vec3 tetCentroid(const TetMesh& m, size_t t);
// Area of face f of tet t; its centroid in *centre unless centre is null.
double tetFaceArea(const TetMesh& m, size_t t, int f, Vec3* centre = nullptr);

// Vertex -> tets (CSR): the tets around vertex p are tets[offset[p] .. offset[p + 1]), ascending.
struct VertexStars {
  std::vector<int64_t> offset;
  std::vector<int32_t> tets;
};
VertexStars vertexStars(const TetMesh& mesh);

// The tets (of n, vertices by `verts(t)`, an array of four) around each of nP vertices for which
// keep(v) holds, ascending: list[start[v] .. start[v + 1]) (fileByBucket). Throws Cancelled when
// progress asks.
template <class Verts, class Keep>
void tetsAroundVertices(int64_t n, size_t nP, Verts verts, Keep keep, std::vector<int64_t>& start,
                        std::vector<int32_t>& list, const Progress& progress) {
  fileByBucket<int32_t>(
      n, nP,
      [&](int64_t t, auto&& emit) {
        for (int32_t v : verts(t))
          if (keep(v)) emit(v, static_cast<int32_t>(t));
      },
      start, list, progress);
}

// Union-find whose root is always the smallest index of its set (deterministic numbering).
struct DisjointSets {
  std::vector<int32_t> parent;
  explicit DisjointSets(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int32_t find(int32_t x) {
    while (parent[static_cast<size_t>(x)] != x) {
      parent[static_cast<size_t>(x)] = parent[static_cast<size_t>(parent[static_cast<size_t>(x)])];
      x = parent[static_cast<size_t>(x)];
    }
    return x;
  }
  void unite(int32_t a, int32_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    if (a < b) std::swap(a, b);
    parent[static_cast<size_t>(a)] = b;
  }
};

// Union-find for two threads at once (the smaller root wins, so the sets' roots are their smallest
// elements whatever the order): a root is linked with a compare-and-swap, and path halving's
// writes only ever shorten a path, so racing ones are harmless.
struct ConcurrentSets {
  std::vector<int32_t> parent;
  explicit ConcurrentSets(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int32_t find(int32_t x) {
    for (;;) {
      std::atomic_ref<int32_t> px(parent[size_t(x)]);
      int32_t p = px.load(std::memory_order_relaxed);
      if (p == x) return x;
      const int32_t g = std::atomic_ref<int32_t>(parent[size_t(p)]).load(std::memory_order_relaxed);
      if (g != p) px.compare_exchange_weak(p, g, std::memory_order_relaxed); // halving
      x = g;
    }
  }
  // Joins the sets of a and b; returns the root of the joined set (as it was then).
  int32_t unite(int32_t a, int32_t b) {
    for (;;) {
      a = find(a);
      b = find(b);
      if (a == b) return a;
      if (a < b) std::swap(a, b);
      int32_t expected = a;
      if (std::atomic_ref<int32_t>(parent[size_t(a)]).compare_exchange_strong(expected, b, std::memory_order_relaxed))
        return b;
    }
  }
};

struct Place {
  Vec3 centroid{0, 0, 0}; // mm
  Vec3 boxMin{0, 0, 0};   // mm
  Vec3 boxMax{0, 0, 0};   // mm
};

// A running centroid (weighted) and bounding box.
struct PlaceAcc {
  static constexpr double kInf = std::numeric_limits<double>::infinity();
  double weight = 0.0;
  Vec3 sum{0, 0, 0};
  Vec3 lo{kInf, kInf, kInf}, hi{-kInf, -kInf, -kInf};
  void add(const Vec3& p, double w) {
    weight += w;
    sum = sum + w * p;
    extend(p);
  }
  // `count` points evenly spaced from a to b (a == b when count is 1), each of weight w.
  void addRun(const Vec3& a, const Vec3& b, double count, double w) {
    weight += count * w;
    sum = sum + (0.5 * count * w) * (a + b);
    extend(a);
    extend(b);
  }
  void extend(const Vec3& p) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  }
  void merge(const PlaceAcc& o) {
    weight += o.weight;
    sum = sum + o.sum;
    extend(o.lo);
    extend(o.hi);
  }
  Place place() const {
    Place p;
    p.centroid = weight > 0 ? (1.0 / weight) * sum : sum;
    p.boxMin = weight > 0 ? lo : Vec3{0, 0, 0};
    p.boxMax = weight > 0 ? hi : Vec3{0, 0, 0};
    return p;
  }
};


// Unordered label pair as one key (smaller label first) and back.
uint64_t labelPairKey(int32_t a, int32_t b);
std::pair<int32_t, int32_t> labelPairOf(uint64_t k);

struct ImageComponent {
  int32_t label = 0;
  int64_t voxels = 0;
  int cores = 0;
  bool touchesBox = false; // a voxel on the volume's boundary (the component reaches the box)
  PlaceAcc where; // voxel centres, weight 1 each
};

// Components (26-connected, equal labels) of a label image, with cores (voxels whose six face
// neighbours carry their label; outside the volume counts as the same label) counted as
// 26-connected groups, and the contacts: label pairs on face-adjacent voxels, with the area of
// those voxel faces [mm^2] and their places.
struct LabelImageTopology {
  std::vector<int32_t> comp; // per voxel
  std::vector<ImageComponent> comps;
  std::map<uint64_t, std::pair<double, PlaceAcc>> contacts; // area [mm^2], face centres
};

LabelImageTopology analyzeLabelImage(const LabelVolume& v, Progress& progress);

// Just the label pairs (a < b) that touch across a voxel face, sorted: one parallel pass, no
// components (what the label repair's quick check and the thin-layer test need).
std::vector<std::pair<int32_t, int32_t>> labelContactPairs(const LabelVolume& v);
// Whether labels a and b (a != b) are face-adjacent inside the voxel box [lo, hi] (inclusive,
// within the grid): both voxels of the pair in the box.
bool labelsTouchInBox(const LabelVolume& v, int32_t a, int32_t b, const int64_t lo[3], const int64_t hi[3]);

// Continuous voxel-index coordinates of a physical point.
struct IndexFrame {
  GridGeometry g;
  Vec3 toIndex(const Vec3& p) const {
    const Vec3 d = p - g.origin;
    Vec3 r;
    for (int a = 0; a < 3; ++a)
      r[a] = (g.direction[0][a] * d[0] + g.direction[1][a] * d[1] + g.direction[2][a] * d[2]) / g.spacing[a];
    return r;
  }
};


// The image component that a tet of label L with centroid c (voxel-index coordinates) votes for:
// the component at the voxel containing c when it has label L, else the nearest voxel of label L
// (centre distance in mm) among its 26 neighbours, else -1.
int32_t voteImageComponent(const LabelVolume& labels, const std::vector<int32_t>& comp, const Vec3& c, int32_t L);

// Same-label pieces of a mesh: tets joined by faces (nb from tetFaceNeighbours) when their labels
// are equal.
// Pairs of tets that are connected although they share no face: through a part of the mesh that
// was left out (cleaving's culled exterior, CleavePipeline.h). A pair joins pieces only while both
// tets carry one label.
using TetJoins = std::vector<std::pair<int32_t, int32_t>>;
DisjointSets sameLabelPieces(const TetMesh& mesh, const std::vector<int32_t>& nb, const TetJoins* joins = nullptr);

// voteImageComponent for every tet (in parallel).
std::vector<int32_t> tetVotes(const TetMesh& mesh, const LabelVolume& labels, const std::vector<int32_t>& comp);

} // namespace tetflow
