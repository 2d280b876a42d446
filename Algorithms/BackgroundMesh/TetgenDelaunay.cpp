#include "TetgenDelaunay.h"

#include <cstring>
#include <string>
#include <vector>

#include "Algorithms/Core/Errors.h"
#include "TetgenCall.h"

namespace tetflow {

std::vector<TetMesh::Tet> tetgenDelaunay(std::vector<Vec3>& points, const std::string& switches, int64_t* flat,
                                         int64_t* duplicates) {
  if (points.size() < 4) throw InputError("a Delaunay tetrahedralization needs at least 4 points");
  if (points.size() >= size_t(INT32_MAX / 2)) throw InputError("too many points for TetGen (2^30 at most)");
  tetgenio in, out;
  tetgencall::setPoints(in, points);
  const std::string sw = "Qz" + switches;
  tetgencall::run(sw, in, out, std::to_string(points.size()) + " points");
  const size_t n0 = points.size();
  for (int i = int(n0); i < out.numberofpoints; ++i)
    points.push_back({out.pointlist[3 * i], out.pointlist[3 * i + 1], out.pointlist[3 * i + 2]});
  std::vector<TetMesh::Tet> tets;
  tets.reserve(size_t(out.numberoftetrahedra));
  std::vector<char> used(points.size(), 0);
  int64_t nflat = 0;
  for (int t = 0; t < out.numberoftetrahedra; ++t) {
    TetMesh::Tet q;
    for (int c = 0; c < 4; ++c) {
      const int v = out.tetrahedronlist[4 * t + c];
      if (v < 0 || size_t(v) >= points.size()) throw ProcessingError("TetGen returned a vertex index out of range");
      q[size_t(c)] = v;
    }
    const double vol = signedTetVolume(points[size_t(q[0])], points[size_t(q[1])], points[size_t(q[2])], points[size_t(q[3])]);
    if (vol == 0.0) {
      ++nflat;
      continue;
    }
    if (vol < 0) std::swap(q[0], q[1]);
    for (int c = 0; c < 4; ++c) used[size_t(q[size_t(c)])] = 1;
    tets.push_back(q);
  }
  if (flat) *flat = nflat;
  if (duplicates) {
    int64_t d = 0;
    for (char u : used) d += !u;
    *duplicates = d;
  }
  return tets;
}

} // namespace tetflow
