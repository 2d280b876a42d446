#pragma once
// The star of every vertex (the tets around it), visited in parallel without holding the whole
// vertex -> tets map: the vertices are taken in consecutive blocks whose stars together hold at
// most `maxCorners` tet corners; for each block one parallel pass over the tets lists the tets of
// the block's vertices, then the block's vertices are visited in parallel. Temporary memory is
// 4 B per listed corner + 16 B per block vertex, whatever the mesh size; the price is one pass over
// the tets per block (a few ms per M tets).
//
// Used by the FEM assembly (pattern and values column by column) and by the boundary-vertex
// search. Deterministic: a vertex's tets are given in ascending order whatever the thread count.
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/TetMesh.h"

namespace tetflow {

// Number of tet corners at each vertex (a tet naming a vertex twice counts twice). Parallel.
std::vector<int32_t> vertexDegrees(const TetMesh& mesh);

// Default block budget: a quarter of all corners (four or five passes over the tets: blocks are
// whole vertices), at least 2^18.
inline int64_t defaultStarBlockCorners(int64_t totalCorners) {
  return std::max<int64_t>(int64_t(1) << 18, (totalCorners + 3) / 4);
}

// visit(thread, vertex, tets, count) is called once for every vertex v with degree[v] > 0, from
// `omp_get_max_threads()` threads (thread in [0, omp_get_max_threads())); tets[0..count) are the
// tets containing v in ascending order (a tet naming v twice appears twice). Calls
// progress.checkCancel() after each block. `degree` is vertexDegrees(mesh).
template <class Visit>
void forEachVertexStar(const TetMesh& mesh, const std::vector<int32_t>& degree, int64_t maxCorners,
                       Progress& progress, Visit&& visit) {
  const int64_t np = static_cast<int64_t>(degree.size());
  const int64_t nt = static_cast<int64_t>(mesh.numTets());
  // Blocks first, so that the buffers are allocated once at their largest size (growing a vector
  // block by block would hold the old and the new buffer at once).
  std::vector<int64_t> bounds{0};
  int64_t largestCorners = 0, largestVertices = 0;
  for (int64_t lo = 0; lo < np;) {
    int64_t hi = lo, corners = 0;
    while (hi < np && (hi == lo || corners + degree[size_t(hi)] <= maxCorners)) corners += degree[size_t(hi++)];
    largestCorners = std::max(largestCorners, corners);
    largestVertices = std::max(largestVertices, hi - lo);
    bounds.push_back(hi);
    lo = hi;
  }
  std::vector<int64_t> offsets, cursor;
  offsets.reserve(size_t(largestVertices + 1));
  cursor.reserve(size_t(largestVertices));
  std::vector<int32_t> list;
  list.reserve(size_t(largestCorners));
  for (size_t bi = 0; bi + 1 < bounds.size(); ++bi) {
    const int64_t lo = bounds[bi], hi = bounds[bi + 1];
    offsets.assign(size_t(hi - lo + 1), 0);
    for (int64_t v = lo; v < hi; ++v) offsets[size_t(v - lo + 1)] = offsets[size_t(v - lo)] + degree[size_t(v)];
    cursor.assign(offsets.begin(), offsets.end() - 1);
    list.resize(size_t(offsets.back()));
#pragma omp parallel for schedule(static)
    for (int64_t t = 0; t < nt; ++t)
      for (int32_t v : mesh.tets[size_t(t)])
        if (v >= lo && v < hi) {
          const int64_t k = std::atomic_ref<int64_t>(cursor[size_t(v - lo)]).fetch_add(1, std::memory_order_relaxed);
          list[size_t(k)] = static_cast<int32_t>(t);
        }
#pragma omp parallel for schedule(dynamic, 512)
    for (int64_t v = lo; v < hi; ++v) {
      const int64_t b = offsets[size_t(v - lo)], e = offsets[size_t(v - lo + 1)];
      if (b == e) continue;
      std::sort(list.begin() + b, list.begin() + e); // atomics fill in any order
      visit(omp_get_thread_num(), static_cast<int32_t>(v), list.data() + b, static_cast<size_t>(e - b));
    }
    progress.checkCancel();
  }
}

} // namespace tetflow
