#include "CadMesher.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Progress.h"

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

} // namespace

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
  // A seed point inside each solid: beside one of its triangles, on the side the classifier
  // calls inside.
  t0 = std::chrono::steady_clock::now();
  if (progress) progress->beginStage("tetgen");
  std::vector<TetgenRegion> regions;
  if (model.solids().size() > 1) {
    for (size_t s = 0; s < model.solids().size(); ++s) {
      bool found = false;
      for (size_t t = 0; t < r.surface.triangles.size() && !found; t += 1 + r.surface.triangles.size() / 50) {
        const int p = r.surface.trianglePatch[t];
        const auto& sol = model.patches()[size_t(p)].solids;
        if (std::find(sol.begin(), sol.end(), int(s)) == sol.end()) continue;
        const auto& tri = r.surface.triangles[t];
        const Vec3 &a = r.surface.points[size_t(tri[0])], &b = r.surface.points[size_t(tri[1])],
                   &c = r.surface.points[size_t(tri[2])];
        const Vec3 n = cross(b - a, c - a);
        const double h = 0.05 * std::min({norm(b - a), norm(c - b), norm(a - c)});
        const Vec3 centre = (1.0 / 3) * (a + b + c);
        for (double sign : {-1.0, 1.0}) {
          const Vec3 q = centre + (sign * h / norm(n)) * n;
          if (model.insideSolid(int(s), q)) {
            regions.push_back({q, int(s) + 1});
            found = true;
            break;
          }
        }
      }
      if (!found)
        throw ProcessingError("no point inside solid " + std::to_string(s + 1) + " of '" + model.source() +
                              "' was found beside its surface triangles");
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
  }
  return r;
}

} // namespace tetflow
