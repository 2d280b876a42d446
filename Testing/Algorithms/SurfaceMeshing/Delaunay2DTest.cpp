// 2D Delaunay triangulation (Algorithms/SurfaceMeshing/Delaunay2D.h): exact predicates against
// big-integer arithmetic, and triangulations of random and degenerate point sets checked against
// independent criteria (orientation, edge manifoldness, convex hull area and boundary, Euler's
// relation, empty circumcircles).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/SurfaceMeshing/Delaunay2D.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {

// ---- Exact reference: signed big integers (a double is an integer times a power of two).

namespace bigint {
struct Big {
  bool neg = false;
  std::vector<uint32_t> mag; // little-endian, no leading zero limbs
};

int compareMag(const std::vector<uint32_t>& a, const std::vector<uint32_t>& b) {
  if (a.size() != b.size()) return a.size() < b.size() ? -1 : 1;
  for (size_t i = a.size(); i-- > 0;)
    if (a[i] != b[i]) return a[i] < b[i] ? -1 : 1;
  return 0;
}

void trim(std::vector<uint32_t>& a) {
  while (!a.empty() && a.back() == 0) a.pop_back();
}

std::vector<uint32_t> addMag(const std::vector<uint32_t>& a, const std::vector<uint32_t>& b) {
  std::vector<uint32_t> r(std::max(a.size(), b.size()) + 1, 0);
  uint64_t carry = 0;
  for (size_t i = 0; i < r.size(); ++i) {
    const uint64_t s = carry + (i < a.size() ? a[i] : 0) + (i < b.size() ? b[i] : 0);
    r[i] = uint32_t(s);
    carry = s >> 32;
  }
  trim(r);
  return r;
}

// a - b for |a| >= |b|.
std::vector<uint32_t> subMag(const std::vector<uint32_t>& a, const std::vector<uint32_t>& b) {
  std::vector<uint32_t> r(a.size(), 0);
  int64_t borrow = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    int64_t s = int64_t(a[i]) - borrow - (i < b.size() ? int64_t(b[i]) : 0);
    borrow = s < 0 ? 1 : 0;
    if (s < 0) s += int64_t(1) << 32;
    r[i] = uint32_t(s);
  }
  trim(r);
  return r;
}

Big operator+(const Big& a, const Big& b) {
  Big r;
  if (a.neg == b.neg) {
    r.mag = addMag(a.mag, b.mag);
    r.neg = a.neg;
  } else if (compareMag(a.mag, b.mag) >= 0) {
    r.mag = subMag(a.mag, b.mag);
    r.neg = a.neg;
  } else {
    r.mag = subMag(b.mag, a.mag);
    r.neg = b.neg;
  }
  if (r.mag.empty()) r.neg = false;
  return r;
}

Big operator-(const Big& a, const Big& b) {
  Big nb = b;
  if (!nb.mag.empty()) nb.neg = !nb.neg;
  return a + nb;
}

Big operator*(const Big& a, const Big& b) {
  Big r;
  if (a.mag.empty() || b.mag.empty()) return r;
  std::vector<uint64_t> acc(a.mag.size() + b.mag.size() + 1, 0);
  for (size_t i = 0; i < a.mag.size(); ++i) {
    uint64_t carry = 0;
    for (size_t j = 0; j < b.mag.size(); ++j) {
      const uint64_t t = uint64_t(a.mag[i]) * b.mag[j] + acc[i + j] + carry;
      acc[i + j] = t & 0xffffffffu;
      carry = t >> 32;
    }
    acc[i + b.mag.size()] += carry;
  }
  r.mag.assign(acc.size(), 0);
  for (size_t i = 0; i < acc.size(); ++i) r.mag[i] = uint32_t(acc[i]);
  trim(r.mag);
  r.neg = a.neg != b.neg;
  return r;
}
} // namespace bigint
using bigint::Big;
using bigint::trim; // the operators stay in bigint (found by ADL), out of other files' way in a unity batch

// The power of two that makes v an integer (v * 2^scaleFor(v) is one).
int scaleFor(double v) {
  int e = 0;
  std::frexp(v, &e);
  return v == 0 ? 0 : 53 - e;
}

// v * 2^k, exactly; v * 2^k must be an integer.
Big exactly(double v, int k) {
  Big r;
  if (v == 0) return r;
  int e = 0;
  const double f = std::frexp(std::fabs(v), &e); // |v| = f 2^e, f in [0.5, 1)
  uint64_t m = uint64_t(std::ldexp(f, 53));
  int shift = e - 53 + k;
  while (shift < 0) { // the low bits are zero
    m >>= 1;
    ++shift;
  }
  r.mag = {uint32_t(m), uint32_t(m >> 32)};
  trim(r.mag);
  const int limbs = shift / 32, bits = shift % 32;
  std::vector<uint32_t> s(size_t(limbs) + r.mag.size() + 1, 0);
  for (size_t i = 0; i < r.mag.size(); ++i) {
    s[i + size_t(limbs)] |= r.mag[i] << bits;
    if (bits > 0) s[i + size_t(limbs) + 1] |= r.mag[i] >> (32 - bits);
  }
  trim(s);
  r.mag = s;
  r.neg = v < 0;
  return r;
}

// The points' coordinates as exact integers (all scaled by the same power of two).
std::vector<std::array<Big, 2>> exactly(std::initializer_list<Point2> pts) {
  int k = 0;
  for (const Point2& p : pts) k = std::max({k, scaleFor(p.x), scaleFor(p.y)});
  std::vector<std::array<Big, 2>> r;
  for (const Point2& p : pts) r.push_back({exactly(p.x, k), exactly(p.y, k)});
  return r;
}

int sign(const Big& a) { return a.mag.empty() ? 0 : (a.neg ? -1 : 1); }
int sign(double v) { return v > 0 ? 1 : (v < 0 ? -1 : 0); }

int exactOrient(const Point2& a, const Point2& b, const Point2& c) {
  const auto p = exactly({a, b, c});
  const Big acx = p[0][0] - p[2][0], acy = p[0][1] - p[2][1];
  const Big bcx = p[1][0] - p[2][0], bcy = p[1][1] - p[2][1];
  return sign(acx * bcy - acy * bcx);
}

int exactInCircle(const Point2& a, const Point2& b, const Point2& c, const Point2& d) {
  const auto p = exactly({a, b, c, d});
  const Big adx = p[0][0] - p[3][0], ady = p[0][1] - p[3][1];
  const Big bdx = p[1][0] - p[3][0], bdy = p[1][1] - p[3][1];
  const Big cdx = p[2][0] - p[3][0], cdy = p[2][1] - p[3][1];
  const Big al = adx * adx + ady * ady, bl = bdx * bdx + bdy * bdy, cl = cdx * cdx + cdy * cdy;
  return sign(al * (bdx * cdy - cdx * bdy) + bl * (cdx * ady - adx * cdy) + cl * (adx * bdy - bdx * ady));
}

double naiveOrient(const Point2& a, const Point2& b, const Point2& c) {
  return (a.x - c.x) * (b.y - c.y) - (a.y - c.y) * (b.x - c.x);
}

double naiveInCircle(const Point2& a, const Point2& b, const Point2& c, const Point2& d) {
  const double adx = a.x - d.x, ady = a.y - d.y, bdx = b.x - d.x, bdy = b.y - d.y;
  const double cdx = c.x - d.x, cdy = c.y - d.y;
  return (adx * adx + ady * ady) * (bdx * cdy - cdx * bdy) + (bdx * bdx + bdy * bdy) * (cdx * ady - adx * cdy) +
         (cdx * cdx + cdy * cdy) * (adx * bdy - bdx * ady);
}

// v moved by k units in the last place.
double ulps(double v, int k) {
  for (; k > 0; --k) v = std::nextafter(v, std::numeric_limits<double>::infinity());
  for (; k < 0; ++k) v = std::nextafter(v, -std::numeric_limits<double>::infinity());
  return v;
}

// ---- Independent checks of a triangulation.

// Strict convex hull (no collinear points), counter-clockwise, by Andrew's monotone chain.
std::vector<Point2> convexHull(std::vector<Point2> p) {
  std::sort(p.begin(), p.end(), [](const Point2& a, const Point2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  p.erase(std::unique(p.begin(), p.end(), [](const Point2& a, const Point2& b) { return a.x == b.x && a.y == b.y; }),
          p.end());
  if (p.size() < 3) return p;
  std::vector<Point2> h(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && orient2D(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (size_t i = p.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && orient2D(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  h.resize(k - 1);
  return h;
}

double polygonArea(const std::vector<Point2>& h) {
  double a = 0;
  for (size_t i = 1; i + 1 < h.size(); ++i) a += naiveOrient(h[0], h[i], h[i + 1]);
  return 0.5 * a;
}

bool onSegment(const Point2& a, const Point2& b, const Point2& p) {
  return orient2D(a, b, p) == 0 && std::min(a.x, b.x) <= p.x && p.x <= std::max(a.x, b.x) &&
         std::min(a.y, b.y) <= p.y && p.y <= std::max(a.y, b.y);
}

enum class Emptiness { AllPoints, LocalEdges };

// Checks that `t` is a Delaunay triangulation of the convex hull of the points not marked in
// `skipped`, using all of them and none of the skipped ones. AllPoints tests every circumcircle
// against every point (small inputs); LocalEdges tests each interior edge against the vertex
// across it (locally Delaunay everywhere implies Delaunay).
void expectDelaunay(const std::vector<Point2>& pts, const Triangulation2D& t, const std::vector<bool>& skipped,
                    Emptiness emptiness) {
  const size_t n = pts.size();
  ASSERT_EQ(skipped.size(), n);
  std::vector<Point2> used;
  for (size_t i = 0; i < n; ++i)
    if (!skipped[i]) used.push_back(pts[i]);
  EXPECT_EQ(t.duplicates, int64_t(n - used.size()));

  // Indices valid, every triangle counter-clockwise, skipped points unused, the others used.
  std::vector<int> degree(n, 0);
  int64_t badIndex = 0, notCcw = 0;
  for (const auto& tri : t.triangles) {
    bool ok = true;
    for (int32_t v : tri) ok = ok && v >= 0 && size_t(v) < n;
    if (!ok) {
      ++badIndex;
      continue;
    }
    for (int32_t v : tri) ++degree[size_t(v)];
    if (orient2D(pts[size_t(tri[0])], pts[size_t(tri[1])], pts[size_t(tri[2])]) <= 0) ++notCcw;
  }
  ASSERT_EQ(badIndex, 0);
  EXPECT_EQ(notCcw, 0);
  int64_t unusedKept = 0, usedSkipped = 0;
  for (size_t i = 0; i < n; ++i) {
    if (skipped[i] && degree[i] > 0) ++usedSkipped;
    if (!skipped[i] && degree[i] == 0) ++unusedKept;
  }
  EXPECT_EQ(usedSkipped, 0);
  EXPECT_EQ(unusedKept, 0);

  // Edges: each directed edge once; an undirected edge in one or two triangles (then in opposite
  // directions); the edges in one triangle are hull edges (every point on their left or on them).
  std::map<std::pair<int32_t, int32_t>, std::pair<int, int32_t>> directed; // -> count, opposite vertex
  for (const auto& tri : t.triangles)
    for (int i = 0; i < 3; ++i) {
      auto& e = directed[{tri[size_t(i)], tri[size_t((i + 1) % 3)]}];
      ++e.first;
      e.second = tri[size_t((i + 2) % 3)];
    }
  int64_t repeated = 0, notHull = 0, notLocallyDelaunay = 0;
  size_t boundaryEdges = 0;
  for (const auto& [e, info] : directed) {
    if (info.first != 1) ++repeated;
    const auto twin = directed.find({e.second, e.first});
    if (twin == directed.end()) {
      ++boundaryEdges;
      for (const Point2& p : used)
        if (orient2D(pts[size_t(e.first)], pts[size_t(e.second)], p) < 0) {
          ++notHull;
          break;
        }
    } else if (emptiness == Emptiness::LocalEdges &&
               inCircle2D(pts[size_t(e.first)], pts[size_t(e.second)], pts[size_t(info.second)],
                          pts[size_t(twin->second.second)]) > 0) {
      ++notLocallyDelaunay;
    }
  }
  EXPECT_EQ(repeated, 0);
  EXPECT_EQ(notHull, 0);
  EXPECT_EQ(notLocallyDelaunay, 0);

  // Covers the convex hull: same area, and Euler's relation T = 2n - 2 - b with b the points on
  // the hull's boundary (collinear ones included); the boundary edges are exactly b.
  const std::vector<Point2> hull = convexHull(used);
  double area = 0;
  for (const auto& tri : t.triangles)
    area += 0.5 * naiveOrient(pts[size_t(tri[0])], pts[size_t(tri[1])], pts[size_t(tri[2])]);
  EXPECT_NEAR(area, polygonArea(hull), 1e-9 * std::fabs(polygonArea(hull)));
  size_t onBoundary = 0;
  for (const Point2& p : used)
    for (size_t i = 0; i < hull.size(); ++i)
      if (onSegment(hull[i], hull[(i + 1) % hull.size()], p)) {
        ++onBoundary;
        break;
      }
  EXPECT_EQ(t.triangles.size(), 2 * used.size() - 2 - onBoundary);
  EXPECT_EQ(boundaryEdges, onBoundary);

  if (emptiness == Emptiness::AllPoints) {
    int64_t inside = 0;
    for (const auto& tri : t.triangles)
      for (size_t i = 0; i < n; ++i)
        if (!skipped[i] && inCircle2D(pts[size_t(tri[0])], pts[size_t(tri[1])], pts[size_t(tri[2])], pts[i]) > 0)
          ++inside;
    EXPECT_EQ(inside, 0);
  }
}

void expectDelaunay(const std::vector<Point2>& pts, const Triangulation2D& t, Emptiness emptiness) {
  expectDelaunay(pts, t, std::vector<bool>(pts.size(), false), emptiness);
}

std::vector<Point2> uniformPoints(size_t n, uint64_t seed, double w = 1, double h = 1) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Point2> p(n);
  for (Point2& q : p) q = {w * u(rng), h * u(rng)};
  return p;
}

} // namespace

// ---- Predicates.

TEST(Delaunay2DPredicates, SignConventions) {
  const Point2 a{0, 0}, b{1, 0}, c{0, 1};
  EXPECT_GT(orient2D(a, b, c), 0);
  EXPECT_LT(orient2D(a, c, b), 0);
  EXPECT_EQ(orient2D(a, b, Point2{3, 0}), 0);
  EXPECT_DOUBLE_EQ(orient2D(a, b, c), 1.0); // twice the area
  EXPECT_GT(inCircle2D(a, b, c, Point2{0.5, 0.5}), 0);
  EXPECT_LT(inCircle2D(a, b, c, Point2{2, 2}), 0);
  EXPECT_EQ(inCircle2D(a, b, c, Point2{1, 1}), 0);   // the square's fourth corner
  EXPECT_LT(inCircle2D(a, c, b, Point2{0.5, 0.5}), 0); // clockwise flips the sign
}

TEST(Delaunay2DPredicates, OrientSignIsExactOnNearlyCollinearPoints) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  std::uniform_int_distribution<int> expo(-40, 4), k(-3, 3);
  int naiveWrong = 0, zeros = 0;
  for (int it = 0; it < 4000; ++it) {
    // a, b of different magnitudes (so differences round), c on or next to the line through them.
    const Point2 a{std::ldexp(u(rng), expo(rng)), std::ldexp(u(rng), expo(rng))};
    const Point2 b{a.x + std::ldexp(u(rng), expo(rng)), a.y + std::ldexp(u(rng), expo(rng))};
    const double s = it % 4 == 0 ? 0.5 : u(rng) * 3;
    Point2 c{a.x + s * (b.x - a.x), a.y + s * (b.y - a.y)};
    if (it % 3 != 0) c = {ulps(c.x, k(rng)), ulps(c.y, k(rng))};
    const int expected = exactOrient(a, b, c);
    ASSERT_EQ(sign(orient2D(a, b, c)), expected) << it;
    ASSERT_EQ(sign(orient2D(b, c, a)), expected) << it;
    ASSERT_EQ(sign(orient2D(b, a, c)), -expected) << it;
    if (sign(naiveOrient(a, b, c)) != expected) ++naiveWrong;
    if (expected == 0) ++zeros;
  }
  // The cases are hard: plain double arithmetic gets many signs wrong, and some are exactly 0.
  EXPECT_GT(naiveWrong, 100);
  EXPECT_GT(zeros, 10);
}

TEST(Delaunay2DPredicates, InCircleSignIsExactOnNearlyCocircularPoints) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1, 1), angle(0, 2 * std::numbers::pi);
  std::uniform_int_distribution<int> expo(-30, 3), k(-4, 4), pick(0, 11);
  // The 12 integer points on the circle x^2 + y^2 = 25.
  const std::vector<Point2> ring{{5, 0}, {4, 3}, {3, 4}, {0, 5}, {-3, 4}, {-4, 3},
                                 {-5, 0}, {-4, -3}, {-3, -4}, {0, -5}, {3, -4}, {4, -3}};
  int naiveWrong = 0, zeros = 0;
  for (int it = 0; it < 3000; ++it) {
    Point2 q[4];
    if (it % 3 == 0) {
      // Exactly cocircular (scaled by a power of two and shifted exactly), then maybe nudged.
      const int e = expo(rng);
      const Point2 shift{std::ldexp(std::round(u(rng) * 64), e), std::ldexp(std::round(u(rng) * 64), e)};
      for (Point2& p : q) {
        const Point2& r = ring[size_t(pick(rng))];
        p = {shift.x + std::ldexp(r.x, e), shift.y + std::ldexp(r.y, e)};
      }
      if (it % 2 == 0) q[3] = {ulps(q[3].x, k(rng)), ulps(q[3].y, k(rng))};
    } else {
      // On a circle up to rounding, centre far from the origin relative to the radius sometimes.
      const Point2 centre{std::ldexp(u(rng), expo(rng)), std::ldexp(u(rng), expo(rng))};
      const double r = std::ldexp(0.5 + 0.5 * std::fabs(u(rng)), expo(rng));
      for (Point2& p : q) {
        const double th = angle(rng);
        p = {centre.x + r * std::cos(th), centre.y + r * std::sin(th)};
      }
      q[3] = {ulps(q[3].x, k(rng)), ulps(q[3].y, k(rng))};
    }
    const int expected = exactInCircle(q[0], q[1], q[2], q[3]);
    ASSERT_EQ(sign(inCircle2D(q[0], q[1], q[2], q[3])), expected) << it;
    ASSERT_EQ(sign(inCircle2D(q[1], q[2], q[0], q[3])), expected) << it;
    ASSERT_EQ(sign(inCircle2D(q[1], q[0], q[2], q[3])), -expected) << it;
    if (sign(naiveInCircle(q[0], q[1], q[2], q[3])) != expected) ++naiveWrong;
    if (expected == 0) ++zeros;
  }
  EXPECT_GT(naiveWrong, 100);
  EXPECT_GT(zeros, 100);
}

// ---- Triangulations.

TEST(Delaunay2D, RandomUniformPointsAreTriangulatedExactly) {
  for (uint64_t seed = 1; seed <= 5; ++seed)
    for (size_t n : {3, 4, 5, 6, 8, 10, 16, 33, 100, 250, 600, 1200, 2000}) {
      SCOPED_TRACE("seed " + std::to_string(seed) + ", n " + std::to_string(n));
      const std::vector<Point2> p = uniformPoints(n, seed);
      const Triangulation2D t = delaunay2D(p);
      EXPECT_EQ(t.duplicates, 0);
      expectDelaunay(p, t, n <= 600 ? Emptiness::AllPoints : Emptiness::LocalEdges);
      // Random points have no collinear hull points: T = 2n - 2 - h exactly.
      EXPECT_EQ(t.triangles.size(), 2 * n - 2 - convexHull(p).size());
      if (HasFailure()) return;
    }
}

TEST(Delaunay2D, ManySmallRandomCases) {
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<size_t> size(3, 14);
  for (int c = 0; c < 600; ++c) {
    SCOPED_TRACE("case " + std::to_string(c));
    const std::vector<Point2> p = uniformPoints(size(rng), rng(), 1 + c % 5, 1 + c % 7);
    expectDelaunay(p, delaunay2D(p), Emptiness::AllPoints);
    if (HasFailure()) return;
  }
}

TEST(Delaunay2D, LargeRandomSetIsLocallyDelaunayEverywhere) {
  const std::vector<Point2> p = uniformPoints(30000, 99, 3.0, 2.0);
  expectDelaunay(p, delaunay2D(p), Emptiness::LocalEdges);
}

TEST(Delaunay2D, LatticePointsFullOfCollinearCocircularAndDuplicatePoints) {
  // Random points of a 7 x 5 lattice: repeats, long collinear runs and cocircular quadruples
  // everywhere, at an exact power-of-two spacing and at a rounded spacing of 0.1.
  std::mt19937_64 rng(5);
  std::uniform_int_distribution<int> ix(0, 6), iy(0, 4);
  std::uniform_int_distribution<size_t> size(3, 60);
  int triangulated = 0, collinear = 0;
  for (int c = 0; c < 800; ++c) {
    SCOPED_TRACE("case " + std::to_string(c));
    const double step = c % 2 == 0 ? 0.25 : 0.1;
    const size_t n = size(rng);
    std::vector<Point2> p(n);
    std::vector<bool> skipped(n, false);
    std::set<std::pair<int, int>> seen;
    for (size_t i = 0; i < n; ++i) {
      const int x = ix(rng), y = iy(rng);
      p[i] = {x * step, 10 + y * step};
      skipped[i] = !seen.insert({x, y}).second;
    }
    std::vector<Point2> distinct;
    for (size_t i = 0; i < n; ++i)
      if (!skipped[i]) distinct.push_back(p[i]);
    if (convexHull(distinct).size() < 3) {
      EXPECT_THROW(delaunay2D(p), InputError);
      ++collinear;
      continue;
    }
    expectDelaunay(p, delaunay2D(p), skipped, Emptiness::AllPoints);
    ++triangulated;
    if (HasFailure()) return;
  }
  EXPECT_GT(triangulated, 700);
  EXPECT_GT(collinear, 0);
}

TEST(Delaunay2D, RegularGridIsSplitIntoHalfCells) {
  // 30 x 30 points: every cell's corners are cocircular. Exact integer grid and a grid at spacing
  // 1/29 (rounded coordinates).
  for (double h : {1.0, 1.0 / 29}) {
    SCOPED_TRACE("spacing " + std::to_string(h));
    std::vector<Point2> p;
    for (int j = 0; j < 30; ++j)
      for (int i = 0; i < 30; ++i) p.push_back({i * h, j * h});
    const Triangulation2D t = delaunay2D(p);
    EXPECT_EQ(t.triangles.size(), size_t(2 * 29 * 29));
    expectDelaunay(p, t, Emptiness::AllPoints);
    double area = 0;
    int64_t notHalfCell = 0;
    for (const auto& tri : t.triangles) {
      const double a = 0.5 * orient2D(p[size_t(tri[0])], p[size_t(tri[1])], p[size_t(tri[2])]);
      area += a;
      if (std::fabs(a - 0.5 * h * h) > 1e-12 * h * h) ++notHalfCell;
    }
    EXPECT_NEAR(area, 29 * h * 29 * h, 1e-12 * 29 * 29 * h * h);
    EXPECT_EQ(notHalfCell, 0);
  }
}

TEST(Delaunay2D, PointsOnACircleAndItsCentreMakeAFan) {
  // Every triangle of three circle points would have the centre inside its circumcircle, so each
  // triangle must use the centre. Points by cos/sin (cocircular up to rounding) and the 12 exactly
  // cocircular integer points of x^2 + y^2 = 25.
  std::vector<std::vector<Point2>> rings(2);
  for (int i = 0; i < 97; ++i) {
    const double th = 2 * std::numbers::pi * i / 97;
    rings[0].push_back({0.3 + 2 * std::cos(th), -0.2 + 2 * std::sin(th)});
  }
  rings[1] = {{5, 0}, {4, 3}, {3, 4}, {0, 5}, {-3, 4}, {-4, 3}, {-5, 0}, {-4, -3}, {-3, -4}, {0, -5}, {3, -4}, {4, -3}};
  const Point2 centres[2] = {{0.3, -0.2}, {0, 0}};
  for (int r = 0; r < 2; ++r) {
    SCOPED_TRACE("ring " + std::to_string(r));
    std::vector<Point2> p = rings[size_t(r)];
    const Triangulation2D ringOnly = delaunay2D(p);
    expectDelaunay(p, ringOnly, Emptiness::AllPoints);
    EXPECT_EQ(ringOnly.triangles.size(), p.size() - 2);
    // The centre inserted in the middle of the input.
    const int32_t centre = int32_t(p.size() / 2);
    p.insert(p.begin() + centre, centres[r]);
    const Triangulation2D t = delaunay2D(p);
    expectDelaunay(p, t, Emptiness::AllPoints);
    EXPECT_EQ(t.triangles.size(), p.size() - 1);
    for (const auto& tri : t.triangles) EXPECT_TRUE(std::count(tri.begin(), tri.end(), centre) == 1);
  }
}

TEST(Delaunay2D, ThinRectangleWithSampledBoundaryAndInteriorPoints) {
  // A parameter-space strip [0, 6.28] x [0, 0.01] (aspect ratio 628:1): its boundary sampled
  // uniformly (long runs of collinear points), with and without random interior points.
  const int nx = 400, ny = 4;
  std::vector<Point2> boundary;
  for (int i = 0; i < nx; ++i) boundary.push_back({6.28 * (double(i) / nx), 0.0});
  for (int j = 0; j < ny; ++j) boundary.push_back({6.28, 0.01 * (double(j) / ny)});
  for (int i = nx; i > 0; --i) boundary.push_back({6.28 * (double(i) / nx), 0.01});
  for (int j = ny; j > 0; --j) boundary.push_back({0.0, 0.01 * (double(j) / ny)});
  for (size_t interior : {size_t(0), size_t(50), size_t(1500)}) {
    SCOPED_TRACE("interior points " + std::to_string(interior));
    std::vector<Point2> p = boundary;
    for (const Point2& q : uniformPoints(interior, 17, 6.28, 0.01))
      if (q.x > 0 && q.x < 6.28 && q.y > 0 && q.y < 0.01) p.push_back(q);
    const Triangulation2D t = delaunay2D(p);
    expectDelaunay(p, t, interior <= 50 ? Emptiness::AllPoints : Emptiness::LocalEdges);
    double area = 0;
    for (const auto& tri : t.triangles) area += 0.5 * naiveOrient(p[size_t(tri[0])], p[size_t(tri[1])], p[size_t(tri[2])]);
    EXPECT_NEAR(area, 6.28 * 0.01, 1e-12);
    // Consecutive boundary samples are joined by an edge; the rectangle's diagonal is not an edge.
    std::vector<std::array<int32_t, 2>> edges;
    for (size_t i = 0; i < boundary.size(); ++i) edges.push_back({int32_t(i), int32_t((i + 1) % boundary.size())});
    const std::vector<bool> found = hasEdges(t, edges);
    EXPECT_EQ(std::count(found.begin(), found.end(), true), std::ptrdiff_t(boundary.size()));
    EXPECT_FALSE(hasEdges(t, {{0, nx + ny}})[0]);
  }
}

TEST(Delaunay2D, DuplicatesAreSkippedCountedAndTheEarlierPointKept) {
  // Box [0, 1]^2 (corners included), so the tolerance is 1e-12.
  std::vector<Point2> p = uniformPoints(200, 23);
  p.push_back({0, 0});
  p.push_back({1, 1});
  p.push_back({0, 1});
  p.push_back({1, 0});
  const size_t originals = p.size();
  std::vector<bool> skipped(originals, false);
  std::mt19937_64 rng(29);
  std::uniform_int_distribution<size_t> pick(0, originals - 1);
  std::uniform_real_distribution<double> dir(-1, 1);
  for (int k = 0; k < 60; ++k) {
    const Point2 q = p[pick(rng)];
    const double d = k % 3 == 0 ? 0.0 : 4e-13; // exact copy or near copy (well within 1e-12)
    p.push_back({q.x + d * dir(rng), q.y + d * dir(rng)});
    skipped.push_back(true);
  }
  // Points just beyond the tolerance are kept.
  p.push_back({0.5, 0.5});
  p.push_back({0.5 + 3e-12, 0.5});
  skipped.push_back(false);
  skipped.push_back(false);
  const Triangulation2D t = delaunay2D(p);
  EXPECT_EQ(t.duplicates, 60);
  expectDelaunay(p, t, skipped, Emptiness::AllPoints);
  // The earlier of two coincident points is the one kept, wherever it is in the input.
  const std::vector<Point2> q{{0.2, 0.2}, {1, 0}, {0.2, 0.2}, {0, 1}, {1, 1}, {0.2, 0.2}};
  const Triangulation2D u = delaunay2D(q);
  EXPECT_EQ(u.duplicates, 2);
  expectDelaunay(q, u, {false, false, true, false, false, true}, Emptiness::AllPoints);
}

TEST(Delaunay2D, CollinearCoincidentOrTooFewPointsThrowInputError) {
  std::vector<Point2> line;
  for (int i = 0; i < 50; ++i) line.push_back({0.25 * i, 1 + 0.5 * i}); // exactly on y = 1 + 2x
  line.push_back(line[7]);
  EXPECT_THROW_MSG(delaunay2D(line), InputError, "delaunay2D", "collinear");
  EXPECT_THROW_MSG(delaunay2D({{0, 0}, {1, 1}}), InputError, "at least 3 points", "got 2");
  EXPECT_THROW_MSG(delaunay2D({}), InputError, "at least 3 points");
  EXPECT_THROW_MSG(delaunay2D({{2, 3}, {2, 3}, {2, 3}, {2, 3}}), InputError, "coincide");
  EXPECT_THROW_MSG(delaunay2D({{0, 0}, {1, 1}, {1e-14, 0}, {1, 1}}), InputError, "3 distinct points", "got 2");
  // One point off the line is enough.
  line.push_back({0.25, 1});
  EXPECT_EQ(delaunay2D(line).triangles.size(), size_t(49));
}

TEST(Delaunay2D, NonFiniteCoordinatesThrowInputError) {
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Point2> p = uniformPoints(10, 1);
  for (const Point2 bad : {Point2{nan, 0.5}, Point2{0.5, inf}, Point2{-inf, 0.0}}) {
    std::vector<Point2> q = p;
    q[4] = bad;
    EXPECT_THROW_MSG(delaunay2D(q), InputError, "point 4", "non-finite");
  }
}

TEST(Delaunay2D, ResultIsInvariantUnderExactScalingAndTranslation) {
  // Points on a 2^-20 lattice, so that scaling by powers of two and shifting by 1024 are exact:
  // the normalised coordinates, and so the triangulation, must be identical.
  std::mt19937_64 rng(31);
  std::uniform_int_distribution<int> c(0, 1 << 20);
  std::vector<Point2> p(3000);
  for (Point2& q : p) q = {std::ldexp(c(rng), -20), std::ldexp(c(rng) / 64, -20)};
  const Triangulation2D base = delaunay2D(p);
  expectDelaunay(p, base, Emptiness::LocalEdges);
  for (int e : {-300, -20, 7, 300}) {
    std::vector<Point2> q = p;
    for (Point2& v : q) v = {std::ldexp(v.x, e), std::ldexp(v.y, e)};
    EXPECT_EQ(delaunay2D(q).triangles, base.triangles) << "scaled by 2^" << e;
  }
  std::vector<Point2> shifted = p;
  for (Point2& v : shifted) v = {v.x + 1024, v.y - 4096};
  EXPECT_EQ(delaunay2D(shifted).triangles, base.triangles);
  // Far from the origin relative to the box (not exactly shiftable): still a Delaunay triangulation.
  std::vector<Point2> far = uniformPoints(500, 37, 1e-3, 1e-3);
  for (Point2& v : far) v = {v.x + 1e6, v.y - 3e7};
  expectDelaunay(far, delaunay2D(far), Emptiness::AllPoints);
}

TEST(Delaunay2D, HasEdgesReportsTriangulationEdgesOnly) {
  // A rhombus: the short diagonal (2-3) is the Delaunay edge, the long one (0-1) is not.
  const std::vector<Point2> p{{0, 0}, {4, 0}, {2, 1}, {2, -1}};
  const Triangulation2D t = delaunay2D(p);
  ASSERT_EQ(t.triangles.size(), size_t(2));
  const std::vector<bool> found = hasEdges(t, {{2, 3}, {3, 2}, {0, 1}, {0, 2}, {2, 1}, {1, 3}, {3, 0}, {0, 0}, {-1, 2}, {0, 9}});
  EXPECT_EQ(found, (std::vector<bool>{true, true, false, true, true, true, true, false, false, false}));
}
