#include "SurfaceIntersections.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

#include "Algorithms/Core/Errors.h"

namespace tetflow {

namespace {

using Tri = std::array<int32_t, 3>;

// Relative tolerance: of the smaller triangle's longest edge for distances, in radians for the
// directions of two corners at a shared vertex (see the header).
constexpr double kRelTol = 1e-10;
// A corner whose edges' unit directions have a cross product shorter than this is flat (its
// triangle has zero area): a ray, or a line through the vertex.
constexpr double kFlat = 1e-10;
// Triangles with |normal| below this times L^2 get no plane-side shortcut (their normal is too
// inaccurate to separate by); the full distance computation decides for them.
constexpr double kShortcutArea = 1e-4;
// Blocks of triangles processed between checks of maxReported.
constexpr int64_t kBlock = 1 << 14;
// Cells per triangle (on average) at most, and cells per axis at most (21 bits each in a key).
constexpr double kCellsPerTriangle = 16;
constexpr int64_t kMaxAxisCells = (int64_t(1) << 21) - 2;

struct Box {
  Vec3 lo{}, hi{};
};

double norm2(const Vec3& a) { return dot(a, a); }

Vec3 unit(const Vec3& a) {
  const double l = norm(a);
  return l > 0 ? (1.0 / l) * a : Vec3{0, 0, 0};
}

double longestEdge(const Vec3& a, const Vec3& b, const Vec3& c) {
  return std::max({norm(b - a), norm(c - b), norm(a - c)});
}

bool repeatsIndex(const Tri& t) { return t[0] == t[1] || t[1] == t[2] || t[0] == t[2]; }

// The triangle's bounding box grown by kRelTol times its longest edge: two triangles closer than
// the tolerance have overlapping padded boxes.
Box paddedBox(const std::vector<Vec3>& p, const Tri& t) {
  const Vec3 &a = p[size_t(t[0])], &b = p[size_t(t[1])], &c = p[size_t(t[2])];
  const double pad = kRelTol * longestEdge(a, b, c);
  Box x;
  for (size_t k = 0; k < 3; ++k) {
    x.lo[k] = std::min({a[k], b[k], c[k]}) - pad;
    x.hi[k] = std::max({a[k], b[k], c[k]}) + pad;
  }
  return x;
}

bool overlap(const Box& x, const Box& y) {
  for (size_t k = 0; k < 3; ++k)
    if (x.lo[k] > y.hi[k] || y.lo[k] > x.hi[k]) return false;
  return true;
}

// ---- Distances between points, segments and triangles. Every closest point returned lies on its
// segment or triangle (up to rounding), so a computed distance never undercuts the true one by
// more than rounding: a gap is never mistaken for a contact.

Vec3 closestOnSegment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 d = b - a;
  const double dd = dot(d, d);
  if (!(dd > 0)) return a;
  return a + std::clamp(dot(p - a, d) / dd, 0.0, 1.0) * d;
}

// Closest point to p on triangle (a, b, c); flat triangles reduce to their edges.
Vec3 closestOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a, e2 = c - a, n = cross(e1, e2);
  const double nn = dot(n, n);
  if (nn > 0) { // barycentric coordinates of p's projection onto the plane
    const Vec3 w = p - a;
    const double u = dot(cross(w, e2), n) / nn, v = dot(cross(e1, w), n) / nn;
    if (u >= 0 && v >= 0 && u + v <= 1) return a + u * e1 + v * e2;
  }
  const Vec3 x = closestOnSegment(p, a, b), y = closestOnSegment(p, b, c), z = closestOnSegment(p, c, a);
  const double dx = norm2(p - x), dy = norm2(p - y), dz = norm2(p - z);
  if (dx <= dy && dx <= dz) return x;
  return dy <= dz ? y : z;
}

// The closest pair found so far: x on the first object, y on the second.
struct Closest {
  double d2 = std::numeric_limits<double>::infinity();
  Vec3 x{}, y{};
  void consider(const Vec3& px, const Vec3& py) {
    const double d = norm2(px - py);
    if (d < d2) {
      d2 = d;
      x = px;
      y = py;
    }
  }
};

// Closest points of segments [p0, p1] and [q0, q1]: the interior critical point of the squared
// distance if it is interior, else the best of the four endpoint-to-segment distances.
void segmentSegment(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1, Closest& best) {
  const Vec3 d = p1 - p0, e = q1 - q0, r = p0 - q0;
  const double a = dot(d, d), b = dot(d, e), c = dot(e, e), f = dot(d, r), g = dot(e, r);
  const double den = norm2(cross(d, e)); // = a c - b^2, without the cancellation
  if (den > kFlat * kFlat * a * c) {
    const double s = (b * g - c * f) / den, t = (a * g - b * f) / den;
    if (s >= 0 && s <= 1 && t >= 0 && t <= 1) best.consider(p0 + s * d, q0 + t * e);
  }
  best.consider(p0, closestOnSegment(p0, q0, q1));
  best.consider(p1, closestOnSegment(p1, q0, q1));
  best.consider(closestOnSegment(q0, p0, p1), q0);
  best.consider(closestOnSegment(q1, p0, p1), q1);
}

// Closest points of segment [p, q] (x) and triangle (a, b, c) (y). A segment crossing the plane
// meets it at a point whose distance to the triangle is 0 when it crosses the triangle; otherwise
// the closest pair involves an endpoint or an edge of the triangle.
void segmentTriangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c, Closest& best) {
  const Vec3 n = cross(b - a, c - a);
  const double dp = dot(n, p - a), dq = dot(n, q - a);
  if ((dp < 0 && dq > 0) || (dp > 0 && dq < 0)) {
    const Vec3 x = p + (dp / (dp - dq)) * (q - p);
    best.consider(x, closestOnTriangle(x, a, b, c));
  }
  best.consider(p, closestOnTriangle(p, a, b, c));
  best.consider(q, closestOnTriangle(q, a, b, c));
  segmentSegment(p, q, a, b, best);
  segmentSegment(p, q, b, c, best);
  segmentSegment(p, q, c, a, best);
}

// Whether triangle B lies wholly more than tol to one side of triangle A's plane.
bool separatedByPlane(const std::array<Vec3, 3>& A, const std::array<Vec3, 3>& B, double tol) {
  const Vec3 n = cross(A[1] - A[0], A[2] - A[0]);
  const double nl = norm(n), L = longestEdge(A[0], A[1], A[2]);
  if (!(nl > kShortcutArea * L * L)) return false;
  int above = 0, below = 0;
  for (const Vec3& b : B) {
    const double h = dot(n, b - A[0]) / nl;
    above += h > tol;
    below += h < -tol;
  }
  return above == 3 || below == 3;
}

// Triangles A and B without a shared vertex: whether they are within tol of each other. Their
// distance is that of an edge of one to the other triangle (the closest pair of two disjoint
// triangles has a point on a triangle's boundary; intersecting triangles have an edge of one
// meeting the other).
bool nearEachOther(const std::array<Vec3, 3>& A, const std::array<Vec3, 3>& B, double tol, Vec3& where) {
  if (separatedByPlane(A, B, tol) || separatedByPlane(B, A, tol)) return false;
  Closest best;
  for (size_t k = 0; k < 3; ++k) {
    segmentTriangle(A[k], A[(k + 1) % 3], B[0], B[1], B[2], best);
    segmentTriangle(B[k], B[(k + 1) % 3], A[0], A[1], A[2], best);
  }
  if (!(best.d2 <= tol * tol)) return false;
  where = 0.5 * (best.x + best.y);
  return true;
}

// ---- One shared vertex.

// Whether unit direction x lies in the convex corner spanned by unit directions u and w (angle
// below pi), n being the unit normal of the corner's orientation (n ~ u x w), with kRelTol radians
// to spare. x is (nearly) in the corner's plane. The last condition tells x from -x when the
// corner is thin.
bool inCorner(const Vec3& u, const Vec3& w, const Vec3& n, const Vec3& x) {
  return dot(cross(u, x), n) >= -kRelTol && dot(cross(x, w), n) >= -kRelTol && std::max(dot(x, u), dot(x, w)) > 0;
}

// Corners (a1, a2) and (b1, b2) at a shared vertex (the origin), given by their edge vectors:
// whether they share a direction (then the triangles share a segment from the vertex, as their
// intersection is convex); `dir` gets it. Scale-free: the test sees only unit directions.
bool cornersOverlap(Vec3 a1, Vec3 a2, Vec3 b1, Vec3 b2, Vec3& dir) {
  a1 = unit(a1);
  a2 = unit(a2);
  b1 = unit(b1);
  b2 = unit(b2);
  const Vec3 m1 = cross(a1, a2), m2 = cross(b1, b2);
  const double s1 = norm(m1), s2 = norm(m2);
  const bool flat1 = s1 <= kFlat, flat2 = s2 <= kFlat;
  if (flat1 && flat2) { // two rays or lines: a common ray
    for (const Vec3& x : {a1, a2})
      for (const Vec3& y : {b1, b2})
        if (norm2(x) > 0 && norm(x - y) <= kRelTol) {
          dir = x;
          return true;
        }
    return false;
  }
  if (flat1 || flat2) { // the flat corner's rays against the other corner
    const Vec3 &u = flat1 ? b1 : a1, &w = flat1 ? b2 : a2;
    const Vec3 n = flat1 ? (1.0 / s2) * m2 : (1.0 / s1) * m1;
    for (const Vec3& x : flat1 ? std::array<Vec3, 2>{a1, a2} : std::array<Vec3, 2>{b1, b2})
      if (std::abs(dot(x, n)) <= kRelTol && inCorner(u, w, n, x)) {
        dir = x;
        return true;
      }
    return false;
  }
  const Vec3 n1 = (1.0 / s1) * m1, n2 = (1.0 / s2) * m2;
  const double hb1 = dot(b1, n1), hb2 = dot(b2, n1), ha1 = dot(a1, n2), ha2 = dot(a2, n2);
  auto oneSide = [](double h1, double h2) {
    return (h1 > kRelTol && h2 > kRelTol) || (h1 < -kRelTol && h2 < -kRelTol);
  };
  if (oneSide(hb1, hb2) || oneSide(ha1, ha2)) return false; // one corner touches the other's plane only at the vertex
  const bool bInPlane1 = std::abs(hb1) <= kRelTol && std::abs(hb2) <= kRelTol;
  const bool aInPlane2 = std::abs(ha1) <= kRelTol && std::abs(ha2) <= kRelTol;
  if (bInPlane1 || aInPlane2) { // coplanar corners: two angular intervals overlap iff one holds an end of the other
    const Vec3 n = bInPlane1 ? n1 : n2;
    const Vec3 na = dot(m1, n) >= 0 ? n : -1.0 * n, nb = dot(m2, n) >= 0 ? n : -1.0 * n;
    for (const Vec3& x : {b1, b2})
      if (inCorner(a1, a2, na, x)) {
        dir = x;
        return true;
      }
    for (const Vec3& x : {a1, a2})
      if (inCorner(b1, b2, nb, x)) {
        dir = x;
        return true;
      }
    return false;
  }
  // Crossing planes: each corner meets the other's plane along one ray, which must lie in the
  // other corner (either test decides; both are made, to be symmetric under rounding).
  auto crossing = [](const Vec3& x1, const Vec3& x2, double h1, double h2) {
    if (std::abs(h1) <= kRelTol) return x1;
    if (std::abs(h2) <= kRelTol) return x2;
    return unit(std::abs(h2) * x1 + std::abs(h1) * x2);
  };
  const Vec3 r2 = crossing(b1, b2, hb1, hb2);
  if (inCorner(a1, a2, n1, r2)) {
    dir = r2;
    return true;
  }
  const Vec3 r1 = crossing(a1, a2, ha1, ha2);
  if (inCorner(b1, b2, n2, r1)) {
    dir = r1;
    return true;
  }
  return false;
}

// How far from the vertex (the origin) a direction in the corner (x1, x2) surely stays in the
// triangle: the height over the opposite edge; for a flat triangle, its shorter edge at the vertex.
double reach(const Vec3& x1, const Vec3& x2) {
  const double h = norm(cross(x1, x2)), base = norm(x2 - x1);
  if (h > kFlat * norm(x1) * norm(x2) && base > 0) return h / base;
  return std::min(norm(x1), norm(x2));
}

// ---- A shared edge.

// Triangles (u, w, p) and (u, w, q) with u at the origin: whether they are folded onto each other
// (third vertices on the same side, separated by less than tol over their common width).
bool foldedOver(const Vec3& w, const Vec3& p, const Vec3& q, double tol, Vec3& where) {
  const double E = norm(w);
  if (!(E > 0)) return false;
  const Vec3 e = (1.0 / E) * w;
  const double sp = dot(p, e), sq = dot(q, e); // along the edge
  const Vec3 wp = p - sp * e, wq = q - sq * e; // across it
  const double lp = norm(wp), lq = norm(wq);
  const bool flatP = lp <= kFlat * std::max(E, norm(p)), flatQ = lq <= kFlat * std::max(E, norm(q));
  if (flatP && flatQ) { // two segments on the edge's line: do they both go on beyond one end?
    if (sp > E + tol && sq > E + tol) {
      where = w + (0.5 * (std::min(sp, sq) - E)) * e;
      return true;
    }
    if (sp < -tol && sq < -tol) {
      where = (0.5 * std::max(sp, sq)) * e;
      return true;
    }
    return false;
  }
  if (flatP || flatQ) return false; // a flat triangle on the edge's line meets the other only on the edge
  if (dot(wp, wq) <= 0) return false;
  if (norm(cross(wp, wq)) > tol * std::max(lp, lq)) return false; // min(lp, lq) sin(dihedral) > tol
  // A point off the edge in both: above the edge's midpoint, at half the lower of the heights
  // the two triangles have there.
  const double yp = lp * (0.5 * E) / std::max(sp, E - sp), yq = lq * (0.5 * E) / std::max(sq, E - sq);
  where = 0.5 * w + (0.5 * std::min(yp, yq) / lp) * wp;
  return true;
}

// ---- The pair test, on triangles without repeated indices, given their padded boxes and longest
// edges.
bool pairIntersects(const std::vector<Vec3>& P, const Tri& s, const Tri& t, const Box& bs, const Box& bt, double Ls,
                    double Lt, Vec3* where) {
  std::array<int, 3> inT{-1, -1, -1}; // inT[k]: position in t of s[k], -1 if none
  int shared = 0;
  for (size_t k = 0; k < 3; ++k)
    for (size_t l = 0; l < 3; ++l)
      if (s[k] == t[l]) {
        inT[k] = int(l);
        ++shared;
      }
  auto at = [&P](int32_t i) -> const Vec3& { return P[size_t(i)]; };
  const double tol = kRelTol * std::min(Ls, Lt);
  Vec3 w{};
  bool hit = false;
  if (shared == 3) { // the same triangle twice
    hit = true;
    w = (1.0 / 3) * (at(s[0]) + at(s[1]) + at(s[2]));
  } else if (shared == 0) {
    if (!overlap(bs, bt)) return false;
    const Vec3 o = at(s[0]);
    const std::array<Vec3, 3> A{at(s[0]) - o, at(s[1]) - o, at(s[2]) - o};
    const std::array<Vec3, 3> B{at(t[0]) - o, at(t[1]) - o, at(t[2]) - o};
    hit = nearEachOther(A, B, tol, w);
    w = w + o;
  } else if (shared == 1) {
    size_t k = 0;
    while (inT[k] < 0) ++k;
    const size_t l = size_t(inT[k]);
    const Vec3 v = at(s[k]);
    const Vec3 a1 = at(s[(k + 1) % 3]) - v, a2 = at(s[(k + 2) % 3]) - v;
    const Vec3 b1 = at(t[(l + 1) % 3]) - v, b2 = at(t[(l + 2) % 3]) - v;
    Vec3 dir{};
    hit = cornersOverlap(a1, a2, b1, b2, dir);
    if (hit) w = v + (0.5 * std::min(reach(a1, a2), reach(b1, b2))) * dir;
  } else { // shared edge
    size_t k = 0; // s's vertex not in t
    while (inT[k] >= 0) ++k;
    size_t l = 0; // t's vertex not in s
    while (t[l] == s[(k + 1) % 3] || t[l] == s[(k + 2) % 3]) ++l;
    const Vec3 u = at(s[(k + 1) % 3]);
    hit = foldedOver(at(s[(k + 2) % 3]) - u, at(s[k]) - u, at(t[l]) - u, tol, w);
    w = w + u;
  }
  if (hit && where) *where = w;
  return hit;
}

void checkTriangle(const std::vector<Vec3>& points, const Tri& t, size_t index) {
  for (int32_t v : t) {
    if (v < 0 || size_t(v) >= points.size()) {
      std::ostringstream m;
      m << "surface intersections: triangle " << index << " has vertex index " << v << ", out of range ("
        << points.size() << " points)";
      throw InputError(m.str());
    }
    const Vec3& p = points[size_t(v)];
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
      std::ostringstream m;
      m << "surface intersections: point " << v << " (of triangle " << index << ") has a non-finite coordinate";
      throw InputError(m.str());
    }
  }
}

// The bits of a 21-bit number spread to every third bit (for Morton codes).
uint64_t spreadBits(uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffULL;
  x = (x | x << 16) & 0x1f0000ff0000ffULL;
  x = (x | x << 8) & 0x100f00f00f00f00fULL;
  x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
  x = (x | x << 2) & 0x1249249249249249ULL;
  return x;
}

uint64_t mixBits(uint64_t x) { // a 64-bit finalizer (splitmix64's)
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebULL;
  x ^= x >> 31;
  return x;
}

} // namespace

bool trianglesIntersect(const std::vector<Vec3>& points, const std::array<int32_t, 3>& s,
                        const std::array<int32_t, 3>& t, Vec3* where) {
  checkTriangle(points, s, 0);
  checkTriangle(points, t, 1);
  if (repeatsIndex(s) || repeatsIndex(t)) return false;
  auto L = [&points](const Tri& x) {
    return longestEdge(points[size_t(x[0])], points[size_t(x[1])], points[size_t(x[2])]);
  };
  return pairIntersects(points, s, t, paddedBox(points, s), paddedBox(points, t), L(s), L(t), where);
}

std::vector<SurfaceIntersection> surfaceIntersections(const std::vector<Vec3>& points,
                                                      const std::vector<std::array<int32_t, 3>>& triangles,
                                                      size_t maxReported) {
  const size_t n = triangles.size();
  if (n >= size_t(INT32_MAX)) throw InputError("surface intersections: too many triangles (2^31 at most)");
  for (size_t i = 0; i < n; ++i) checkTriangle(points, triangles[i], i);
  std::vector<SurfaceIntersection> found;
  if (maxReported == 0 || n < 2) return found;
  const int64_t N = int64_t(n);

  // Padded boxes, longest and mean edge lengths of the triangles that take part.
  std::vector<Box> box(n);
  std::vector<double> longest(n), meanEdge(n, -1.0); // meanEdge < 0: skipped (repeated index)
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < N; ++i) {
    const Tri& t = triangles[size_t(i)];
    if (repeatsIndex(t)) continue;
    box[size_t(i)] = paddedBox(points, t);
    const Vec3 &a = points[size_t(t[0])], &b = points[size_t(t[1])], &c = points[size_t(t[2])];
    meanEdge[size_t(i)] = (norm(b - a) + norm(c - b) + norm(a - c)) / 3;
    longest[size_t(i)] = longestEdge(a, b, c);
  }
  double edgeSum = 0;
  int64_t used = 0;
  Vec3 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
          std::numeric_limits<double>::infinity()};
  Vec3 hi = -1.0 * lo;
  for (size_t i = 0; i < n; ++i) {
    if (meanEdge[i] < 0) continue;
    edgeSum += meanEdge[i];
    ++used;
    for (size_t k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], box[i].lo[k]);
      hi[k] = std::max(hi[k], box[i].hi[k]);
    }
  }
  if (used < 2) return found;

  // Cell size: the mean edge, grown while the grid would be too large.
  double cell = edgeSum / double(used);
  if (!(cell > 0)) cell = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1.0});
  std::array<int64_t, 3> dims{};
  double inv = 0;
  auto cellOf = [&](double x, size_t k) { // x >= lo[k]: truncation is floor
    const double c = (x - lo[k]) * inv;
    return c < 1 ? int64_t(0) : std::min(int64_t(c), dims[k] - 1);
  };
  const double budget = kCellsPerTriangle * double(used) + 1024;
  double entries = 0;
  for (;;) {
    bool fits = true;
    for (size_t k = 0; k < 3; ++k) fits = fits && (hi[k] - lo[k]) / cell < double(kMaxAxisCells);
    if (fits) {
      inv = 1.0 / cell;
      for (size_t k = 0; k < 3; ++k) dims[k] = std::min(int64_t((hi[k] - lo[k]) * inv) + 1, kMaxAxisCells);
      entries = 0;
#pragma omp parallel for schedule(static) reduction(+ : entries)
      for (int64_t i = 0; i < N; ++i) {
        if (meanEdge[size_t(i)] < 0) continue;
        double m = 1;
        for (size_t k = 0; k < 3; ++k)
          m *= double(cellOf(box[size_t(i)].hi[k], k) - cellOf(box[size_t(i)].lo[k], k) + 1);
        entries += m;
      }
      if (entries <= budget) break;
    }
    cell *= fits ? 1.5 : 2.0;
  }
  if (entries >= double(UINT32_MAX)) throw ProcessingError("surface intersections: too many grid entries");

  // Spatial hash: at least as many buckets as entries, each a list of triangle indices (filled in
  // parallel, then sorted ascending). A cell's bucket is the low bits of its Morton code (so
  // nearby cells share cache lines) XOR a hash of the high bits (so distant cells spread over all
  // buckets); cells sharing a bucket are told apart by the reference-cell test below.
  int bucketBits = 10;
  while (double(uint64_t(1) << bucketBits) < entries) ++bucketBits;
  const size_t buckets = size_t(1) << bucketBits;
  const uint64_t mask = buckets - 1;
  auto bucketOf = [mask, bucketBits](int64_t x, int64_t y, int64_t z) {
    const uint64_t code = spreadBits(uint64_t(x)) | spreadBits(uint64_t(y)) << 1 | spreadBits(uint64_t(z)) << 2;
    return size_t((code ^ mixBits(code >> bucketBits)) & mask);
  };
  std::vector<uint32_t> start(buckets + 1, 0);
  auto forCells = [&](size_t i, auto&& f) {
    const Box& b = box[i];
    const int64_t x0 = cellOf(b.lo[0], 0), x1 = cellOf(b.hi[0], 0), y0 = cellOf(b.lo[1], 1),
                  y1 = cellOf(b.hi[1], 1), z0 = cellOf(b.lo[2], 2), z1 = cellOf(b.hi[2], 2);
    for (int64_t z = z0; z <= z1; ++z)
      for (int64_t y = y0; y <= y1; ++y)
        for (int64_t x = x0; x <= x1; ++x) f(x, y, z);
  };
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < N; ++i)
    if (meanEdge[size_t(i)] >= 0)
      forCells(size_t(i), [&](int64_t x, int64_t y, int64_t z) {
        uint32_t& c = start[bucketOf(x, y, z) + 1];
#pragma omp atomic
        ++c;
      });
  for (size_t b = 0; b < buckets; ++b) start[b + 1] += start[b];
  std::vector<int32_t> list(start[buckets]);
  {
    std::vector<uint32_t> cursor(start.begin(), start.end() - 1);
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < N; ++i)
      if (meanEdge[size_t(i)] >= 0)
        forCells(size_t(i), [&](int64_t x, int64_t y, int64_t z) {
          uint32_t& c = cursor[bucketOf(x, y, z)];
          uint32_t at;
#pragma omp atomic capture
          at = c++;
          list[at] = int32_t(i);
        });
  }
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < int64_t(buckets); ++b)
    std::sort(list.begin() + start[size_t(b)], list.begin() + start[size_t(b) + 1]);

  // The pairs (i, j), j > i, in blocks of i.
  for (int64_t begin = 0; begin < N; begin += kBlock) {
    const int64_t end = std::min(N, begin + kBlock);
#pragma omp parallel
    {
      std::vector<SurfaceIntersection> mine;
      std::vector<std::pair<int32_t, Vec3>> hits;
#pragma omp for schedule(dynamic, 64) nowait
      for (int64_t ii = begin; ii < end; ++ii) {
        const size_t i = size_t(ii);
        if (meanEdge[i] < 0) continue;
        hits.clear();
        const Box& bi = box[i];
        forCells(i, [&](int64_t x, int64_t y, int64_t z) {
          const size_t b = bucketOf(x, y, z);
          const int32_t* first = list.data() + start[b];
          const int32_t* last = list.data() + start[b + 1];
          int32_t previous = -1; // a triangle in two cells of the same bucket is listed twice in a row
          for (const int32_t* it = std::upper_bound(first, last, int32_t(ii)); it != last; ++it) {
            const int32_t j = *it;
            if (j == previous) continue;
            previous = j;
            const Box& bj = box[size_t(j)];
            if (!overlap(bi, bj)) continue;
            // Test the pair only in the cell holding the lower corner of the boxes' overlap.
            if (cellOf(std::max(bi.lo[0], bj.lo[0]), 0) != x || cellOf(std::max(bi.lo[1], bj.lo[1]), 1) != y ||
                cellOf(std::max(bi.lo[2], bj.lo[2]), 2) != z)
              continue;
            Vec3 w{};
            if (pairIntersects(points, triangles[i], triangles[size_t(j)], bi, bj, longest[i], longest[size_t(j)], &w))
              hits.emplace_back(j, w);
          }
        });
        // Only the maxReported smallest j of this i can be among the result.
        std::sort(hits.begin(), hits.end(), [](const auto& p, const auto& q) { return p.first < q.first; });
        if (hits.size() > maxReported) hits.resize(maxReported);
        for (const auto& [j, w] : hits) mine.push_back({int32_t(i), j, w});
      }
#pragma omp critical(tetflow_surface_intersections)
      found.insert(found.end(), mine.begin(), mine.end());
    }
    if (found.size() >= maxReported) break;
  }
  std::sort(found.begin(), found.end(), [](const SurfaceIntersection& p, const SurfaceIntersection& q) {
    return p.a != q.a ? p.a < q.a : p.b < q.b;
  });
  if (found.size() > maxReported) found.resize(maxReported);
  return found;
}

} // namespace tetflow
