#include "Delaunay2D.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <sstream>
#include <utility>

#include "Algorithms/Core/Errors.h"

// The exact arithmetic below needs every double operation rounded once, to double (x87 extended
// precision would break it).
#if defined(FLT_EVAL_METHOD) && FLT_EVAL_METHOD > 0
#error "Delaunay2D.cpp needs FLT_EVAL_METHOD == 0 (SSE2 or similar double arithmetic)"
#endif

namespace tetflow {

namespace {

// ---------------------------------------------------------------------------------------------
// Expansion arithmetic (after Shewchuk, "Adaptive precision floating-point arithmetic and fast
// robust geometric predicates", 1997). An expansion is a sum of doubles, stored in increasing
// order of magnitude, no two overlapping and none zero (the empty expansion is 0); its sign is the
// sign of its last component.

constexpr double kEps = 1.1102230246251565e-16; // 2^-53, half an ulp of 1
constexpr double kOrientBound = (3.0 + 16.0 * kEps) * kEps;
constexpr double kInCircleBound = (10.0 + 96.0 * kEps) * kEps;

// x + y == a + b exactly, with x = fl(a + b).
inline void twoSum(double a, double b, double& x, double& y) {
  x = a + b;
  const double bv = x - a;
  const double av = x - bv;
  const double br = b - bv;
  const double ar = a - av;
  y = ar + br;
}

// As twoSum, for |a| >= |b| (or a == 0).
inline void fastTwoSum(double a, double b, double& x, double& y) {
  x = a + b;
  const double bv = x - a;
  y = b - bv;
}

// x + y == a - b exactly, with x = fl(a - b).
inline void twoDiff(double a, double b, double& x, double& y) {
  x = a - b;
  const double bv = a - x;
  const double av = x + bv;
  const double br = bv - b;
  const double ar = a - av;
  y = ar + br;
}

// x + y == a * b exactly, with x = fl(a * b). With a hardware fused multiply-add that is one
// instruction; otherwise Dekker's splitting, each step a separate statement (there is no fused
// instruction the compiler could contract them into).
inline void twoProduct(double a, double b, double& x, double& y) {
  x = a * b;
#if defined(__FP_FAST_FMA) || defined(__FMA__) || defined(__ARM_FEATURE_FMA)
  y = std::fma(a, b, -x);
#else
  constexpr double kSplitter = 134217729.0; // 2^27 + 1
  const double ca = kSplitter * a;
  const double abig = ca - a;
  const double ahi = ca - abig;
  const double alo = a - ahi;
  const double cb = kSplitter * b;
  const double bbig = cb - b;
  const double bhi = cb - bbig;
  const double blo = b - bhi;
  const double e1 = x - ahi * bhi;
  const double e2 = e1 - alo * bhi;
  const double e3 = e2 - ahi * blo;
  y = alo * blo - e3;
#endif
}

// a - b as an expansion of at most 2 components; returns its length.
inline int diffExpansion(double a, double b, double* h) {
  double x, y;
  twoDiff(a, b, x, y);
  int n = 0;
  if (y != 0) h[n++] = y;
  if (x != 0) h[n++] = x;
  return n;
}

// h = e + f (h has room for ne + nf components and differs from e and f); returns its length.
int sumExpansion(const double* e, int ne, const double* f, int nf, double* h) {
  int ie = 0, jf = 0, n = 0;
  // Next component of the merged sequence, by increasing magnitude.
  auto next = [&]() {
    if (jf >= nf || (ie < ne && std::fabs(e[ie]) < std::fabs(f[jf]))) return e[ie++];
    return f[jf++];
  };
  const int total = ne + nf;
  if (total == 0) return 0;
  double q = next();
  if (total > 1) {
    double qn, hh;
    fastTwoSum(next(), q, qn, hh);
    if (hh != 0) h[n++] = hh;
    q = qn;
  }
  for (int k = 2; k < total; ++k) {
    double qn, hh;
    twoSum(q, next(), qn, hh);
    if (hh != 0) h[n++] = hh;
    q = qn;
  }
  if (q != 0) h[n++] = q;
  return n;
}

// h = b * e (h has room for 2 ne components); returns its length.
int scaleExpansion(const double* e, int ne, double b, double* h) {
  if (ne == 0 || b == 0) return 0;
  int n = 0;
  double q, hh;
  twoProduct(e[0], b, q, hh);
  if (hh != 0) h[n++] = hh;
  for (int i = 1; i < ne; ++i) {
    double p1, p0, s;
    twoProduct(e[i], b, p1, p0);
    twoSum(q, p0, s, hh);
    if (hh != 0) h[n++] = hh;
    fastTwoSum(p1, s, q, hh);
    if (hh != 0) h[n++] = hh;
  }
  if (q != 0) h[n++] = q;
  return n;
}

constexpr int kMaxScaled = 16; // longest expansion ever passed as `e` to mulExpansion

// h = e * f; h and scratch each have room for 2 ne nf components; ne <= kMaxScaled.
int mulExpansion(const double* e, int ne, const double* f, int nf, double* h, double* scratch) {
  if (ne == 0 || nf == 0) return 0;
  double s[2 * kMaxScaled];
  double* acc = h;
  double* other = scratch;
  int n = scaleExpansion(e, ne, f[0], acc);
  for (int j = 1; j < nf; ++j) {
    const int ns = scaleExpansion(e, ne, f[j], s);
    n = sumExpansion(acc, n, s, ns, other);
    std::swap(acc, other);
  }
  if (acc != h) std::copy(acc, acc + n, h);
  return n;
}

inline void negate(double* e, int n) {
  for (int i = 0; i < n; ++i) e[i] = -e[i];
}

inline double signOf(const double* e, int n) { return n == 0 ? 0.0 : e[n - 1]; }

double orientExact(const Point2& a, const Point2& b, const Point2& c) {
  double acx[2], acy[2], bcx[2], bcy[2];
  const int nacx = diffExpansion(a.x, c.x, acx);
  const int nacy = diffExpansion(a.y, c.y, acy);
  const int nbcx = diffExpansion(b.x, c.x, bcx);
  const int nbcy = diffExpansion(b.y, c.y, bcy);
  double l[8], r[8], scratch[8], det[16];
  const int nl = mulExpansion(acx, nacx, bcy, nbcy, l, scratch);
  const int nr = mulExpansion(acy, nacy, bcx, nbcx, r, scratch);
  negate(r, nr);
  return signOf(det, sumExpansion(l, nl, r, nr, det));
}

// lift(p) * (u.x * v.y - v.x * u.y) for difference expansions p, u, v (each at most 2 long);
// `out` has room for 512 components.
int liftedTerm(const double* px, int npx, const double* py, int npy, const double* ux, int nux,
               const double* uy, int nuy, const double* vx, int nvx, const double* vy, int nvy,
               double* out) {
  double t1[8], t2[8], scratch8[8], cross[16], xx[8], yy[8], lift[16], scratch512[512];
  const int n1 = mulExpansion(ux, nux, vy, nvy, t1, scratch8);
  const int n2 = mulExpansion(vx, nvx, uy, nuy, t2, scratch8);
  negate(t2, n2);
  const int nc = sumExpansion(t1, n1, t2, n2, cross);
  const int nxx = mulExpansion(px, npx, px, npx, xx, scratch8);
  const int nyy = mulExpansion(py, npy, py, npy, yy, scratch8);
  const int nl = sumExpansion(xx, nxx, yy, nyy, lift);
  return mulExpansion(lift, nl, cross, nc, out, scratch512);
}

double inCircleExact(const Point2& a, const Point2& b, const Point2& c, const Point2& d) {
  double adx[2], ady[2], bdx[2], bdy[2], cdx[2], cdy[2];
  const int nadx = diffExpansion(a.x, d.x, adx), nady = diffExpansion(a.y, d.y, ady);
  const int nbdx = diffExpansion(b.x, d.x, bdx), nbdy = diffExpansion(b.y, d.y, bdy);
  const int ncdx = diffExpansion(c.x, d.x, cdx), ncdy = diffExpansion(c.y, d.y, cdy);
  double ta[512], tb[512], ab[1024], det[1536];
  const int na = liftedTerm(adx, nadx, ady, nady, bdx, nbdx, bdy, nbdy, cdx, ncdx, cdy, ncdy, ta);
  const int nb = liftedTerm(bdx, nbdx, bdy, nbdy, cdx, ncdx, cdy, ncdy, adx, nadx, ady, nady, tb);
  const int nab = sumExpansion(ta, na, tb, nb, ab);
  const int nc = liftedTerm(cdx, ncdx, cdy, ncdy, adx, nadx, ady, nady, bdx, nbdx, bdy, nbdy, ta);
  return signOf(det, sumExpansion(ab, nab, ta, nc, det));
}

// ---------------------------------------------------------------------------------------------
// Bowyer-Watson on normalised points. Triangles are stored with their vertices counter-clockwise
// and nb[t][i] is the triangle across the edge opposite vertex i. A ghost triangle (a, b, kGhost)
// (the ghost vertex always at index 2) covers the outside of the hull edge a -> b, which has the
// hull's interior on its right; its "circumcircle" is the open half-plane left of a -> b plus the
// open segment (a, b) itself, so the usual conflict rule inserts points outside the hull too.

constexpr int32_t kGhost = -1;

class Builder {
public:
  explicit Builder(std::vector<Point2> points) : p_(std::move(points)) {
    const size_t m = p_.size();
    v_.reserve(2 * m + 4);
    nb_.reserve(2 * m + 4);
    mark_.reserve(2 * m + 4);
    startAt_.assign(m + 1, 0);
    startStamp_.assign(m + 1, 0);
  }

  // The first triangle; a, b, c must be counter-clockwise.
  void start(int32_t a, int32_t b, int32_t c) {
    v_ = {{a, b, c}, {c, b, kGhost}, {a, c, kGhost}, {b, a, kGhost}};
    nb_ = {{1, 2, 3}, {3, 2, 0}, {1, 3, 0}, {2, 1, 0}};
    mark_.assign(4, 0);
    last_ = 0;
  }

  void insert(int32_t id);

  // The solid triangles.
  std::vector<std::array<int32_t, 3>> triangles() const {
    std::vector<std::array<int32_t, 3>> out;
    out.reserve(v_.size());
    for (const auto& t : v_)
      if (t[2] != kGhost) out.push_back(t);
    return out;
  }

private:
  struct BoundaryEdge {
    int32_t a, b;   // the edge a -> b as seen from inside the cavity
    int32_t out;    // the triangle beyond it
  };

  const Point2& pt(int32_t v) const { return p_[size_t(v)]; }
  bool conflicts(int32_t t, const Point2& q) const;
  int32_t locate(const Point2& q);
  void collectCavity(int32_t t0, const Point2& q);
  void retriangulate(int32_t id);

  std::vector<Point2> p_;
  std::vector<std::array<int32_t, 3>> v_, nb_;
  std::vector<uint32_t> mark_;       // 2 s: in the cavity of insertion s; 2 s + 1: tested, not in it
  uint32_t stamp_ = 0;
  int32_t last_ = 0;                 // a triangle next to the last inserted point
  uint32_t rng_ = 0x9e3779b9u;       // for the stochastic walk
  std::vector<int32_t> cavity_, stack_, newIds_, next_, prev_;
  std::vector<BoundaryEdge> boundary_;
  std::vector<int32_t> startAt_;     // per vertex + 1: the boundary edge starting there
  std::vector<uint32_t> startStamp_; // whether startAt_ is from this insertion
};

// Whether q lies strictly inside t's circumcircle (for a ghost: see above).
bool Builder::conflicts(int32_t t, const Point2& q) const {
  const auto& v = v_[size_t(t)];
  if (v[2] != kGhost) return inCircle2D(pt(v[0]), pt(v[1]), pt(v[2]), q) > 0;
  const Point2& a = pt(v[0]);
  const Point2& b = pt(v[1]);
  const double o = orient2D(a, b, q);
  if (o != 0) return o > 0;
  // q is on the line through a and b (exactly): inside iff strictly between them.
  if (a.x != b.x) return (a.x < q.x && q.x < b.x) || (b.x < q.x && q.x < a.x);
  return (a.y < q.y && q.y < b.y) || (b.y < q.y && q.y < a.y);
}

// A triangle that conflicts with q: the solid triangle containing it (closed), or a ghost
// triangle whose hull edge q is strictly outside of. Stochastic visibility walk from last_.
int32_t Builder::locate(const Point2& q) {
  int32_t t = last_, prev = -1;
  const size_t limit = 4 * v_.size() + 64;
  for (size_t steps = 0; steps < limit; ++steps) {
    const auto& v = v_[size_t(t)];
    if (v[2] == kGhost) {
      if (orient2D(pt(v[0]), pt(v[1]), q) > 0) return t;
      prev = t;
      t = nb_[size_t(t)][2];
      continue;
    }
    rng_ = rng_ * 1664525u + 1013904223u;
    const int r = int((rng_ >> 16) % 3u);
    int32_t to = -1;
    for (int k = 0; k < 3 && to < 0; ++k) {
      const int i = (r + k) % 3;
      const int32_t n = nb_[size_t(t)][size_t(i)];
      if (n != prev && orient2D(pt(v[size_t((i + 1) % 3)]), pt(v[size_t((i + 2) % 3)]), q) < 0) to = n;
    }
    if (to < 0) return t;
    prev = t;
    t = to;
  }
  throw ProcessingError("delaunay2D: internal error: point location did not terminate");
}

// cavity_ = the triangles whose circumcircle contains q (connected, from t0), grown until every
// boundary edge is strictly visible from q; boundary_ = its boundary edges.
void Builder::collectCavity(int32_t t0, const Point2& q) {
  ++stamp_;
  const uint32_t in = 2 * stamp_, tested = 2 * stamp_ + 1;
  cavity_.assign(1, t0);
  stack_.assign(1, t0);
  mark_[size_t(t0)] = in;
  while (!stack_.empty()) {
    const int32_t t = stack_.back();
    stack_.pop_back();
    for (int i = 0; i < 3; ++i) {
      const int32_t n = nb_[size_t(t)][size_t(i)];
      if (mark_[size_t(n)] == in || mark_[size_t(n)] == tested) continue;
      if (conflicts(n, q)) {
        mark_[size_t(n)] = in;
        cavity_.push_back(n);
        stack_.push_back(n);
      } else {
        mark_[size_t(n)] = tested;
      }
    }
  }
  // Star-shapedness: q must see every solid boundary edge strictly from inside, else the new
  // triangle on it would be flat or inverted. With exact predicates this always holds; where it
  // does not, the triangle beyond the edge joins the cavity.
  for (bool grew = true; grew;) {
    grew = false;
    boundary_.clear();
    for (size_t c = 0; c < cavity_.size(); ++c) {
      const int32_t t = cavity_[c];
      for (int i = 0; i < 3; ++i) {
        const int32_t n = nb_[size_t(t)][size_t(i)];
        if (mark_[size_t(n)] == in) continue;
        const int32_t a = v_[size_t(t)][size_t((i + 1) % 3)];
        const int32_t b = v_[size_t(t)][size_t((i + 2) % 3)];
        if (a != kGhost && b != kGhost && orient2D(pt(a), pt(b), q) <= 0) {
          mark_[size_t(n)] = in;
          cavity_.push_back(n);
          grew = true;
          continue;
        }
        boundary_.push_back({a, b, n});
      }
    }
  }
}

void Builder::insert(int32_t id) {
  const Point2 q = pt(id);
  collectCavity(locate(q), q);
  retriangulate(id);
}

// Replaces the cavity by the fan of triangles from `id` to its boundary edges.
void Builder::retriangulate(int32_t id) {
  const size_t nbnd = boundary_.size(), ncav = cavity_.size();
  // The cavity must be a disc without interior vertices: a connected set of C triangles whose
  // boundary visits B distinct vertices is one iff C == B - 2 (Euler characteristic).
  bool ok = nbnd == ncav + 2;
  for (size_t k = 0; ok && k < nbnd; ++k) {
    const size_t a = size_t(boundary_[k].a + 1);
    if (startStamp_[a] == stamp_) ok = false;
    startStamp_[a] = stamp_;
    startAt_[a] = int32_t(k);
  }
  next_.resize(nbnd);
  prev_.resize(nbnd);
  for (size_t k = 0; ok && k < nbnd; ++k) {
    const size_t b = size_t(boundary_[k].b + 1);
    if (startStamp_[b] != stamp_) {
      ok = false;
    } else {
      next_[k] = startAt_[b];
      prev_[size_t(startAt_[b])] = int32_t(k);
    }
  }
  if (!ok) throw ProcessingError("delaunay2D: internal error: the insertion cavity is not a disc");

  newIds_.assign(cavity_.begin(), cavity_.end());
  while (newIds_.size() < nbnd) {
    newIds_.push_back(int32_t(v_.size()));
    v_.push_back({0, 0, 0});
    nb_.push_back({0, 0, 0});
    mark_.push_back(0);
  }
  for (size_t k = 0; k < nbnd; ++k) {
    const BoundaryEdge& e = boundary_[k];
    const int32_t t = newIds_[k];
    std::array<int32_t, 3> v{e.a, e.b, id};
    std::array<int32_t, 3> n{newIds_[size_t(next_[k])], newIds_[size_t(prev_[k])], e.out};
    // The triangle beyond the edge now has t across it.
    auto& on = nb_[size_t(e.out)];
    const auto& ov = v_[size_t(e.out)];
    for (int j = 0; j < 3; ++j)
      if (ov[size_t(j)] != e.a && ov[size_t(j)] != e.b) on[size_t(j)] = t;
    // Ghost vertex to index 2 (a rotation keeps the orientation).
    if (e.a == kGhost) {
      v = {v[1], v[2], v[0]};
      n = {n[1], n[2], n[0]};
    } else if (e.b == kGhost) {
      v = {v[2], v[0], v[1]};
      n = {n[2], n[0], n[1]};
    }
    v_[size_t(t)] = v;
    nb_[size_t(t)] = n;
  }
  last_ = newIds_[0];
}

// ---------------------------------------------------------------------------------------------
// Normalisation, duplicates and insertion order.

std::string pointText(size_t i, const Point2& p) {
  std::ostringstream m;
  m.precision(17);
  m << "point " << i << " (" << p.x << ", " << p.y << ")";
  return m.str();
}

// Hilbert curve index of (x, y) on a 2^31 x 2^31 grid, one level (quadrant) at a time by a
// 4-state automaton: kHilbert[4 state + quadrant] = the quadrant's digit | next state << 2.
uint64_t hilbertIndex(uint32_t x, uint32_t y) {
  static constexpr uint8_t kHilbert[16] = {4, 1, 11, 2, 0, 15, 5, 6, 10, 9, 3, 12, 14, 7, 13, 8};
  uint64_t d = 0;
  uint32_t state = 0;
  for (int level = 30; level >= 0; --level) {
    const uint32_t quadrant = ((x >> level) & 1u) << 1 | ((y >> level) & 1u);
    const uint32_t e = kHilbert[4 * state + quadrant];
    d = d << 2 | (e & 3u);
    state = e >> 2;
  }
  return d;
}

uint64_t splitMix(uint64_t& s) {
  uint64_t z = (s += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

// Open-addressing hash grid of the kept points, to find duplicates within `tol`.
class DuplicateGrid {
public:
  DuplicateGrid(size_t n, double tol) : tol_(tol), cell_(16 * tol) {
    size_t cap = 16;
    while (cap < 2 * n) cap *= 2;
    slots_.assign(cap, Slot{});
    next_.reserve(n);
  }
  // Whether p is within tol of a kept point; otherwise records p as the next one (index
  // kept.size(), which the caller then appends) and returns false.
  bool findOrAdd(const Point2& p, const std::vector<Point2>& kept) {
    const int64_t cx = cellOf(p.x), cy = cellOf(p.y);
    const size_t home = find(cx, cy);
    if (near(slots_[home].head, p, kept)) return true;
    // The neighbouring cells, where p is within tol of the border (rarely: cells are 16 tol wide).
    const int64_t x0 = cellOf(p.x - tol_), x1 = cellOf(p.x + tol_);
    const int64_t y0 = cellOf(p.y - tol_), y1 = cellOf(p.y + tol_);
    for (int64_t x = x0; x <= x1; ++x)
      for (int64_t y = y0; y <= y1; ++y)
        if ((x != cx || y != cy) && near(slots_[find(x, y)].head, p, kept)) return true;
    Slot& s = slots_[home];
    s.x = cx;
    s.y = cy;
    next_.push_back(s.head);
    s.head = int32_t(next_.size() - 1);
    return false;
  }

private:
  struct Slot {
    int64_t x = 0, y = 0;
    int32_t head = -1;
  };
  int64_t cellOf(double v) const { return int64_t(std::floor(v / cell_)); }
  bool near(int32_t head, const Point2& p, const std::vector<Point2>& kept) const {
    for (int32_t i = head; i >= 0; i = next_[size_t(i)]) {
      const double dx = kept[size_t(i)].x - p.x, dy = kept[size_t(i)].y - p.y;
      if (dx * dx + dy * dy <= tol_ * tol_) return true;
    }
    return false;
  }
  // The slot of cell (x, y), or the empty slot where it would go.
  size_t find(int64_t x, int64_t y) const {
    uint64_t h = uint64_t(x) * 0x9e3779b97f4a7c15ull ^ (uint64_t(y) + 0x632be59bd9b4e019ull) * 0xc2b2ae3d27d4eb4full;
    h ^= h >> 29;
    const size_t mask = slots_.size() - 1;
    for (size_t i = size_t(h) & mask;; i = (i + 1) & mask) {
      const Slot& s = slots_[i];
      if (s.head < 0 || (s.x == x && s.y == y)) return i;
    }
  }
  double tol_, cell_;
  std::vector<Slot> slots_;
  std::vector<int32_t> next_;
};

} // namespace

double orient2D(const Point2& a, const Point2& b, const Point2& c) {
  const double detleft = (a.x - c.x) * (b.y - c.y);
  const double detright = (a.y - c.y) * (b.x - c.x);
  const double det = detleft - detright;
  const double bound = kOrientBound * (std::fabs(detleft) + std::fabs(detright));
  if (det > bound || -det > bound) return det;
  return orientExact(a, b, c);
}

double inCircle2D(const Point2& a, const Point2& b, const Point2& c, const Point2& d) {
  const double adx = a.x - d.x, ady = a.y - d.y;
  const double bdx = b.x - d.x, bdy = b.y - d.y;
  const double cdx = c.x - d.x, cdy = c.y - d.y;
  const double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
  const double cdxady = cdx * ady, adxcdy = adx * cdy;
  const double adxbdy = adx * bdy, bdxady = bdx * ady;
  const double alift = adx * adx + ady * ady;
  const double blift = bdx * bdx + bdy * bdy;
  const double clift = cdx * cdx + cdy * cdy;
  const double det = alift * (bdxcdy - cdxbdy) + blift * (cdxady - adxcdy) + clift * (adxbdy - bdxady);
  const double permanent = (std::fabs(bdxcdy) + std::fabs(cdxbdy)) * alift +
                           (std::fabs(cdxady) + std::fabs(adxcdy)) * blift +
                           (std::fabs(adxbdy) + std::fabs(bdxady)) * clift;
  const double bound = kInCircleBound * permanent;
  if (det > bound || -det > bound) return det;
  return inCircleExact(a, b, c, d);
}

Triangulation2D delaunay2D(const std::vector<Point2>& points) {
  const size_t n = points.size();
  if (n > (size_t(1) << 29)) throw InputError("delaunay2D: too many points (more than 2^29)");
  for (size_t i = 0; i < n; ++i)
    if (!std::isfinite(points[i].x) || !std::isfinite(points[i].y))
      throw InputError("delaunay2D: " + pointText(i, points[i]) + " has a non-finite coordinate");
  if (n < 3) throw InputError("delaunay2D: need at least 3 points, got " + std::to_string(n));

  // Normalise: translate each axis to start at 0 where that is exact for every point, and scale
  // by a power of two so that the longest side of the bounding box is in [1, 2).
  double lo[2] = {points[0].x, points[0].y}, hi[2] = {lo[0], lo[1]};
  for (const Point2& p : points) {
    lo[0] = std::min(lo[0], p.x);
    hi[0] = std::max(hi[0], p.x);
    lo[1] = std::min(lo[1], p.y);
    hi[1] = std::max(hi[1], p.y);
  }
  const double extent = std::max(hi[0] - lo[0], hi[1] - lo[1]);
  if (extent == 0) throw InputError("delaunay2D: all " + std::to_string(n) + " points coincide");
  // (Half the extent where the extent itself overflows.)
  const double halfExtent = std::max(hi[0] * 0.5 - lo[0] * 0.5, hi[1] * 0.5 - lo[1] * 0.5);
  const int scaleExp = std::isfinite(extent) ? -std::ilogb(extent) : -std::ilogb(halfExtent) - 1;
  const double side = std::isfinite(extent) ? std::ldexp(extent, scaleExp) : std::ldexp(halfExtent, scaleExp + 1);
  double origin[2] = {lo[0], lo[1]};
  for (int a = 0; a < 2; ++a)
    for (const Point2& p : points) {
      double d, e;
      twoDiff(a == 0 ? p.x : p.y, origin[a], d, e);
      if (e != 0 || !std::isfinite(d)) {
        origin[a] = 0;
        break;
      }
    }
  const double tiny = std::ldexp(1.0, -200);
  auto normalise = [&](double v, int a) {
    const double s = std::ldexp(v - origin[a], scaleExp);
    return std::fabs(s) < tiny ? 0.0 : s;
  };

  // Drop duplicates (within 1e-12 of the box size of an earlier kept point).
  std::vector<Point2> kept;
  std::vector<int32_t> keptIndex;
  kept.reserve(n);
  keptIndex.reserve(n);
  Triangulation2D result;
  {
    DuplicateGrid grid(n, 1e-12 * side);
    for (size_t i = 0; i < n; ++i) {
      const Point2 q{normalise(points[i].x, 0), normalise(points[i].y, 1)};
      if (grid.findOrAdd(q, kept)) {
        ++result.duplicates;
      } else {
        kept.push_back(q);
        keptIndex.push_back(int32_t(i));
      }
    }
  }
  const size_t m = kept.size();
  if (m < 3)
    throw InputError("delaunay2D: need at least 3 distinct points, got " + std::to_string(m) + " (and " +
                     std::to_string(result.duplicates) + " duplicates)");

  // BRIO order: a fixed-seed shuffle split into rounds [.., m/8), [m/8, m/4), [m/4, m/2),
  // [m/2, m), each round sorted along a Hilbert curve.
  double klo[2] = {kept[0].x, kept[0].y};
  for (const Point2& p : kept) {
    klo[0] = std::min(klo[0], p.x);
    klo[1] = std::min(klo[1], p.y);
  }
  const double toGrid = double((1u << 31) - 1) / (side * (1 + 1e-9));
  std::vector<std::pair<uint64_t, int32_t>> order(m);
  for (size_t i = 0; i < m; ++i) {
    const auto gx = uint32_t(std::min(double((1u << 31) - 1), (kept[i].x - klo[0]) * toGrid));
    const auto gy = uint32_t(std::min(double((1u << 31) - 1), (kept[i].y - klo[1]) * toGrid));
    order[i] = {hilbertIndex(gx, gy), int32_t(i)};
  }
  uint64_t seed = 0x5eed2d;
  for (size_t i = m - 1; i > 0; --i) std::swap(order[i], order[size_t(splitMix(seed) % (i + 1))]);
  for (size_t end = m; end > 0;) {
    const size_t begin = end > 64 ? end / 2 : 0;
    std::sort(order.begin() + std::ptrdiff_t(begin), order.begin() + std::ptrdiff_t(end));
    end = begin;
  }

  // The first triangle: the first two points and the next point not collinear with them.
  size_t third = 2;
  while (third < m && orient2D(kept[size_t(order[0].second)], kept[size_t(order[1].second)],
                               kept[size_t(order[third].second)]) == 0)
    ++third;
  if (third == m)
    throw InputError("delaunay2D: all " + std::to_string(m) +
                     " distinct points are collinear, so there is no triangle");
  std::swap(order[2], order[third]);

  // Internal ids are insertion ranks.
  std::vector<Point2> ranked(m);
  for (size_t r = 0; r < m; ++r) ranked[r] = kept[size_t(order[r].second)];
  Builder builder(std::move(ranked));
  if (orient2D(kept[size_t(order[0].second)], kept[size_t(order[1].second)], kept[size_t(order[2].second)]) > 0)
    builder.start(0, 1, 2);
  else
    builder.start(0, 2, 1);
  for (size_t r = 3; r < m; ++r) builder.insert(int32_t(r));

  result.triangles = builder.triangles();
  for (auto& t : result.triangles)
    for (int32_t& v : t) v = keptIndex[size_t(order[size_t(v)].second)];
  return result;
}

std::vector<bool> hasEdges(const Triangulation2D& t, const std::vector<std::array<int32_t, 2>>& edges) {
  auto key = [](int32_t a, int32_t b) {
    if (a > b) std::swap(a, b);
    return uint64_t(uint32_t(a)) << 32 | uint64_t(uint32_t(b));
  };
  std::vector<uint64_t> keys;
  keys.reserve(3 * t.triangles.size());
  for (const auto& tri : t.triangles)
    for (int i = 0; i < 3; ++i) keys.push_back(key(tri[size_t(i)], tri[size_t((i + 1) % 3)]));
  std::sort(keys.begin(), keys.end());
  std::vector<bool> found(edges.size(), false);
  for (size_t i = 0; i < edges.size(); ++i) {
    const auto& e = edges[i];
    if (e[0] < 0 || e[1] < 0 || e[0] == e[1]) continue;
    found[i] = std::binary_search(keys.begin(), keys.end(), key(e[0], e[1]));
  }
  return found;
}

} // namespace tetflow
