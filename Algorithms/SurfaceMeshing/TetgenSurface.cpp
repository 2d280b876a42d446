#include "TetgenSurface.h"

#include <sstream>

#include "Algorithms/BackgroundMesh/TetgenCall.h"
#include "Algorithms/Core/Errors.h"

namespace tetflow {

TetMesh tetgenFromSurface(const std::vector<Vec3>& points, const std::vector<std::array<int32_t, 3>>& triangles,
                          const std::vector<TetgenRegion>& regions, const std::string& quality, double maxVolume,
                          TetgenSurfaceStats* stats) {
  if (triangles.size() < 4 || points.size() < 4)
    throw InputError("tetrahedralizing a surface needs at least 4 triangles and 4 points");
  if (points.size() >= size_t(INT32_MAX / 2) || triangles.size() >= size_t(INT32_MAX / 2))
    throw InputError("too many points or triangles for TetGen (2^30 at most)");
  tetgenio in, out;
  tetgencall::setPoints(in, points);
  in.numberoffacets = int(triangles.size());
  in.facetlist = new tetgenio::facet[triangles.size()];
  for (size_t f = 0; f < triangles.size(); ++f) {
    tetgenio::facet& fc = in.facetlist[f];
    tetgenio::init(&fc);
    fc.numberofpolygons = 1;
    fc.polygonlist = new tetgenio::polygon[1];
    tetgenio::init(&fc.polygonlist[0]);
    fc.polygonlist[0].numberofvertices = 3;
    fc.polygonlist[0].vertexlist = new int[3];
    for (int c = 0; c < 3; ++c) {
      const int v = triangles[f][size_t(c)];
      if (v < 0 || size_t(v) >= points.size()) throw InputError("a surface triangle's vertex index is out of range");
      fc.polygonlist[0].vertexlist[c] = v;
    }
  }
  if (!regions.empty()) {
    in.numberofregions = int(regions.size());
    in.regionlist = new REAL[regions.size() * 5];
    for (size_t r = 0; r < regions.size(); ++r) {
      for (int a = 0; a < 3; ++a) in.regionlist[5 * r + size_t(a)] = regions[r].point[size_t(a)];
      in.regionlist[5 * r + 3] = regions[r].label;
      in.regionlist[5 * r + 4] = -1;
    }
  }
  std::ostringstream sw;
  sw << "pzQY";
  if (!regions.empty()) sw << "A";
  if (!quality.empty()) sw << "q" << quality;
  if (maxVolume > 0) sw << "a" << maxVolume;
  tetgencall::run(sw.str(), in, out, "a surface of " + std::to_string(triangles.size()) + " triangles");
  TetMesh mesh;
  mesh.points.reserve(size_t(out.numberofpoints));
  for (int i = 0; i < out.numberofpoints; ++i)
    mesh.points.push_back({out.pointlist[3 * i], out.pointlist[3 * i + 1], out.pointlist[3 * i + 2]});
  int64_t flat = 0;
  for (int t = 0; t < out.numberoftetrahedra; ++t) {
    TetMesh::Tet q;
    for (int c = 0; c < 4; ++c) {
      const int v = out.tetrahedronlist[4 * t + c];
      if (v < 0 || v >= out.numberofpoints) throw ProcessingError("TetGen returned a vertex index out of range");
      q[size_t(c)] = v;
    }
    int label = 1;
    if (!regions.empty()) {
      label = out.numberoftetrahedronattributes > 0 ? int(out.tetrahedronattributelist[t * out.numberoftetrahedronattributes]) : 0;
      if (label == 0) continue; // in no region
    }
    const double vol = signedTetVolume(mesh.points[size_t(q[0])], mesh.points[size_t(q[1])], mesh.points[size_t(q[2])],
                                       mesh.points[size_t(q[3])]);
    if (vol == 0.0) {
      ++flat;
      continue;
    }
    if (vol < 0) std::swap(q[0], q[1]);
    mesh.tets.push_back(q);
    mesh.materials.push_back(label);
  }
  if (stats) {
    stats->inputPoints = int64_t(points.size());
    stats->addedPoints = int64_t(out.numberofpoints) - int64_t(points.size());
    stats->flatDropped = flat;
  }
  return mesh;
}

} // namespace tetflow
