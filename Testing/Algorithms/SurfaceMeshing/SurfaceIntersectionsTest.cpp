// Self-intersection check of triangle surfaces (Algorithms/SurfaceMeshing/SurfaceIntersections.h):
// closed subdivided octahedra (clean, one vertex pushed through, two overlapping or separated,
// duplicated), small configurations at a shared vertex and a shared edge, the pair test on
// constructed crossing and separated pairs, a random triangle soup against the O(n^2) brute force
// of the same pair test, maxReported, and the result on one and two threads.
#include <gtest/gtest.h>

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/SurfaceMeshing/SurfaceIntersections.h"

using namespace tetflow;

namespace {

using Tri = std::array<int32_t, 3>;

struct Surface {
  std::vector<Vec3> points;
  std::vector<Tri> triangles;
};

// An octahedron subdivided `levels` times (each triangle into four at its edge midpoints), its
// points projected onto the sphere of `radius` around `centre`.
Surface octaSphere(int levels, double radius = 1.0, Vec3 centre = {0, 0, 0}) {
  Surface s;
  s.points = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  s.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<int32_t, int32_t>, int32_t> mid;
    auto midpoint = [&](int32_t a, int32_t b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      s.points.push_back(0.5 * (s.points[size_t(a)] + s.points[size_t(b)]));
      const int32_t m = int32_t(s.points.size() - 1);
      mid.emplace(key, m);
      return m;
    };
    std::vector<Tri> next;
    for (const Tri& t : s.triangles) {
      const int32_t ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]), ca = midpoint(t[2], t[0]);
      next.push_back({t[0], ab, ca});
      next.push_back({ab, t[1], bc});
      next.push_back({ca, bc, t[2]});
      next.push_back({ab, bc, ca});
    }
    s.triangles = std::move(next);
  }
  for (Vec3& p : s.points) p = centre + (radius / norm(p)) * p;
  return s;
}

// The two surfaces as one (b's indices shifted).
Surface join(const Surface& a, const Surface& b) {
  Surface s = a;
  const int32_t shift = int32_t(a.points.size());
  s.points.insert(s.points.end(), b.points.begin(), b.points.end());
  for (Tri t : b.triangles) s.triangles.push_back({t[0] + shift, t[1] + shift, t[2] + shift});
  return s;
}

std::vector<SurfaceIntersection> all(const Surface& s) {
  return surfaceIntersections(s.points, s.triangles, std::numeric_limits<size_t>::max());
}

bool inBox(const Surface& s, int32_t t, const Vec3& x) {
  const Tri& tri = s.triangles[size_t(t)];
  for (size_t k = 0; k < 3; ++k) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (int32_t v : tri) {
      lo = std::min(lo, s.points[size_t(v)][k]);
      hi = std::max(hi, s.points[size_t(v)][k]);
    }
    const double slack = 1e-9 * (1 + hi - lo);
    if (x[k] < lo - slack || x[k] > hi + slack) return false;
  }
  return true;
}

int sharedVertices(const Tri& s, const Tri& t) {
  int n = 0;
  for (int32_t a : s)
    for (int32_t b : t) n += a == b;
  return n;
}

// Each reported pair: ordered, sorted, unique, confirmed by the pair test, its point in both boxes.
void expectWellFormed(const Surface& s, const std::vector<SurfaceIntersection>& r) {
  for (size_t k = 0; k < r.size(); ++k) {
    EXPECT_LT(r[k].a, r[k].b);
    if (k > 0) {
      EXPECT_TRUE(std::make_pair(r[k - 1].a, r[k - 1].b) < std::make_pair(r[k].a, r[k].b));
    }
    EXPECT_TRUE(trianglesIntersect(s.points, s.triangles[size_t(r[k].a)], s.triangles[size_t(r[k].b)]));
    EXPECT_TRUE(inBox(s, r[k].a, r[k].where)) << r[k].a << " " << r[k].b;
    EXPECT_TRUE(inBox(s, r[k].b, r[k].where)) << r[k].a << " " << r[k].b;
  }
}

// Two triangles as a surface (points in the given order, triangles {0,1,2} and `second`).
Surface twoTriangles(std::vector<Vec3> points, Tri second) {
  return Surface{std::move(points), {{0, 1, 2}, second}};
}

Vec3 unit(const Vec3& a) { return (1 / norm(a)) * a; }

bool pairHit(const Surface& s) { return trianglesIntersect(s.points, s.triangles[0], s.triangles[1]); }

} // namespace

TEST(SurfaceIntersections, ClosedOctaSphereIsClean) {
  const Surface s = octaSphere(3);
  ASSERT_EQ(s.triangles.size(), 512u);
  EXPECT_TRUE(all(s).empty());
  // Off the origin, larger and smaller: the tolerances are relative.
  EXPECT_TRUE(all(octaSphere(3, 1e4, {3e5, -2e5, 1e5})).empty());
  EXPECT_TRUE(all(octaSphere(3, 1e-4, {3e-1, 0, 0})).empty());
}

TEST(SurfaceIntersections, VertexPushedThroughIsFound) {
  Surface s = octaSphere(3);
  const int32_t v = int32_t(s.points.size() - 1); // a midpoint vertex of the last level: 6 triangles
  s.points[size_t(v)] = -1.5 * s.points[size_t(v)];
  const auto r = all(s);
  ASSERT_FALSE(r.empty());
  expectWellFormed(s, r);
  bool withMoved = false;
  for (const SurfaceIntersection& x : r) {
    const Tri &a = s.triangles[size_t(x.a)], &b = s.triangles[size_t(x.b)];
    withMoved = withMoved || std::count(a.begin(), a.end(), v) || std::count(b.begin(), b.end(), v);
  }
  EXPECT_TRUE(withMoved);
  // A spike crosses the far side of the sphere: some pairs share no vertex.
  EXPECT_TRUE(std::any_of(r.begin(), r.end(), [&](const SurfaceIntersection& x) {
    return sharedVertices(s.triangles[size_t(x.a)], s.triangles[size_t(x.b)]) == 0;
  }));
}

TEST(SurfaceIntersections, TwoSpheres) {
  const Surface a = octaSphere(3);
  const Surface overlapping = join(a, octaSphere(3, 1.0, {0.5, 0, 0}));
  const auto r = all(overlapping);
  ASSERT_FALSE(r.empty());
  expectWellFormed(overlapping, r);
  for (const SurfaceIntersection& x : r) { // only pairs across the two spheres
    EXPECT_LT(x.a, 512);
    EXPECT_GE(x.b, 512);
  }
  // The inscribed polyhedra of two unit spheres 0.01 apart are at least 0.01 apart.
  EXPECT_TRUE(all(join(a, octaSphere(3, 1.0, {2.01, 0, 0}))).empty());
  EXPECT_TRUE(all(join(a, octaSphere(3, 1.0, {1.3, 1.3, 1.3}))).empty());
}

TEST(SurfaceIntersections, CoincidentCopiesAreFound) {
  const Surface a = octaSphere(2);
  const Surface twice = join(a, a);
  const auto r = all(twice);
  expectWellFormed(twice, r);
  const int32_t n = int32_t(a.triangles.size());
  for (int32_t t = 0; t < n; ++t) // every triangle against its copy
    EXPECT_TRUE(std::any_of(r.begin(), r.end(), [&](const SurfaceIntersection& x) { return x.a == t && x.b == t + n; }))
        << t;
  // Also the same triangle listed twice (same indices).
  Surface listedTwice = a;
  listedTwice.triangles.push_back(a.triangles[7]);
  const auto r2 = all(listedTwice);
  ASSERT_EQ(r2.size(), 1u);
  EXPECT_EQ(r2[0].a, 7);
  EXPECT_EQ(r2[0].b, n);
}

TEST(SurfaceIntersections, SharedVertex) {
  const Vec3 v{0, 0, 0}, p1{1, 0, 0}, p2{0, 1, 0};
  // The second triangle passes through the first: a fold through the shared vertex.
  const Surface fold = twoTriangles({v, p1, p2, {0.3, 0.3, 1}, {0.3, 0.3, -1}}, {0, 3, 4});
  EXPECT_TRUE(pairHit(fold));
  const auto r = all(fold);
  ASSERT_EQ(r.size(), 1u);
  expectWellFormed(fold, r);
  EXPECT_GT(norm(r[0].where - v), 0.01); // away from the shared vertex
  EXPECT_NEAR(r[0].where[0], r[0].where[1], 1e-12); // on the crossing line x = y, z = 0
  EXPECT_NEAR(r[0].where[2], 0, 1e-12);
  // Crossing the first triangle's plane outside its corner (behind the vertex): only the vertex.
  EXPECT_FALSE(pairHit(twoTriangles({v, p1, p2, {-0.3, -0.3, 1}, {-0.3, -0.3, -1}}, {0, 3, 4})));
  // Crossing the plane along the corner's edge direction x: they share a segment.
  EXPECT_TRUE(pairHit(twoTriangles({v, p1, p2, {0.5, 0, 1}, {0.5, 0, -1}}, {0, 3, 4})));
  // ... and along -x, just outside it.
  EXPECT_FALSE(pairHit(twoTriangles({v, p1, p2, {-0.5, 0, 1}, {-0.5, 0, -1}}, {0, 3, 4})));
  // Tilted so the crossing direction is 1e-6 rad outside the corner.
  EXPECT_FALSE(pairHit(twoTriangles({v, p1, p2, {1, -1e-6, 1}, {1, -1e-6, -1}}, {0, 3, 4})));
  // Both on one side of each other's plane (a vertex of a convex surface).
  EXPECT_FALSE(pairHit(twoTriangles({v, p1, p2, {-1, 0, -0.2}, {0, -1, -0.2}}, {0, 3, 4})));
  // Coplanar: inside the first corner, in the opposite quadrant, and along its edge.
  EXPECT_TRUE(pairHit(twoTriangles({v, p1, p2, {0.5, 0.2, 0}, {0.2, 0.5, 0}}, {0, 3, 4})));
  EXPECT_FALSE(pairHit(twoTriangles({v, p1, p2, {-1, 0, 0}, {0, -1, 0}}, {0, 3, 4})));
  EXPECT_FALSE(pairHit(twoTriangles({v, p1, p2, {-1, 0.01, 0}, {-0.01, -1, 0}}, {0, 3, 4})));
  EXPECT_TRUE(pairHit(twoTriangles({v, p1, p2, {0, 2, 0}, {-1, 0, 0}}, {0, 3, 4})));
  // Coplanar, only the second corner's second edge inside the first corner (and the first
  // corner's second edge inside the second).
  EXPECT_TRUE(pairHit(twoTriangles({v, p1, p2, {-1, 0.5, 0}, {0.5, 0.5, 0}}, {0, 3, 4})));
  // A corner of 1.5e-10 rad is not its opposite direction (within the angular tolerance of both
  // of its edges, but pointing the other way).
  EXPECT_FALSE(pairHit(twoTriangles({v, p1, {1, 1.5e-10, 0}, {-1, -0.75e-10, 0}, {0, -1, 0}}, {0, 3, 4})));
  // Vertex order and triangle orientation do not matter.
  EXPECT_TRUE(pairHit(twoTriangles({p2, v, p1, {0.3, 0.3, -1}, {0.3, 0.3, 1}}, {4, 1, 3})));
}

TEST(SurfaceIntersections, SharedEdge) {
  const double pi = std::acos(-1.0);
  const Vec3 u{0, 0, 0}, w{1, 0, 0}, p{0.3, 1, 0};
  auto folded = [&](double dihedral, double along) { // q at the given angle from p's half-plane
    return twoTriangles({u, w, p, {along, std::cos(dihedral), std::sin(dihedral)}}, {1, 0, 3});
  };
  EXPECT_FALSE(pairHit(folded(pi / 180, 0.6)));  // 1 degree: nearly folded flat, meets only on the edge
  EXPECT_FALSE(pairHit(folded(-pi / 180, 0.6)));
  EXPECT_FALSE(pairHit(folded(pi / 2, 0.6)));
  EXPECT_FALSE(pairHit(folded(pi, 0.6)));        // flat, on the other side
  EXPECT_TRUE(pairHit(folded(0, 0.6)));          // folded over: overlapping
  EXPECT_TRUE(pairHit(folded(1e-13, 0.6)));      // ~0
  EXPECT_TRUE(pairHit(folded(0, 1.7)));          // overlapping, third vertex beyond the edge's end
  const Surface s = folded(1e-13, -0.4);
  const auto r = all(s);
  ASSERT_EQ(r.size(), 1u);
  expectWellFormed(s, r);
  EXPECT_GT(r[0].where[1], 0.01); // off the shared edge
}

TEST(SurfaceIntersections, PairTestOnConstructedPairs) {
  // Random well-shaped triangles at scales 1e-3..1e3 (off the origin by up to 100 sizes), and
  // second triangles built to cross, touch, overlap or stay 2e-9 of the size away.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1), u01(0, 1);
  auto randomUnit = [&] {
    for (;;) {
      const Vec3 d{u(rng), u(rng), u(rng)};
      if (norm(d) > 0.2 && norm(d) < 1) return (1 / norm(d)) * d;
    }
  };
  auto rotate = [](const Vec3& x, const Vec3& k, double angle) { // about the unit axis k through 0
    return std::cos(angle) * x + std::sin(angle) * cross(k, x) + ((1 - std::cos(angle)) * dot(k, x)) * k;
  };
  int tested = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const double scale = std::pow(10.0, 6 * u01(rng) - 3);
    const Vec3 shift = (100 * scale) * Vec3{u(rng), u(rng), u(rng)};
    std::vector<Vec3> T(3);
    for (Vec3& x : T) x = shift + scale * Vec3{u(rng), u(rng), u(rng)};
    const Vec3 n = cross(T[1] - T[0], T[2] - T[0]);
    const double L = std::max({norm(T[1] - T[0]), norm(T[2] - T[1]), norm(T[0] - T[2])});
    if (norm(n) < 0.2 * L * L) continue; // well-shaped only
    ++tested;
    const Vec3 nu = (1 / norm(n)) * n;
    std::array<double, 3> wt{0.1 + u01(rng), 0.1 + u01(rng), 0.1 + u01(rng)};
    const double sum = wt[0] + wt[1] + wt[2];
    const Vec3 X = (wt[0] / sum) * T[0] + (wt[1] / sum) * T[1] + (wt[2] / sum) * T[2]; // interior
    const Vec3 d = unit(randomUnit() + 2.0 * nu); // at least ~20 degrees off the plane, upwards
    const Vec3 e = unit(randomUnit() + 2.0 * nu);
    auto with = [&](std::vector<Vec3> second) {
      std::vector<Vec3> p = T;
      p.insert(p.end(), second.begin(), second.end());
      return twoTriangles(p, {3, 4, 5});
    };
    const double t1 = 0.1 + u01(rng), t2 = 0.1 + u01(rng);
    // An edge through X.
    EXPECT_TRUE(pairHit(with({X + (t1 * L) * d, X - (t2 * L) * d, X + L * e}))) << trial;
    // A vertex at X, the rest above: touching; lifted by 2e-9 L: apart.
    EXPECT_TRUE(pairHit(with({X, X + (t1 * L) * d, X + L * e}))) << trial;
    const Vec3 lift = (2e-9 * L) * nu;
    EXPECT_FALSE(pairHit(with({X + lift, X + (t1 * L) * d + lift, X + L * e + lift}))) << trial;
    EXPECT_FALSE(pairHit(with({X - lift, X - (t1 * L) * d - lift, X - L * e - lift}))) << trial;
    // A copy of T: coincident; lifted by 2e-9 L: apart; turned about a line in T's plane through X
    // by 1e-7 rad (nearly coplanar): crossing along that line.
    EXPECT_TRUE(pairHit(with({T[0], T[1], T[2]}))) << trial;
    EXPECT_FALSE(pairHit(with({T[0] + lift, T[1] + lift, T[2] + lift}))) << trial;
    const Vec3 axis = unit(cross(nu, randomUnit()));
    EXPECT_TRUE(pairHit(with({X + rotate(T[0] - X, axis, 1e-7), X + rotate(T[1] - X, axis, 1e-7),
                              X + rotate(T[2] - X, axis, 1e-7)})))
        << trial;
    // T mirrored across its edge (T0, T1), tilted about that edge, moved away from T by g in T's
    // plane: apart for g = 2e-9 L, overlapping for g = -2e-9 L when coplanar.
    const Vec3 k = unit(T[1] - T[0]);
    Vec3 m = unit(cross(k, nu));
    if (dot(m, T[2] - T[0]) > 0) m = -1.0 * m;
    const double tilt = u01(rng) < 0.5 ? 0.0 : 0.5 * u(rng);
    const Vec3 mirrored = T[0] + rotate(T[0] + T[1] - T[2] - T[0], k, tilt);
    for (double g : {2e-9, -2e-9}) {
      const Vec3 off = (g * L) * m;
      const bool hit = pairHit(with({T[0] + off, T[1] + off, mirrored + off}));
      if (g > 0) {
        EXPECT_FALSE(hit) << trial << " tilt " << tilt;
      } else if (tilt == 0.0) {
        EXPECT_TRUE(hit) << trial;
      }
    }
  }
  EXPECT_GT(tested, 500);
}

TEST(SurfaceIntersections, RandomSoupMatchesBruteForce) {
  // 200 small triangles in the unit box; some share an edge of an earlier triangle (half of
  // those in its plane, folded over or continuing it), some a vertex.
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> u(-1, 1), u01(0, 1);
  std::uniform_int_distribution<int> corner(0, 2);
  const double h = 0.12;
  Surface s;
  auto add = [&](const Vec3& p) {
    s.points.push_back(p);
    return int32_t(s.points.size() - 1);
  };
  auto around = [&](const Vec3& c) { return add(c + h * Vec3{u(rng), u(rng), u(rng)}); };
  for (int i = 0; i < 200; ++i) {
    const double r = u01(rng);
    if (i >= 10 && r < 0.15) {
      const Tri& t = s.triangles[std::uniform_int_distribution<size_t>(0, s.triangles.size() - 1)(rng)];
      const int c = corner(rng);
      const int32_t a = t[size_t(c)], b = t[size_t((c + 1) % 3)], o = t[size_t((c + 2) % 3)];
      const Vec3 &A = s.points[size_t(a)], &B = s.points[size_t(b)], &O = s.points[size_t(o)];
      const int32_t q = u01(rng) < 0.5 ? add(A + u01(rng) * (B - A) + u(rng) * (O - A)) : around(0.5 * (A + B));
      s.triangles.push_back({b, a, q});
    } else if (i >= 10 && r < 0.35) {
      const int32_t v = std::uniform_int_distribution<int32_t>(0, int32_t(s.points.size() - 1))(rng);
      const Vec3 c = s.points[size_t(v)];
      s.triangles.push_back({v, around(c), around(c)});
    } else {
      const Vec3 c{u01(rng), u01(rng), u01(rng)};
      s.triangles.push_back({around(c), around(c), around(c)});
    }
  }
  std::vector<SurfaceIntersection> brute;
  for (int32_t i = 0; i < 200; ++i)
    for (int32_t j = i + 1; j < 200; ++j) {
      Vec3 w{};
      if (trianglesIntersect(s.points, s.triangles[size_t(i)], s.triangles[size_t(j)], &w)) brute.push_back({i, j, w});
    }
  std::array<int, 4> byShared{};
  for (const SurfaceIntersection& x : brute)
    ++byShared[size_t(sharedVertices(s.triangles[size_t(x.a)], s.triangles[size_t(x.b)]))];
  ASSERT_GE(byShared[0], 10); // the soup exercises every kind of pair
  ASSERT_GE(byShared[1], 3);
  ASSERT_GE(byShared[2], 3);
  const auto r = all(s);
  ASSERT_EQ(r.size(), brute.size());
  for (size_t k = 0; k < r.size(); ++k) {
    EXPECT_EQ(r[k].a, brute[k].a);
    EXPECT_EQ(r[k].b, brute[k].b);
    EXPECT_LT(norm(r[k].where - brute[k].where), 1e-12);
  }
  expectWellFormed(s, r);
}

TEST(SurfaceIntersections, MaxReportedIsRespected) {
  const Surface s = join(octaSphere(3), octaSphere(3, 1.0, {0.5, 0, 0}));
  const auto full = all(s);
  ASSERT_GT(full.size(), 20u);
  EXPECT_EQ(surfaceIntersections(s.points, s.triangles).size(), 10u); // the default
  for (size_t m : {size_t(0), size_t(1), size_t(3), size_t(10), full.size(), full.size() + 5}) {
    const auto r = surfaceIntersections(s.points, s.triangles, m);
    ASSERT_EQ(r.size(), std::min(m, full.size())) << m;
    for (size_t k = 0; k < r.size(); ++k) { // the smallest pairs
      EXPECT_EQ(r[k].a, full[k].a);
      EXPECT_EQ(r[k].b, full[k].b);
    }
  }
}

TEST(SurfaceIntersections, SameResultOnOneAndTwoThreads) {
  // 32768 triangles (two blocks of the search): two separate clean spheres, then two overlapping
  // ones, so the first intersections are found in the second block.
  Surface s = join(join(octaSphere(5), octaSphere(5, 1.0, {3, 0, 0})),
                   join(octaSphere(5, 1.0, {0, 3, 0}), octaSphere(5, 1.0, {0.3, 3.2, 0.1})));
  const int threads = omp_get_max_threads();
  std::vector<std::vector<SurfaceIntersection>> r;
  for (int t : {1, 2}) {
    omp_set_num_threads(t);
    r.push_back(surfaceIntersections(s.points, s.triangles, 7));
    r.push_back(all(s));
  }
  omp_set_num_threads(threads);
  ASSERT_EQ(r[0].size(), 7u);
  EXPECT_GE(r[0][0].a, 16384);
  ASSERT_GT(r[1].size(), 7u);
  for (size_t k : {size_t(0), size_t(1)}) {
    ASSERT_EQ(r[k].size(), r[k + 2].size());
    for (size_t i = 0; i < r[k].size(); ++i) {
      EXPECT_EQ(r[k][i].a, r[k + 2][i].a);
      EXPECT_EQ(r[k][i].b, r[k + 2][i].b);
      EXPECT_EQ(r[k][i].where, r[k + 2][i].where);
    }
  }
  for (size_t i = 0; i < 7; ++i) EXPECT_EQ(r[0][i].b, r[1][i].b);
}

TEST(SurfaceIntersections, InputErrorsAndSkippedTriangles) {
  Surface s = octaSphere(1);
  s.triangles.push_back({0, 0, 1}); // repeated index: skipped
  s.triangles.push_back({2, 3, 3});
  EXPECT_TRUE(all(s).empty());
  Surface bad = s;
  bad.triangles.push_back({0, 1, int32_t(s.points.size())});
  EXPECT_THROW(all(bad), InputError);
  bad = s;
  bad.triangles.push_back({0, 1, -1});
  EXPECT_THROW(all(bad), InputError);
  bad = s;
  bad.points[3][1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(all(bad), InputError);
  EXPECT_TRUE(surfaceIntersections({}, {}).empty());
}
