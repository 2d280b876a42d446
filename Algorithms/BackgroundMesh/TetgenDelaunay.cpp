#include "TetgenDelaunay.h"

#include <tetgen.h>

#include <cstring>
#include <string>
#include <vector>

#include "Algorithms/Core/Errors.h"

namespace tetflow {

std::vector<TetMesh::Tet> tetgenDelaunay(std::vector<Vec3>& points, const std::string& switches, int64_t* flat,
                                         int64_t* duplicates) {
  if (points.size() < 4) throw InputError("a Delaunay tetrahedralization needs at least 4 points");
  if (points.size() >= size_t(INT32_MAX / 2)) throw InputError("too many points for TetGen (2^30 at most)");
  tetgenio in, out;
  in.firstnumber = 0;
  in.numberofpoints = int(points.size());
  in.pointlist = new REAL[points.size() * 3];
  for (size_t i = 0; i < points.size(); ++i)
    for (int a = 0; a < 3; ++a) in.pointlist[3 * i + size_t(a)] = points[i][size_t(a)];
  std::string sw = "Qz" + switches;
  std::vector<char> buf(sw.begin(), sw.end());
  buf.push_back('\0');
  try {
    tetrahedralize(buf.data(), &in, &out);
  } catch (int code) {
    const char* why = code == 1   ? "out of memory"
                      : code == 2 ? "internal error"
                      : code == 3 ? "a self-intersection"
                      : code == 4 ? "a very small input feature size"
                      : code == 5 ? "two very close input facets"
                      : code == 10 ? "an input error"
                                  : "an unknown error";
    throw ProcessingError("TetGen failed (" + std::string(why) + ", code " + std::to_string(code) + ") on " +
                          std::to_string(points.size()) + " points with switches -" + sw);
  }
  if (out.numberofcorners != 4) throw ProcessingError("TetGen returned elements that are not linear tets");
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
