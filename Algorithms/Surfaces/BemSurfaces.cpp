// Closed triangle surfaces out of a labelled tet mesh (see BemSurfaces.h).
#include "Algorithms/Surfaces/BemSurfaces.h"

#include <algorithm>
#include <numeric>
#include <unordered_map>

#include "Algorithms/Quality/LabelTopology.h"
#include "Algorithms/SurfaceMeshing/SurfaceIntersections.h"

namespace tetflow {


std::vector<uint8_t> materialMask(const TetMesh& mesh, const std::vector<int32_t>& materials) {
  std::vector<int32_t> sorted = materials;
  std::sort(sorted.begin(), sorted.end());
  std::vector<uint8_t> inside(mesh.numTets());
  for (size_t t = 0; t < mesh.numTets(); ++t)
    inside[t] = std::binary_search(sorted.begin(), sorted.end(), mesh.materials[t]) ? 1 : 0;
  return inside;
}

TriSurface unionBoundary(const TetMesh& mesh, const std::vector<int32_t>& materials, const std::vector<int32_t>& nb) {
  return maskBoundary(mesh, materialMask(mesh, materials), nb);
}

TriSurface maskBoundary(const TetMesh& mesh, const std::vector<uint8_t>& inside, const std::vector<int32_t>& nb) {
  TriSurface s;
  std::unordered_map<int32_t, int32_t> index;
  auto point = [&](int32_t v) {
    auto [it, added] = index.emplace(v, int32_t(s.points.size()));
    if (added) {
      s.points.push_back(mesh.points[size_t(v)]);
      s.meshVertex.push_back(v);
    }
    return it->second;
  };
  for (size_t t = 0; t < mesh.numTets(); ++t) {
    if (!inside[t]) continue;
    const auto& q = mesh.tets[t];
    for (int f = 0; f < 4; ++f) {
      const int32_t o = nb[4 * t + size_t(f)];
      if (o >= 0 && inside[size_t(o)]) continue;
      int32_t a = q[size_t(kTetFaceVertices[f][0])], b = q[size_t(kTetFaceVertices[f][1])], c = q[size_t(kTetFaceVertices[f][2])];
      const Vec3 &pa = mesh.points[size_t(a)], &pb = mesh.points[size_t(b)], &pc = mesh.points[size_t(c)];
      if (dot(cross(pb - pa, pc - pa), mesh.points[size_t(q[size_t(f)])] - pa) > 0) std::swap(b, c); // outward
      s.triangles.push_back({point(a), point(b), point(c)});
    }
  }
  return s;
}

SurfaceCheck checkSurface(const TriSurface& s, std::vector<int32_t>* defective) {
  SurfaceCheck c;
  c.triangles = int64_t(s.triangles.size());
  c.vertices = int64_t(s.points.size());
  // Directed edges (from, to, triangle), grouped by their undirected edge.
  struct Edge {
    int32_t lo, hi, tri;
    bool forward;
    bool operator<(const Edge& e) const { return lo != e.lo ? lo < e.lo : hi != e.hi ? hi < e.hi : tri < e.tri; }
  };
  std::vector<Edge> edges;
  edges.reserve(3 * s.triangles.size());
  for (size_t i = 0; i < s.triangles.size(); ++i) {
    const auto& t = s.triangles[i];
    for (int k = 0; k < 3; ++k) {
      const int32_t u = t[size_t(k)], v = t[size_t((k + 1) % 3)];
      edges.push_back({std::min(u, v), std::max(u, v), int32_t(i), u < v});
    }
    const Vec3 &a = s.points[size_t(t[0])], &b = s.points[size_t(t[1])], &d = s.points[size_t(t[2])];
    c.area += 0.5 * norm(cross(b - a, d - a));
    c.enclosedVolume += dot(a, cross(b, d)) / 6.0;
  }
  std::sort(edges.begin(), edges.end());
  DisjointSets tris(s.triangles.size());
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j].lo == edges[i].lo && edges[j].hi == edges[i].hi) {
      tris.unite(edges[j - 1].tri, edges[j].tri);
      ++j;
    }
    const size_t n = j - i;
    if (n == 1) ++c.openEdges;
    else if (n > 2) {
      ++c.nonManifoldEdges;
      if (defective) {
        defective->push_back(edges[i].lo);
        defective->push_back(edges[i].hi);
      }
    }
    else if (edges[i].forward == edges[i + 1].forward) ++c.misorientedEdges;
    i = j;
  }
  for (size_t i = 0; i < s.triangles.size(); ++i)
    if (tris.find(int32_t(i)) == int32_t(i)) ++c.components;
  // One fan per vertex: the link edges (the opposite edge of each incident triangle) connect.
  std::vector<std::vector<std::array<int32_t, 2>>> link(s.points.size());
  for (const auto& t : s.triangles)
    for (int k = 0; k < 3; ++k) link[size_t(t[size_t(k)])].push_back({t[size_t((k + 1) % 3)], t[size_t((k + 2) % 3)]});
  for (size_t p = 0; p < link.size(); ++p) {
    const auto& l = link[p];
    if (l.size() < 2) continue;
    std::vector<int32_t> ends;
    for (const auto& e : l) {
      ends.push_back(e[0]);
      ends.push_back(e[1]);
    }
    std::sort(ends.begin(), ends.end());
    ends.erase(std::unique(ends.begin(), ends.end()), ends.end());
    DisjointSets u(ends.size());
    auto at = [&](int32_t v) { return int32_t(std::lower_bound(ends.begin(), ends.end(), v) - ends.begin()); };
    for (const auto& e : l) u.unite(at(e[0]), at(e[1]));
    int fans = 0;
    for (size_t k = 0; k < ends.size(); ++k) fans += u.find(int32_t(k)) == int32_t(k);
    if (fans > 1) {
      ++c.nonManifoldVertices;
      if (defective) defective->push_back(int32_t(p));
    }
  }
  if (defective) {
    std::sort(defective->begin(), defective->end());
    defective->erase(std::unique(defective->begin(), defective->end()), defective->end());
  }
  return c;
}

int64_t sharedVertices(const TriSurface& a, const TriSurface& b) {
  std::vector<int32_t> x = a.meshVertex, y = b.meshVertex;
  std::sort(x.begin(), x.end());
  std::sort(y.begin(), y.end());
  std::vector<int32_t> both;
  std::set_intersection(x.begin(), x.end(), y.begin(), y.end(), std::back_inserter(both));
  return int64_t(both.size());
}

int64_t selfIntersections(const TriSurface& s, size_t atMost) {
  return int64_t(surfaceIntersections(s.points, s.triangles, atMost).size());
}

int64_t crossingPairs(const TriSurface& a, const TriSurface& b, size_t atMost) {
  std::vector<Vec3> points = a.points;
  points.insert(points.end(), b.points.begin(), b.points.end());
  std::vector<std::array<int32_t, 3>> triangles = a.triangles;
  const int32_t offset = int32_t(a.points.size());
  for (const auto& t : b.triangles) triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  int64_t between = 0;
  for (const SurfaceIntersection& x : surfaceIntersections(points, triangles, atMost))
    between += (size_t(x.a) < a.triangles.size()) != (size_t(x.b) < a.triangles.size());
  return between;
}

} // namespace tetflow
