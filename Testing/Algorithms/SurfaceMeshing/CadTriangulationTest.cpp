// CadTriangulation: parameter-space triangulation of a particle sample of the OpenCASCADE test
// models (Fixtures/CadModels.h). The sample comes from a simple deterministic sampler written here
// (corners; equal arc-length steps on curves; a (u, v) grid on patches), so these tests do not
// depend on the particle system. Each surface must be closed, manifold and consistently oriented,
// have the model's Euler characteristic, enclose the solid's volume, contain every curve as a chain
// of edges, and have its vertices on their patches.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <unordered_map>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/SurfaceMeshing/CadTriangulation.h"
#include "Fixtures/CadModels.h"

using namespace tetflow;
using namespace tetflow::testing;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Points hashed on a grid of cell `cell`, for "is any point within r" queries (r <= cell).
class PointHash {
public:
  explicit PointHash(double cell) : cell_(cell) {}
  void add(const Vec3& p) { cells_[key(cellOf(p[0]), cellOf(p[1]), cellOf(p[2]))].push_back(p); }
  bool anyWithin(const Vec3& p, double r) const {
    const int64_t i = cellOf(p[0]), j = cellOf(p[1]), k = cellOf(p[2]);
    for (int64_t a = i - 1; a <= i + 1; ++a)
      for (int64_t b = j - 1; b <= j + 1; ++b)
        for (int64_t c = k - 1; c <= k + 1; ++c) {
          auto it = cells_.find(key(a, b, c));
          if (it == cells_.end()) continue;
          for (const Vec3& q : it->second)
            if (norm(q - p) < r) return true;
        }
    return false;
  }

private:
  int64_t cellOf(double x) const { return int64_t(std::floor(x / cell_)); }
  static int64_t key(int64_t i, int64_t j, int64_t k) {
    return ((i + (1 << 20)) << 42) | ((j + (1 << 20)) << 21) | (k + (1 << 20));
  }
  double cell_;
  std::unordered_map<int64_t, std::vector<Vec3>> cells_;
};

// The smallest radius of curvature of the model's patches and curves (sampled).
double minCurvatureRadius(const CadModel& m) {
  double kappa = 0;
  for (size_t p = 0; p < m.patches().size(); ++p) {
    const CadPatch& pa = m.patches()[p];
    for (int i = 0; i <= 8; ++i)
      for (int j = 0; j <= 8; ++j)
        kappa = std::max(kappa, m.patchMaxCurvature(int(p), pa.u0 + (pa.u1 - pa.u0) * (0.05 + 0.9 * i / 8.0),
                                                    pa.v0 + (pa.v1 - pa.v0) * (0.05 + 0.9 * j / 8.0)));
  }
  for (size_t c = 0; c < m.curves().size(); ++c) {
    const CadCurve& cv = m.curves()[c];
    for (int i = 0; i <= 16; ++i) kappa = std::max(kappa, m.curveCurvature(int(c), cv.t0 + (cv.t1 - cv.t0) * i / 16.0));
  }
  return kappa > 0 ? 1 / kappa : 1e300;
}

// The deterministic sampler: corners; on each curve, particles at equal arc-length steps of about
// hCurve; on each patch, a (u, v) grid whose 3-D spacing at the patch's centre is about h, kept
// inside the trimmed domain and at least h/2 from every corner and curve particle and from the
// patch's grid points kept before (the last condition thins the grid where the parameterisation
// crowds it, e.g. near a sphere's pole).
CadSample gridSample(const CadModel& m, double h, double hCurve = 0) {
  if (hCurve <= 0) hCurve = h;
  CadSample s;
  s.onCurve.resize(m.curves().size());
  s.onPatch.resize(m.patches().size());
  PointHash boundary(h);
  for (size_t c = 0; c < m.corners().size(); ++c) {
    CadParticle q;
    q.dim = 0;
    q.cell = int(c);
    q.x = m.corners()[c];
    q.sigma = h;
    s.particles.push_back(q);
    boundary.add(q.x);
  }
  for (size_t c = 0; c < m.curves().size(); ++c) {
    const CadCurve& cv = m.curves()[c];
    const int dense = std::max(400, int(50 * cv.length / hCurve));
    std::vector<double> ts(size_t(dense) + 1), arc(size_t(dense) + 1, 0.0);
    Vec3 prev = m.curvePoint(int(c), cv.t0);
    for (int k = 0; k <= dense; ++k) {
      ts[size_t(k)] = cv.t0 + (cv.t1 - cv.t0) * k / double(dense);
      const Vec3 x = m.curvePoint(int(c), ts[size_t(k)]);
      if (k > 0) arc[size_t(k)] = arc[size_t(k) - 1] + norm(x - prev);
      prev = x;
    }
    const double length = arc.back();
    const int segments = std::max(1, int(std::lround(length / hCurve)));
    for (int k = 1; k < segments; ++k) {
      const double target = length * k / segments;
      const size_t i = size_t(std::lower_bound(arc.begin(), arc.end(), target) - arc.begin());
      const double f = (target - arc[i - 1]) / (arc[i] - arc[i - 1]);
      CadParticle q;
      q.dim = 1;
      q.cell = int(c);
      q.t = ts[i - 1] + f * (ts[i] - ts[i - 1]);
      q.x = m.curvePoint(int(c), q.t);
      q.sigma = hCurve;
      s.onCurve[c].push_back(int(s.particles.size()));
      s.particles.push_back(q);
      boundary.add(q.x);
    }
  }
  for (size_t p = 0; p < m.patches().size(); ++p) {
    const CadPatch& pa = m.patches()[p];
    // The trimmed domain: the loops' pcurves as dense polygons.
    std::vector<std::vector<Point2>> polygons;
    for (const auto& loop : pa.loops) {
      std::vector<Point2> poly;
      for (const CadCurveUse& u : loop) {
        const double a = u.reversed ? u.t1 : u.t0, b = u.reversed ? u.t0 : u.t1;
        for (int k = 0; k < 64; ++k) poly.push_back(m.useOnPatch(int(p), u, a + (b - a) * k / 64.0));
      }
      polygons.push_back(std::move(poly));
    }
    auto inside = [&](const Point2& q) {
      bool in = false;
      for (const auto& poly : polygons)
        for (size_t i = 0, n = poly.size(); i < n; ++i) {
          const Point2& a = poly[i];
          const Point2& b = poly[(i + 1) % n];
          if ((a.y > q.y) != (b.y > q.y) && q.x < a.x + (q.y - a.y) * (b.x - a.x) / (b.y - a.y)) in = !in;
        }
      return in;
    };
    const PatchPoint centre = m.patchPoint(int(p), 0.5 * (pa.u0 + pa.u1), 0.5 * (pa.v0 + pa.v1));
    const double su = std::max(norm(centre.du), 1e-9), sv = std::max(norm(centre.dv), 1e-9);
    const int nu = std::clamp(int(std::ceil((pa.u1 - pa.u0) * su / h)), 1, 4000);
    const int nv = std::clamp(int(std::ceil((pa.v1 - pa.v0) * sv / h)), 1, 4000);
    PointHash own(h);
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i) {
        const Point2 uv{pa.u0 + (pa.u1 - pa.u0) * (i + 0.5) / nu, pa.v0 + (pa.v1 - pa.v0) * (j + 0.5) / nv};
        if (!inside(uv)) continue;
        const Vec3 x = m.patchPoint(int(p), uv.x, uv.y).p;
        if (boundary.anyWithin(x, 0.5 * h) || own.anyWithin(x, 0.5 * h)) continue;
        own.add(x);
        CadParticle q;
        q.dim = 2;
        q.cell = int(p);
        q.uv = uv;
        q.x = x;
        q.sigma = h;
        s.onPatch[p].push_back(int(s.particles.size()));
        s.particles.push_back(q);
      }
  }
  return s;
}

double degrees(double radians) { return radians * 180 / kPi; }

struct Figures {
  int64_t vertices = 0, edges = 0, triangles = 0;
  int64_t badEdges = 0;          // undirected edges not in exactly two triangles
  int64_t inconsistentEdges = 0; // directed edges that appear more than once
  int euler = 0;
  double volume = 0;   // signed, mm³
  double minAngle = 180; // degrees
};

Figures figures(const CadSurfaceMesh& mesh) {
  Figures f;
  std::map<std::pair<int, int>, int> directed, undirected;
  std::vector<char> used(mesh.points.size(), 0);
  for (const auto& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const int a = t[size_t(k)], b = t[size_t((k + 1) % 3)];
      ++directed[{a, b}];
      ++undirected[{std::min(a, b), std::max(a, b)}];
      used[size_t(a)] = 1;
    }
    const Vec3 &a = mesh.points[size_t(t[0])], &b = mesh.points[size_t(t[1])], &c = mesh.points[size_t(t[2])];
    f.volume += dot(a, cross(b, c)) / 6;
    const Vec3 e[3] = {b - a, c - b, a - c};
    for (int k = 0; k < 3; ++k) {
      const Vec3 u = e[k], v = -1.0 * e[(k + 2) % 3];
      const double cosine = dot(u, v) / (norm(u) * norm(v));
      f.minAngle = std::min(f.minAngle, degrees(std::acos(std::clamp(cosine, -1.0, 1.0))));
    }
  }
  for (const auto& [e, n] : directed)
    if (n != 1) ++f.inconsistentEdges;
  for (const auto& [e, n] : undirected)
    if (n != 2) ++f.badEdges;
  f.vertices = std::count(used.begin(), used.end(), 1);
  f.edges = int64_t(undirected.size());
  f.triangles = int64_t(mesh.triangles.size());
  f.euler = int(f.vertices - f.edges + f.triangles);
  return f;
}

bool hasEdge(const std::map<std::pair<int, int>, int>& edges, int a, int b) {
  return edges.count({std::min(a, b), std::max(a, b)}) > 0;
}

// Triangulates a sample of every test model and checks the surface. `fine`: h = 0.8 capped at 0.3
// times the model's smallest radius of curvature (so the volume check means something for the thin
// coil), with the 3 % volume check; otherwise h as given with only a sign check.
void checkAllModels(double h, bool fine) {
  for (const auto& tm : testModels()) {
    SCOPED_TRACE(tm.name + " h=" + std::to_string(h));
    auto m = modelOf(tm.make(), tm.name);
    const double spacing = fine ? std::min(h, 0.3 * minCurvatureRadius(*m)) : h;
    CadSample sample = gridSample(*m, spacing);
    CadTriangulationStats stats;
    const CadSurfaceMesh mesh = triangulateCadSample(*m, sample, &stats);
    const Figures f = figures(mesh);
    const double solid = m->solids()[0].volume;
    std::printf("[ %-21s h=%.2f spacing=%.3f ] %lld triangles, min angle %.2f°, volume %+.3f %%, rounds %d, "
                "splits %lld, encroaching %lld, flips %lld, pole triangles %lld\n",
                tm.name.c_str(), h, spacing, (long long)f.triangles, f.minAngle, 100 * (f.volume - solid) / solid,
                stats.rounds, (long long)stats.curveSplits, (long long)stats.encroachingRemoved,
                (long long)stats.flips, (long long)stats.degenerateDropped);
    ASSERT_EQ(mesh.points.size(), sample.particles.size());
    ASSERT_EQ(mesh.trianglePatch.size(), mesh.triangles.size());
    EXPECT_GT(f.triangles, 0);
    EXPECT_EQ(f.badEdges, 0) << "edges not in exactly two triangles";
    EXPECT_EQ(f.inconsistentEdges, 0) << "directed edges used twice (inconsistent orientation)";
    EXPECT_EQ(f.euler, m->eulerCharacteristic());
    EXPECT_EQ(f.euler, tm.euler);
    EXPECT_GT(f.volume, 0);
    if (fine) {
      EXPECT_NEAR(f.volume, solid, 0.03 * solid);
    }
    // Every curve is a chain of edges: corner0, its particles (sorted by t), corner1.
    std::map<std::pair<int, int>, int> edges;
    for (const auto& t : mesh.triangles)
      for (int k = 0; k < 3; ++k) {
        const int a = t[size_t(k)], b = t[size_t((k + 1) % 3)];
        ++edges[{std::min(a, b), std::max(a, b)}];
      }
    for (size_t c = 0; c < m->curves().size(); ++c) {
      std::vector<int> chain{m->curves()[c].corner0};
      chain.insert(chain.end(), sample.onCurve[c].begin(), sample.onCurve[c].end());
      chain.push_back(m->curves()[c].corner1);
      for (size_t i = 0; i + 1 < chain.size(); ++i) {
        EXPECT_TRUE(hasEdge(edges, chain[i], chain[i + 1])) << "curve " << c << " link " << i;
        if (i > 0 && i + 2 < chain.size()) {
          EXPECT_LT(sample.particles[size_t(chain[i])].t, sample.particles[size_t(chain[i + 1])].t);
        }
      }
    }
    // A few vertices of each patch's triangles lie on the patch.
    std::vector<int> seen(m->patches().size(), 0);
    for (size_t t = 0; t < mesh.triangles.size(); t += 7) {
      const int p = mesh.trianglePatch[t];
      if (seen[size_t(p)]++ >= 4) continue;
      for (int v : mesh.triangles[t]) EXPECT_LT(m->distanceToPatch(p, mesh.points[size_t(v)]), 1e-6) << "patch " << p;
    }
  }
}

} // namespace

TEST(CadTriangulation, CoarseSamplesGiveClosedSurfacesOfTheModelsTopology) { checkAllModels(1.5, false); }

TEST(CadTriangulation, FineSamplesGiveClosedSurfacesEnclosingTheSolidsVolume) { checkAllModels(0.8, true); }

TEST(CadTriangulation, ReportsTheMinimumTriangleAngle) {
  // No threshold: the grid sampler is crude (its grid is square in (u, v), not in 3-D).
  for (const auto& tm : testModels()) {
    auto m = modelOf(tm.make(), tm.name);
    CadSample sample = gridSample(*m, 0.8);
    CadTriangulationStats stats;
    const Figures f = figures(triangulateCadSample(*m, sample, &stats));
    std::printf("[ %-21s h=0.80 ] minimum triangle angle %.2f° over %lld triangles (%lld flips)\n",
                tm.name.c_str(), f.minAngle, (long long)f.triangles, (long long)stats.flips);
    EXPECT_GT(f.minAngle, 0);
  }
}

TEST(CadTriangulation, CoarseCurvesAreSplitUntilTheirSegmentsAreDelaunayEdges) {
  // A 30 x 20 x 5 block with two 6 x 6 square holes 0.1 mm apart, the second 1 mm higher in y
  // (genus 2). On the top and bottom faces a 2 mm segment of one hole's side has the other hole's
  // particle 0.1 mm from its middle, and no circle through its ends is empty: the hole's own
  // particles bound the circle on the other side. It is not a Delaunay edge until split.
  TopoDS_Shape block = BRepPrimAPI_MakeBox(30, 20, 5).Shape();
  block = BRepAlgoAPI_Cut(block, BRepPrimAPI_MakeBox(gp_Pnt(4, 7, -1), 6, 6, 7).Shape()).Shape();
  block = BRepAlgoAPI_Cut(block, BRepPrimAPI_MakeBox(gp_Pnt(10.1, 8, -1), 6, 6, 7).Shape()).Shape();
  auto m = modelOf(unify(block), "two_close_holes");
  ASSERT_EQ(m->eulerCharacteristic(), -2);
  CadSample sample = gridSample(*m, 1.5, 2.0);
  const size_t before = sample.particles.size();
  CadTriangulationStats stats;
  const CadSurfaceMesh mesh = triangulateCadSample(*m, sample, &stats);
  const Figures f = figures(mesh);
  std::printf("[ two_close_holes h=1.5, curves 2 ] %lld triangles, %d rounds, %lld splits, %lld encroaching\n",
              (long long)f.triangles, stats.rounds, (long long)stats.curveSplits, (long long)stats.encroachingRemoved);
  EXPECT_GT(stats.curveSplits, 0);
  EXPECT_GT(stats.rounds, 1);
  EXPECT_EQ(sample.particles.size(), before + size_t(stats.curveSplits));
  EXPECT_EQ(f.badEdges, 0);
  EXPECT_EQ(f.inconsistentEdges, 0);
  EXPECT_EQ(f.euler, m->eulerCharacteristic());
  for (size_t c = 0; c < m->curves().size(); ++c) {
    const auto& chain = sample.onCurve[c];
    for (size_t i = 0; i + 1 < chain.size(); ++i)
      EXPECT_LT(sample.particles[size_t(chain[i])].t, sample.particles[size_t(chain[i + 1])].t);
    for (int id : chain) {
      const CadParticle& q = sample.particles[size_t(id)];
      EXPECT_EQ(q.dim, 1);
      EXPECT_EQ(q.cell, int(c));
      EXPECT_LT(norm(q.x - m->curvePoint(int(c), q.t)), 1e-12);
    }
  }
}

TEST(CadTriangulation, PatchParticlesEncroachingUponACurveSegmentAreRemoved) {
  auto m = modelOf(boxWithHole(), "box_with_hole");
  CadSample sample = gridSample(*m, 1.5);
  // A particle just inside patch 0, next to the middle of its first boundary segment (from the
  // start corner of the loop's first use to the curve's next particle). A forward face lies to the
  // left of its loops in (u, v).
  const int p = 0;
  const CadCurveUse& use = m->patches()[p].loops[0][0];
  ASSERT_GE(use.curve, 0);
  const auto& chain = sample.onCurve[size_t(use.curve)];
  ASSERT_GE(chain.size(), 1u);
  const double tStart = use.reversed ? m->curves()[size_t(use.curve)].t1 : m->curves()[size_t(use.curve)].t0;
  const double tNext = sample.particles[size_t(use.reversed ? chain.back() : chain.front())].t;
  const Point2 a = m->useOnPatch(p, use, tStart), b = m->useOnPatch(p, use, tNext);
  const Point2 mid = m->useOnPatch(p, use, 0.5 * (tStart + tNext));
  const double inward = 0.05; // of the segment's length in (u, v)
  CadParticle q;
  q.dim = 2;
  q.cell = p;
  q.uv = {mid.x - inward * (b.y - a.y), mid.y + inward * (b.x - a.x)};
  q.x = m->patchPoint(p, q.uv.x, q.uv.y).p;
  q.sigma = 1.5;
  const int id = int(sample.particles.size());
  sample.particles.push_back(q);
  sample.onPatch[p].push_back(id);
  CadTriangulationStats stats;
  const CadSurfaceMesh mesh = triangulateCadSample(*m, sample, &stats);
  EXPECT_GE(stats.encroachingRemoved, 1);
  EXPECT_EQ(std::count(sample.onPatch[p].begin(), sample.onPatch[p].end(), id), 0);
  EXPECT_EQ(mesh.points.size(), sample.particles.size()); // still a particle, used by no triangle
  for (const auto& t : mesh.triangles) EXPECT_EQ(std::count(t.begin(), t.end(), id), 0);
  EXPECT_EQ(figures(mesh).badEdges, 0);
}

TEST(CadTriangulation, DuplicateBoundaryParticlesAreAnErrorNamingThePatch) {
  auto m = modelOf(torus(), "torus");
  CadSample sample = gridSample(*m, 1.5);
  // Two particles at the same place on curve 0.
  auto& chain = sample.onCurve[0];
  ASSERT_GE(chain.size(), 2u);
  CadParticle copy = sample.particles[size_t(chain[1])];
  sample.particles.push_back(copy);
  chain.insert(chain.begin() + 2, int(sample.particles.size()) - 1);
  try {
    triangulateCadSample(*m, sample);
    FAIL() << "no error";
  } catch (const ProcessingError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("patch 0"), std::string::npos) << msg;
    EXPECT_NE(msg.find("torus"), std::string::npos) << msg;
    EXPECT_NE(msg.find("coincide"), std::string::npos) << msg;
  }
}

TEST(CadTriangulation, ClosedCurvesWithTooFewParticlesAreSplitFirst) {
  // Without particles a closed curve's chain would join its corner to itself; with one, it would
  // join the same two particles twice.
  auto m = modelOf(boxWithHole(), "box_with_hole");
  CadSample sample = gridSample(*m, 1.5);
  std::vector<int> closed;
  for (size_t c = 0; c < m->curves().size(); ++c)
    if (m->curves()[c].corner0 == m->curves()[c].corner1) closed.push_back(int(c));
  ASSERT_EQ(closed.size(), 2u); // the hole's two circles
  sample.onCurve[size_t(closed[0])].clear();
  sample.onCurve[size_t(closed[1])].resize(1);
  CadTriangulationStats stats;
  const Figures f = figures(triangulateCadSample(*m, sample, &stats));
  EXPECT_GE(stats.curveSplits, 3);
  for (int c : closed) EXPECT_GE(sample.onCurve[size_t(c)].size(), 2u);
  EXPECT_EQ(f.badEdges, 0);
  EXPECT_EQ(f.inconsistentEdges, 0);
  EXPECT_EQ(f.euler, m->eulerCharacteristic());
}

TEST(CadTriangulation, DenseCurvesAtAPoleStillGiveAClosedSurface) {
  // Curve particles closer than the patch's: in the scaled parameters the pole's points then sit
  // next to the seam's last particles, and the Delaunay triangles between them are slivers along
  // the seam in 3-D; flips through the pole remove them.
  auto m = modelOf(cylinderWithCap(), "cylinder_with_cap");
  CadSample sample = gridSample(*m, 0.35, 0.21);
  CadTriangulationStats stats;
  const Figures f = figures(triangulateCadSample(*m, sample, &stats));
  std::printf("[ cylinder_with_cap h=0.35, curves 0.21 ] %lld triangles, min angle %.2f°, %lld flips, %lld pole "
              "triangles\n",
              (long long)f.triangles, f.minAngle, (long long)stats.flips, (long long)stats.degenerateDropped);
  EXPECT_GT(stats.degenerateDropped, 0);
  EXPECT_EQ(f.badEdges, 0);
  EXPECT_EQ(f.inconsistentEdges, 0);
  EXPECT_EQ(f.euler, m->eulerCharacteristic());
  EXPECT_GT(f.volume, 0);
}

TEST(CadTriangulation, SamplesTooCoarseForAThinTubeAreAnErrorNamingThePatch) {
  // Spacing 4 mm on a tube of radius 1 mm: triangles span the tube from one side of its seam to
  // the other.
  auto m = modelOf(helicalSweep(), "helical_sweep");
  CadSample sample = gridSample(*m, 4.0);
  try {
    triangulateCadSample(*m, sample);
    FAIL() << "no error";
  } catch (const ProcessingError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("helical_sweep': patch "), std::string::npos) << msg;
    EXPECT_NE(msg.find("too coarse"), std::string::npos) << msg;
  }
}
