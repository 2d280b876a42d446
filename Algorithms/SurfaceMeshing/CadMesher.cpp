#include "CadMesher.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Progress.h"
#include "Algorithms/Quality/TetQuality.h"
#include "Algorithms/SurfaceMeshing/SurfaceIntersections.h"

namespace tetflow {

namespace {

double seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

double smallestAngle(const Vec3& p, const Vec3& q, const Vec3& r) {
  auto at = [](const Vec3& apex, const Vec3& a, const Vec3& b) {
    const Vec3 u = a - apex, v = b - apex;
    return std::atan2(norm(cross(u, v)), dot(u, v));
  };
  return std::min({at(p, q, r), at(q, r, p), at(r, p, q)}) * 180.0 / M_PI;
}

} // namespace

int64_t smoothCadSurface(const CadModel& model, const CadSample& sample, CadSurfaceMesh& surface, double belowDeg,
                         int passes) {
  const size_t nv = surface.points.size();
  std::vector<std::vector<int32_t>> around(nv); // triangles at each vertex
  for (size_t t = 0; t < surface.triangles.size(); ++t)
    for (int32_t v : surface.triangles[t]) around[size_t(v)].push_back(int32_t(t));
  auto worstAt = [&](int32_t v) {
    double w = 180;
    for (int32_t t : around[size_t(v)]) {
      const auto& q = surface.triangles[size_t(t)];
      w = std::min(w, smallestAngle(surface.points[size_t(q[0])], surface.points[size_t(q[1])], surface.points[size_t(q[2])]));
    }
    return w;
  };
  std::vector<Point2> uv(nv);
  for (size_t v = 0; v < nv && v < sample.particles.size(); ++v) uv[v] = sample.particles[v].uv;
  int64_t moves = 0;
  for (int pass = 0; pass < passes; ++pass) {
    std::vector<int32_t> todo;
    for (const auto& q : surface.triangles)
      if (smallestAngle(surface.points[size_t(q[0])], surface.points[size_t(q[1])], surface.points[size_t(q[2])]) < belowDeg)
        for (int32_t v : q)
          if (size_t(v) < sample.particles.size() && sample.particles[size_t(v)].dim == 2) todo.push_back(v);
    std::sort(todo.begin(), todo.end());
    todo.erase(std::unique(todo.begin(), todo.end()), todo.end());
    int64_t movedNow = 0;
    for (int32_t v : todo) {
      const CadParticle& part = sample.particles[size_t(v)];
      const CadPatch& patch = model.patches()[size_t(part.cell)];
      // The centroid of the ring, reached in the patch's parameters (J⁺ step).
      Vec3 c{0, 0, 0};
      int n = 0;
      for (int32_t t : around[size_t(v)])
        for (int32_t w : surface.triangles[size_t(t)])
          if (w != v) {
            c = c + surface.points[size_t(w)];
            ++n;
          }
      if (n == 0) continue;
      c = (1.0 / n) * c;
      const Vec3 x = surface.points[size_t(v)];
      const PatchPoint pp = model.patchPoint(part.cell, uv[size_t(v)].x, uv[size_t(v)].y);
      const double a = dot(pp.du, pp.du), b = dot(pp.du, pp.dv), cc = dot(pp.dv, pp.dv), det = a * cc - b * b;
      if (!(det > 1e-18 * (a + cc) * (a + cc))) continue;
      const Vec3 d = c - x;
      const double gu = dot(pp.du, d), gv = dot(pp.dv, d);
      const Point2 step{(cc * gu - b * gv) / det, (a * gv - b * gu) / det};
      const double before = worstAt(v);
      for (double f : {1.0, 0.5, 0.25}) {
        const Point2 q{uv[size_t(v)].x + f * step.x, uv[size_t(v)].y + f * step.y};
        if (q.x < patch.u0 || q.x > patch.u1 || q.y < patch.v0 || q.y > patch.v1) continue;
        const Vec3 y = model.patchPoint(part.cell, q.x, q.y).p;
        // The ring's triangles keep facing along the surface normal (the vertex stays inside its
        // ring, so inside the patch) and the worst of their angles rises.
        const Vec3 nrm = model.patchNormal(part.cell, q.x, q.y);
        bool ok = true;
        surface.points[size_t(v)] = y;
        for (int32_t t : around[size_t(v)]) {
          const auto& tri = surface.triangles[size_t(t)];
          const Vec3 tn = cross(surface.points[size_t(tri[1])] - surface.points[size_t(tri[0])],
                                surface.points[size_t(tri[2])] - surface.points[size_t(tri[0])]);
          if (dot(tn, nrm) <= 0.2 * norm(tn)) ok = false;
        }
        if (ok && worstAt(v) > before + 1e-6) {
          uv[size_t(v)] = q;
          ++movedNow;
          break;
        }
        surface.points[size_t(v)] = x;
      }
    }
    moves += movedNow;
    if (movedNow == 0) break;
  }
  return moves;
}

SurfaceFigures surfaceFigures(const std::vector<Vec3>& points, const std::vector<std::array<int32_t, 3>>& triangles) {
  SurfaceFigures f;
  f.triangles = int64_t(triangles.size());
  std::map<std::pair<int, int>, std::pair<int, int>> edges; // undirected -> (uses, forward uses)
  std::vector<char> used(points.size(), 0);
  std::vector<double> minAngles, ratios;
  minAngles.reserve(triangles.size());
  ratios.reserve(triangles.size());
  for (const auto& t : triangles) {
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      used[size_t(a)] = 1;
      auto& e = edges[{std::min(a, b), std::max(a, b)}];
      ++e.first;
      if (a < b) ++e.second;
    }
    const Vec3 &p = points[size_t(t[0])], &q = points[size_t(t[1])], &r = points[size_t(t[2])];
    const double a = norm(q - r), b = norm(p - r), c = norm(p - q);
    auto angle = [](double x, double y, double z) { // opposite x
      const double cs = std::clamp((y * y + z * z - x * x) / (2 * y * z), -1.0, 1.0);
      return std::acos(cs) * 180.0 / M_PI;
    };
    minAngles.push_back(std::min({angle(a, b, c), angle(b, a, c), angle(c, a, b)}));
    const double area2 = norm(cross(q - p, r - p));
    const double R = area2 > 0 ? a * b * c / (2 * area2) : INFINITY;
    ratios.push_back(R / std::min({a, b, c}));
  }
  f.edges = int64_t(edges.size());
  for (const auto& [k, e] : edges) {
    if (e.first == 1) ++f.boundaryEdges;
    else if (e.first > 2) ++f.nonManifoldEdges;
    else if (e.second != 1) ++f.inconsistentEdges;
  }
  for (char u : used) f.vertices += u;
  f.euler = int(f.vertices - f.edges + f.triangles);
  if (!minAngles.empty()) {
    f.minAngle = *std::min_element(minAngles.begin(), minAngles.end());
    f.maxRadiusEdge = *std::max_element(ratios.begin(), ratios.end());
    f.medianMinAngle = median(minAngles);
    f.medianRadiusEdge = median(ratios);
  }
  return f;
}

CadMeshResult meshCadModel(const CadModel& model, const CadMeshParams& params) {
  CadMeshResult r;
  r.modelEuler = model.eulerCharacteristic();
  Progress* progress = currentProgress();
  auto t0 = std::chrono::steady_clock::now();
  if (progress) progress->beginStage("particles");
  CadSample sample = sampleCadModel(model, params.particles, &r.particles);
  r.seconds[0] = seconds(t0);
  t0 = std::chrono::steady_clock::now();
  if (progress) progress->beginStage("triangulate");
  r.surface = triangulateCadSample(model, sample, &r.triangulation);
  r.smoothed = smoothCadSurface(model, sample, r.surface);
  {
    // Only the particles the triangles use (TetGen would insert any other as a vertex), in
    // their order (so the corners stay first).
    std::vector<int32_t> index(r.surface.points.size(), -1);
    for (const auto& t : r.surface.triangles)
      for (int32_t v : t) index[size_t(v)] = 0;
    for (size_t c = 0; c < model.corners().size(); ++c)
      if (index[c] != 0)
        throw ProcessingError("corner " + std::to_string(c) + " of '" + model.source() + "' is in no surface triangle");
    std::vector<Vec3> kept;
    for (size_t i = 0; i < index.size(); ++i)
      if (index[i] == 0) {
        index[i] = int32_t(kept.size());
        kept.push_back(r.surface.points[i]);
      }
    for (auto& t : r.surface.triangles)
      for (auto& v : t) v = index[size_t(v)];
    r.surface.points = std::move(kept);
    r.curvePoints.assign(sample.onCurve.size(), {});
    r.curvePointParameters.assign(r.surface.points.size(), std::nan(""));
    for (size_t c = 0; c < sample.onCurve.size(); ++c)
      for (int i : sample.onCurve[c])
        if (index[size_t(i)] >= 0) {
          r.curvePoints[c].push_back(index[size_t(i)]);
          r.curvePointParameters[size_t(index[size_t(i)])] = sample.particles[size_t(i)].t;
        }
  }
  r.figures = surfaceFigures(r.surface.points, r.surface.triangles);
  r.seconds[1] = seconds(t0);
  const SurfaceFigures& f = r.figures;
  if (f.boundaryEdges || f.nonManifoldEdges || f.inconsistentEdges || f.euler != r.modelEuler) {
    std::ostringstream os;
    os << "the surface mesh of '" << model.source() << "' is not a closed manifold of the model's topology: "
       << f.boundaryEdges << " open edges, " << f.nonManifoldEdges << " non-manifold edges, " << f.inconsistentEdges
       << " inconsistently oriented edges, Euler characteristic " << f.euler << " (the model's: " << r.modelEuler
       << "); try a smaller max_size or s_kappa larger";
    throw ProcessingError(os.str());
  }
  // TetGen crashes on a surface that intersects itself (instead of saying so): check first.
  const auto hits = surfaceIntersections(r.surface.points, r.surface.triangles, 3);
  if (!hits.empty()) {
    const auto& h = hits.front();
    std::ostringstream os;
    os << "the surface mesh of '" << model.source() << "' intersects itself (" << hits.size()
       << (hits.size() >= 3 ? "+" : "") << " pairs of triangles): a triangle of patch "
       << r.surface.trianglePatch[size_t(h.a)] << " and one of patch " << r.surface.trianglePatch[size_t(h.b)]
       << " meet near (" << h.where[0] << ", " << h.where[1] << ", " << h.where[2]
       << ") mm; the sampling is too coarse for a gap there: lower max_size, or raise s_kappa";
    throw ProcessingError(os.str());
  }
  // A seed point inside each solid, for TetGen's regions: beside a triangle of its boundary, on
  // its side. Triangles face out of their patch's first solid, so the solid is behind the
  // triangle when it is that one and in front of it otherwise (the patch it shares with a
  // neighbour). The mesh decides, not the CAD solid: a point between a chord and the curved
  // surface is in the CAD solid but not in its mesh. The largest triangle is taken, the point
  // a twentieth of its shortest edge away (nothing else of the surface is that near it).
  t0 = std::chrono::steady_clock::now();
  if (progress) progress->beginStage("tetgen");
  std::vector<TetgenRegion> regions;
  if (model.solids().size() > 1) {
    for (size_t s = 0; s < model.solids().size(); ++s) {
      double bestArea = 0;
      Vec3 seed{};
      for (size_t t = 0; t < r.surface.triangles.size(); ++t) {
        const auto& sol = model.patches()[size_t(r.surface.trianglePatch[t])].solids;
        if (std::find(sol.begin(), sol.end(), int(s)) == sol.end()) continue;
        const auto& tri = r.surface.triangles[t];
        const Vec3 &a = r.surface.points[size_t(tri[0])], &b = r.surface.points[size_t(tri[1])],
                   &c = r.surface.points[size_t(tri[2])];
        const Vec3 n = cross(b - a, c - a);
        const double area = 0.5 * norm(n);
        if (!(area > bestArea)) continue;
        bestArea = area;
        const double h = 0.05 * std::min({norm(b - a), norm(c - b), norm(a - c)});
        const double side = sol[0] == int(s) ? -1.0 : 1.0;
        seed = (1.0 / 3) * (a + b + c) + (side * h / norm(n)) * n;
      }
      if (!(bestArea > 0))
        throw ProcessingError("solid " + std::to_string(s + 1) + " of '" + model.source() +
                              "' has no surface triangle to seed its region from");
      regions.push_back({seed, int(s) + 1});
    }
  }
  r.mesh = tetgenFromSurface(r.surface.points, r.surface.triangles, regions, params.tetgenQuality,
                             params.maxTetVolume, &r.tetgen);
  r.seconds[2] = seconds(t0);
  if (params.improve) {
    t0 = std::chrono::steady_clock::now();
    ImproveParams ip = params.improveParams;
    ip.fixSurfaces = true;
    NullProgress quiet;
    r.improve = improveMesh(r.mesh, ip, progress ? *progress : quiet);
    r.seconds[3] = seconds(t0);
    r.minDihedral = r.improve.minAfter; // the improvement measured the whole mesh
    r.maxDihedral = r.improve.maxAfter;
  } else {
    r.minDihedral = 180;
    for (size_t t = 0; t < r.mesh.numTets(); ++t) {
      const auto& q = r.mesh.tets[t];
      const auto& P = r.mesh.points;
      r.minDihedral = std::min(r.minDihedral, minDihedral(P[q[0]], P[q[1]], P[q[2]], P[q[3]]));
      r.maxDihedral = std::max(r.maxDihedral, maxDihedral(P[q[0]], P[q[1]], P[q[2]], P[q[3]]));
    }
  }
  return r;
}

} // namespace tetflow
