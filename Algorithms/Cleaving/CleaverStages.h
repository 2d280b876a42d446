#pragma once
// Internal to Algorithms/Cleaving: the lattice cleaver's state and stages (seed chapter 4), shared
// by the files that hold one stage each:
//   CleaverSetup.cpp    box constraints, sampling the materials, interface points (cuts, triples,
//                       quadruples) and the edge/face/tet adjacency;
//   CleaverSnap.cpp     alphas, snapping and warping of vertices, edges and faces (§4.5), the
//                       generalized stencil's virtual points;
//   CleaverResolve.cpp  resolving degeneracies: virtual quadruples and the closure over faces and
//                       tets;
//   CleaverStencil.cpp  emitting the stencil tets;
//   CleaverAngles.cpp   the angle optimisation of the output;
//   Cleaver.cpp         run() in that order, and the public API (Cleaver.h).
// Nothing outside Algorithms/Cleaving includes this file.
#include "Algorithms/Cleaving/Cleaver.h"

#include <Eigen/Dense>
#include <omp.h>
#include "Algorithms/Core/CancellableSort.h"
#include <algorithm>
#include <atomic>
#include <cmath>
#include <deque>
#include <optional>
#include <sstream>
#include <unordered_map>
#include "Algorithms/Core/Errors.h"
#include "Algorithms/Quality/LabelTopology.h"
#include "Algorithms/Quality/TetQuality.h"

namespace tetflow::cleaving_detail {


// ---- references to interface points -----------------------------------------------------

constexpr uint8_t kVertex = 0, kCut = 1, kTriple = 2, kQuad = 3, kNone = 4;

struct Ref {
  uint8_t kind = kNone;
  int32_t index = -1;
  bool operator==(const Ref&) const = default;
  bool none() const { return kind == kNone; }
};

// Local numbering inside a tet (vertices 0..3).
constexpr int kEdgeVerts[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
constexpr int kFaceVerts[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}}; // opposite i

inline int localEdge(int a, int b) {
  if (a > b) std::swap(a, b);
  for (int e = 0; e < 6; ++e)
    if (kEdgeVerts[e][0] == a && kEdgeVerts[e][1] == b) return e;
  return -1;
}

inline bool faceHasVertex(int lf, int lv) { return lf != lv; }
inline bool edgeHasVertex(int le, int lv) { return kEdgeVerts[le][0] == lv || kEdgeVerts[le][1] == lv; }
inline bool faceHasEdge(int lf, int le) { return !edgeHasVertex(le, lf); }

// The 24 flags (vertex in edge in face) of the generalized stencil, with the corner order that
// gives positive orientation for a positively oriented background tet.
struct Flag {
  int v, e, f;
  bool swapVE; // emit (cut, vertex, triple, quad) instead of (vertex, cut, triple, quad)
};

inline std::vector<Flag> buildFlags() {
  const Vec3 ref[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const Vec3 centre = 0.25 * (ref[0] + ref[1] + ref[2] + ref[3]);
  std::vector<Flag> flags;
  for (int f = 0; f < 4; ++f)
    for (int e = 0; e < 6; ++e) {
      if (!faceHasEdge(f, e)) continue;
      for (int k = 0; k < 2; ++k) {
        const int v = kEdgeVerts[e][k];
        const Vec3 pe = 0.5 * (ref[kEdgeVerts[e][0]] + ref[kEdgeVerts[e][1]]);
        const Vec3 pf = (1.0 / 3.0) * (ref[kFaceVerts[f][0]] + ref[kFaceVerts[f][1]] + ref[kFaceVerts[f][2]]);
        const double vol = signedTetVolume(ref[v], pe, pf, centre);
        flags.push_back({v, e, f, vol < 0});
      }
    }
  return flags;
}

inline double alphaFraction(double a) { return std::clamp(a, 0.0, 0.49); }

class Cleaver {
public:
  Cleaver(const BackgroundMesh& bg, const MaterialSet& mats, const CleaveParams& p, Progress& progress)
      : bg_(bg), m_(bg.tets()), mats_(mats), p_(p), progress_(progress), flags_(buildFlags()),
        exact_(p.interface_points == CleaveParams::InterfacePoints::Exact ||
               (p.interface_points == CleaveParams::InterfacePoints::Auto && !bg.kind.empty())) {}

  CleaveResult run();

private:
  // ---- state ----
  const BackgroundMesh& bg_;
  const TetMesh& m_;
  const MaterialSet& mats_;
  const CleaveParams& p_;
  Progress& progress_;
  const std::vector<Flag> flags_;
  const bool exact_; // interface points where the functions cross (CleaveParams::interface_points)
  CleaveStats stats_;

  std::vector<Vec3> pos_;            // current (warped) vertex positions
  std::vector<int32_t> label_;       // dense material index per vertex
  std::vector<int64_t> sampleStart_; // CSR into samples_
  std::vector<MaterialSample> samples_;
  std::vector<uint8_t> warped_;
  std::unordered_map<int32_t, std::vector<MaterialSample>> resampled_;
  std::vector<float> vertexAlpha_; // unstructured: absolute alpha (mm)
  // Vertices on the domain box (in the materials grid's frame) keep their box coordinates when
  // warped, so the mesh still fills the box exactly: bit a set = local axis a is fixed.
  std::vector<uint8_t> fixedAxes_;
  Vec3 boxLo_{0, 0, 0}, boxHi_{0, 0, 0}; // domain box in the frame's local coordinates
  bool onBox(const Vec3& p) const {
    const Vec3 d = p - mats_.grid().origin;
    for (int a = 0; a < 3; ++a) {
      const double l = frame_[0][a] * d[0] + frame_[1][a] * d[1] + frame_[2][a] * d[2];
      const double eps = 1e-9 * (boxHi_[a] - boxLo_[a]);
      if (std::abs(l - boxLo_[a]) <= eps || std::abs(l - boxHi_[a]) <= eps) return true;
    }
    return false;
  }
  // All background tets around each vertex of an interface tet (CSR; empty for the others), to
  // keep warps from flattening any of them.
  std::vector<int64_t> allStart_;
  std::vector<int32_t> allList_;
  // Largest fraction (1, 1/2, 1/4, ...) of the move to `target` that keeps every background tet
  // around v at >= 10 % of its original volume; 0 when none does.
  Vec3 safeWarp(int32_t v, const Vec3& target) {
    const Vec3 from = pos_[v];
    for (int tries = 0; tries < 8; ++tries) {
      const double s = std::ldexp(1.0, -tries);
      const Vec3 p = from + s * (target - from);
      bool ok = true;
      pos_[v] = p;
      for (int64_t i = allStart_[v]; i < allStart_[v + 1] && ok; ++i) {
        const auto& q = m_.tets[allList_[i]];
        const double now = signedTetVolume(pos_[q[0]], pos_[q[1]], pos_[q[2]], pos_[q[3]]);
        const double orig = signedTetVolume(m_.points[q[0]], m_.points[q[1]], m_.points[q[2]], m_.points[q[3]]);
        ok = now >= 0.1 * orig;
      }
      pos_[v] = from;
      if (ok) return p;
    }
    ++stats_.limitedWarps;
    return from;
  }
  Mat3 frame_ = identity3();
  void computeBoxConstraints();
  Vec3 constrainWarp(int32_t v, const Vec3& target) const {
    const uint8_t fixed = fixedAxes_[v];
    if (!fixed) return target;
    if (fixed == 7) return m_.points[v];
    const Vec3 d = target - m_.points[v];
    Vec3 l{0, 0, 0};
    for (int a = 0; a < 3; ++a) // local = frame^T d
      if (!(fixed >> a & 1)) l[a] = frame_[0][a] * d[0] + frame_[1][a] * d[1] + frame_[2][a] * d[2];
    return m_.points[v] + mul(frame_, l);
  }

  std::vector<uint8_t> cull_;                    // background tet left out (empty: none)
  std::vector<int32_t> itet_;                    // interface tet -> background tet
  std::vector<int32_t> bgToInterface_;           // background tet -> interface tet or -1
  std::vector<std::array<int32_t, 6>> tetEdge_;  // interface tet -> edges
  std::vector<std::array<int32_t, 4>> tetFace_;  // interface tet -> faces
  std::vector<std::array<int32_t, 2>> edgeV_;    // sorted vertex ids
  std::vector<std::array<int32_t, 3>> faceV_;    // sorted vertex ids

  std::vector<float> cutT_; // parameter from edgeV_[e][0]
  std::vector<Ref> cutAlias_;
  std::vector<uint8_t> cutReal_;
  std::vector<std::array<float, 3>> triB_; // barycentric over faceV_
  std::vector<Ref> triAlias_;
  std::vector<uint8_t> triReal_;
  // A face whose three cuts all sit on vertices is a single output triangle wherever its triple
  // sits among its vertices, so each tet may view that triple at a vertex of its own choosing
  // (only the material of the cone tets depends on it). -1 = use the shared triple.
  std::vector<std::array<int32_t, 4>> triOverride_;
  std::vector<std::array<float, 4>> quadB_; // barycentric over the background tet's vertices
  std::vector<Ref> quadAlias_;
  std::vector<uint8_t> quadReal_;

  // CSR adjacency (interface tets only)
  std::vector<int64_t> vtStart_, etStart_, ftStart_;
  std::vector<int32_t> vtList_, etList_, ftList_;

  // ---- helpers ----
  const TetMesh::Tet& tv(int32_t t) const { return m_.tets[static_cast<size_t>(itet_[t])]; }
  int localVertex(int32_t t, int32_t v) const {
    const auto& q = tv(t);
    for (int i = 0; i < 4; ++i)
      if (q[i] == v) return i;
    return -1;
  }

  float value(int32_t v, int32_t mat) const {
    const MaterialSample* b;
    const MaterialSample* e;
    if (warped_[v]) {
      const auto& s = resampled_.at(v);
      b = s.data();
      e = s.data() + s.size();
    } else {
      b = samples_.data() + sampleStart_[v];
      e = samples_.data() + sampleStart_[v + 1];
    }
    for (const MaterialSample* s = b; s != e; ++s)
      if (s->material == mat) return s->value;
    return mats_.absentValue();
  }

  double alphaAt(int32_t x, int32_t y) const {
    if (!bg_.kind.empty()) {
      const auto kx = bg_.kind[x], ky = bg_.kind[y];
      if (kx == LatticeVertexKind::FaceCentre || ky == LatticeVertexKind::FaceCentre || kx == ky)
        return alphaFraction(p_.alpha_long);
      return alphaFraction(p_.alpha_short);
    }
    const double len = norm(m_.points[x] - m_.points[y]);
    return len > 0 ? alphaFraction(vertexAlpha_[y] / len) : 0.0;
  }
  // "x is negligible next to y": the violation half-space test of §4.6.
  bool negl(int32_t x, int32_t y, double lx, double ly) const {
    const double a = alphaAt(x, y);
    return lx * (1.0 - a) < a * ly || lx <= 1e-9;
  }

  Ref resolve(Ref r) const {
    for (;;) {
      switch (r.kind) {
        case kCut:
          if (cutAlias_[r.index].none()) return r;
          r = cutAlias_[r.index];
          break;
        case kTriple:
          if (triAlias_[r.index].none()) return r;
          r = triAlias_[r.index];
          break;
        case kQuad:
          if (quadAlias_[r.index].none()) return r;
          r = quadAlias_[r.index];
          break;
        default: return r;
      }
    }
  }
  Vec3 positionOf(Ref r) const {
    r = resolve(r);
    switch (r.kind) {
      case kVertex: return pos_[r.index];
      case kCut: {
        const auto& e = edgeV_[r.index];
        const double t = cutT_[r.index];
        return (1.0 - t) * pos_[e[0]] + t * pos_[e[1]];
      }
      case kTriple: {
        const auto& f = faceV_[r.index];
        const auto& b = triB_[r.index];
        return double(b[0]) * pos_[f[0]] + double(b[1]) * pos_[f[1]] + double(b[2]) * pos_[f[2]];
      }
      case kQuad: {
        const auto& q = tv(r.index);
        const auto& b = quadB_[r.index];
        return double(b[0]) * pos_[q[0]] + double(b[1]) * pos_[q[1]] + double(b[2]) * pos_[q[2]] +
               double(b[3]) * pos_[q[3]];
      }
    }
    return {0, 0, 0};
  }
  void setAlias(Ref r, Ref target) {
    switch (r.kind) {
      case kCut: cutAlias_[r.index] = target; break;
      case kTriple: triAlias_[r.index] = target; break;
      case kQuad: quadAlias_[r.index] = target; break;
      default: break;
    }
  }

  // ---- violation tests ----
  bool cutViolates(int32_t e, int end) const { // end 0/1: the vertex edgeV_[e][end]
    const auto& v = edgeV_[e];
    const double t = cutT_[e];
    return end == 0 ? negl(v[1], v[0], t, 1.0 - t) : negl(v[0], v[1], 1.0 - t, t);
  }
  // Point with barycentrics b over vertices vs violates the sub-simplex given by mask `in`.
  template <int N>
  bool violates(const std::array<int32_t, N>& vs, const std::array<float, N>& b, unsigned in) const {
    for (int y = 0; y < N; ++y) {
      if (!(in >> y & 1u)) continue;
      for (int x = 0; x < N; ++x)
        if (!(in >> x & 1u) && !negl(vs[x], vs[y], b[x], b[y])) return false;
    }
    return true;
  }
  bool triViolates(int32_t f, unsigned mask) const { return violates<3>(faceV_[f], triB_[f], mask); }
  bool quadViolates(int32_t t, unsigned mask) const {
    const auto& q = tv(t);
    return violates<4>({q[0], q[1], q[2], q[3]}, quadB_[t], mask);
  }
  unsigned faceMask(int32_t f, int32_t v) const {
    for (int i = 0; i < 3; ++i)
      if (faceV_[f][i] == v) return 1u << i;
    return 0;
  }

  // Calls fn(Ref) once for every real interface point that is still free on the edges, faces
  // and tets of the interface tets around vertex v (`stamp` dedupes shared edges and faces).
  template <class F>
  void forFreePointsAround(int32_t v, int32_t stamp, std::vector<int32_t>& edgeStamp,
                           std::vector<int32_t>& faceStamp, F&& fn) {
    for (int64_t i = vtStart_[v]; i < vtStart_[v + 1]; ++i) {
      const int32_t t = vtList_[i];
      const int lv = localVertex(t, v);
      for (int le = 0; le < 6; ++le) {
        if (!edgeHasVertex(le, lv)) continue;
        const int32_t e = tetEdge_[t][le];
        if (edgeStamp[e] == stamp) continue;
        edgeStamp[e] = stamp;
        if (cutReal_[e] && cutAlias_[e].none()) fn(Ref{kCut, e});
      }
      for (int lf = 0; lf < 4; ++lf) {
        if (!faceHasVertex(lf, lv)) continue;
        const int32_t f = tetFace_[t][lf];
        if (faceStamp[f] == stamp) continue;
        faceStamp[f] = stamp;
        if (triReal_[f] && triAlias_[f].none()) fn(Ref{kTriple, f});
      }
      if (quadReal_[t] && quadAlias_[t].none()) fn(Ref{kQuad, t});
    }
  }
  // The vertices of a cut's, triple's or quadruple's own simplex; returns their count.
  int simplexOf(Ref r, int32_t vs[4]) const {
    switch (r.kind) {
      case kCut: vs[0] = edgeV_[r.index][0]; vs[1] = edgeV_[r.index][1]; return 2;
      case kTriple: for (int k = 0; k < 3; ++k) vs[k] = faceV_[r.index][k]; return 3;
      case kQuad: for (int k = 0; k < 4; ++k) vs[k] = tv(r.index)[k]; return 4;
      default: return 0;
    }
  }
  // Does interface point r violate the k-th vertex of its simplex?
  bool violatesVertex(Ref r, int k) const {
    switch (r.kind) {
      case kCut: return cutViolates(r.index, k);
      case kTriple: return triViolates(r.index, 1u << k);
      case kQuad: return quadViolates(r.index, 1u << k);
      default: return false;
    }
  }
  void recompute(Ref r) {
    if (r.kind == kCut) computeCut(r.index);
    else if (r.kind == kTriple) computeTriple(r.index);
    else if (r.kind == kQuad) computeQuad(r.index);
  }

  // The materials a cut separates (its ends' labels), smaller first.
  std::pair<int32_t, int32_t> cutPair(int32_t e) const {
    const int32_t a = label_[edgeV_[e][0]], b = label_[edgeV_[e][1]];
    return {std::min(a, b), std::max(a, b)};
  }
  // ---- interface point computation (linear interpolation of sampled values) ----
  void computeCut(int32_t e) {
    const auto& v = edgeV_[e];
    const int32_t la = label_[v[0]], lb = label_[v[1]];
    const double ga = double(value(v[0], la)) - value(v[0], lb);
    const double gb = double(value(v[1], la)) - value(v[1], lb);
    double t;
    if (ga <= 0) t = 0.0;
    else if (gb >= 0) t = 1.0;
    else t = exact_ ? exactCrossing(v[0], v[1], la, lb, ga, gb) : ga / (ga - gb);
    // A warped end sits on an interface, where its own label no longer wins (or only just): with
    // exact points the edge can still cross between the ends' labels away from it - a one-voxel
    // sheet whose vertex was warped onto the sheet's far face, the edge crossing the near face.
    // That crossing is kept (searched from the other end) instead of the cut falling onto the
    // warped vertex, which left the whole tet to the other label.
    if (exact_ && (t == 0.0 || t == 1.0) && warped_[v[t == 0.0 ? 0 : 1]])
      if (const auto inner = crossingFromOtherEnd(v[0], v[1], la, lb, ga, gb, t == 1.0)) t = *inner;
    cutT_[e] = static_cast<float>(std::clamp(t, 0.0, 1.0));
  }
  // With end b warped (towardB) or end a: the first of the quarter points from the other end where
  // the sign of f_la - f_lb has changed from that end's, and the crossing before it; none when the
  // functions do not change sign there.
  std::optional<double> crossingFromOtherEnd(int32_t a, int32_t b, int32_t la, int32_t lb, double ga, double gb,
                                             bool towardB) const {
    const Vec3 pa = pos_[a], pb = pos_[b];
    for (double q : {0.25, 0.5, 0.75}) {
      const double tq = towardB ? q : 1.0 - q;
      const double gq = difference((1.0 - tq) * pa + tq * pb, la, lb);
      if (towardB && ga > 0 && gq < 0) return exactCrossing(a, b, la, lb, ga, gq, 0.0, tq);
      if (!towardB && gb < 0 && gq > 0) return exactCrossing(a, b, la, lb, gq, gb, tq, 1.0);
    }
    return std::nullopt;
  }
  // f_la - f_lb at p (the materials sampled there).
  double difference(const Vec3& p, int32_t la, int32_t lb) const {
    thread_local std::vector<MaterialSample> s;
    mats_.sample(p, s);
    float fa = mats_.absentValue(), fb = mats_.absentValue();
    for (const auto& x : s) {
      if (x.material == la) fa = x.value;
      else if (x.material == lb) fb = x.value;
    }
    return double(fa) - double(fb);
  }
  // The crossing of f_la - f_lb on the segment pos_[a] -> pos_[b] (ga > 0 > gb at its ends),
  // by the Illinois variant of regula falsi on the materials themselves, from the linear guess.
  // (Within [lo, hi] of the segment when given, ga and gb the values there.)
  double exactCrossing(int32_t a, int32_t b, int32_t la, int32_t lb, double ga, double gb, double lo = 0.0,
                       double hi = 1.0) const {
    const Vec3 pa = pos_[a], pb = pos_[b];
    double t0 = lo, t1 = hi, g0 = ga, g1 = gb;
    const double len = norm(pb - pa);
    const double tol = len > 0 ? p_.interface_tolerance / len : 1.0;
    int side = 0;
    double t = lo + (hi - lo) * ga / (ga - gb);
    for (int it = 0; it < 12; ++it) {
      const double g = difference((1.0 - t) * pa + t * pb, la, lb);
      if (g == 0.0) return t;
      if (g > 0) {
        t0 = t;
        g0 = g;
        if (side == 1) g1 *= 0.5;
        side = 1;
      } else {
        t1 = t;
        g1 = g;
        if (side == -1) g0 *= 0.5;
        side = -1;
      }
      if (t1 - t0 < tol) break;
      t = (t0 * g1 - t1 * g0) / (g1 - g0);
    }
    return (t0 * g1 - t1 * g0) / (g1 - g0);
  }
  // With exact interfaces, the linear model of g = f_a - f_b that triples and quadruples solve
  // (its values at the simplex's vertices) is made to vanish where the edge's cut is: the value at
  // the far end gb is set to ga (t - 1) / t, so the points agree with the cuts around them.
  static void throughCut(double ga, double& gb, double t) {
    if (ga > 0 && t > 0.0 && t < 1.0) gb = ga * (t - 1.0) / t;
  }
  template <int N>
  static void projectBarycentric(std::array<float, N>& b) {
    double s = 0;
    for (auto& x : b) {
      if (!(x > 0)) x = 0;
      s += x;
    }
    if (!(s > 0)) {
      for (auto& x : b) x = 1.0f / N;
      return;
    }
    for (auto& x : b) x = static_cast<float>(x / s);
  }
  void computeTriple(int32_t f) {
    const auto& v = faceV_[f];
    const int32_t l[3] = {label_[v[0]], label_[v[1]], label_[v[2]]};
    Eigen::Matrix3d A;
    for (int x = 0; x < 3; ++x) {
      A(0, x) = double(value(v[x], l[0])) - value(v[x], l[1]);
      A(1, x) = double(value(v[x], l[0])) - value(v[x], l[2]);
      A(2, x) = 1.0;
    }
    if (exact_) { // the zero lines through the cuts on edges (v0, v1) and (v0, v2)
      throughCut(A(0, 0), A(0, 1), cutT_[faceEdge(f, v[0], v[1])]);
      throughCut(A(1, 0), A(1, 2), cutT_[faceEdge(f, v[0], v[2])]);
    }
    const double scale = A.block<2, 3>(0, 0).cwiseAbs().maxCoeff();
    std::array<float, 3> b;
    if (scale > 0 && std::abs(A.determinant()) > 1e-9 * scale * scale) {
      const Eigen::Vector3d x = A.partialPivLu().solve(Eigen::Vector3d(0, 0, 1));
      b = {float(x[0]), float(x[1]), float(x[2])};
    } else {
      b = {1.0f / 3, 1.0f / 3, 1.0f / 3};
    }
    projectBarycentric<3>(b);
    triB_[f] = b;
  }
  void computeQuad(int32_t t) {
    const auto& q = tv(t);
    const int32_t l[4] = {label_[q[0]], label_[q[1]], label_[q[2]], label_[q[3]]};
    Eigen::Matrix4d A;
    for (int x = 0; x < 4; ++x) {
      for (int r = 0; r < 3; ++r) A(r, x) = double(value(q[x], l[0])) - value(q[x], l[r + 1]);
      A(3, x) = 1.0;
    }
    if (exact_) // the zero planes through the cuts on edges (q0, q1), (q0, q2), (q0, q3)
      for (int r = 0; r < 3; ++r) {
        const int32_t e = tetEdge_[t][localEdge(0, r + 1)];
        const double c = cutT_[e];
        throughCut(A(r, 0), A(r, r + 1), edgeV_[e][0] == q[0] ? c : 1.0 - c);
      }
    const double scale = A.block<3, 4>(0, 0).cwiseAbs().maxCoeff();
    std::array<float, 4> b;
    if (scale > 0 && std::abs(A.determinant()) > 1e-9 * scale * scale * scale) {
      const Eigen::Vector4d x = A.partialPivLu().solve(Eigen::Vector4d(0, 0, 0, 1));
      b = {float(x[0]), float(x[1]), float(x[2]), float(x[3])};
    } else {
      b = {0.25f, 0.25f, 0.25f, 0.25f};
    }
    projectBarycentric<4>(b);
    quadB_[t] = b;
  }

  // ---- stages ----
  void sample();
  void buildInterfaces();
  void buildWarpStars();    // allStart_/allList_, after buildInterfaces
  void cullExterior();      // cull_ (CleaveParams::cull_exterior), after sample
  void joinAroundCulled(CleaveResult& r) const; // r.exteriorJoins, after the stencil
  void releaseInterfaces(); // after the stencil
  void computeVertexAlphas();
  void phaseVertices();
  void phaseEdges();
  void phaseFaces();
  void generalize();
  void closure();
  CleaveResult stencil();
  void optimizeAngles(TetMesh& out);

  // closure helpers
  std::deque<std::pair<uint8_t, int32_t>> work_;
  std::vector<uint8_t> faceQueued_, tetQueued_;
  void pushFace(int32_t f) {
    if (!faceQueued_[f]) {
      faceQueued_[f] = 1;
      work_.emplace_back(kTriple, f);
    }
  }
  void pushTet(int32_t t) {
    if (!tetQueued_[t]) {
      tetQueued_[t] = 1;
      work_.emplace_back(kQuad, t);
    }
  }
  void cutChanged(int32_t e) {
    for (int64_t i = etStart_[e]; i < etStart_[e + 1]; ++i) {
      const int32_t t = etList_[i];
      pushTet(t);
      for (int lf = 0; lf < 4; ++lf) {
        const int32_t f = tetFace_[t][lf];
        const auto& fv = faceV_[f];
        const auto& ev = edgeV_[e];
        const bool has = (fv[0] == ev[0] || fv[1] == ev[0] || fv[2] == ev[0]) &&
                         (fv[0] == ev[1] || fv[1] == ev[1] || fv[2] == ev[1]);
        if (has) pushFace(f);
      }
    }
  }
  void tripleChanged(int32_t f) {
    pushFace(f);
    for (int64_t i = ftStart_[f]; i < ftStart_[f + 1]; ++i) pushTet(ftList_[i]);
  }
  void checkFace(int32_t f);
  void checkTet(int32_t t);
  void placeVirtualQuad(int32_t t);
  void releaseQuad(int32_t t);
  int32_t faceEdge(int32_t f, int32_t a, int32_t b) const; // edge id of (a,b) in a tet holding f
  // A lattice vertex that did not move onto an interface and carries another material than
  // `owner`: it must not become a corner of owner's tets.
  bool strayVertex(Ref r, int32_t owner) const {
    return r.kind == kVertex && !warped_[r.index] && label_[r.index] != label_[owner];
  }
  // Stencil tets of tet t with quadruple Q and the given view of its face triples that would
  // contain a stray vertex.
  int strayCount(int32_t t, Ref Q, const std::array<Ref, 4>& T) const {
    const auto& q = tv(t);
    int bad = 0;
    for (const Flag& fl : flags_) {
      const Ref V{kVertex, q[fl.v]};
      const Ref C = resolve({kCut, tetEdge_[t][fl.e]});
      const Ref& Tf = T[fl.f];
      if (C == V || Tf == V || Q == V || C == Tf || C == Q || Tf == Q) continue;
      if (strayVertex(C, q[fl.v]) || strayVertex(Tf, q[fl.v]) || strayVertex(Q, q[fl.v])) ++bad;
    }
    return bad;
  }
  bool cutsOnVertices(int32_t t, int lf) const {
    for (int le = 0; le < 6; ++le)
      if (faceHasEdge(lf, le) && resolve({kCut, tetEdge_[t][le]}).kind != kVertex) return false;
    return true;
  }
  // The triple of face lf as tet t sees it.
  Ref tripleSeen(int32_t t, int lf) const {
    const int32_t o = triOverride_[t][lf];
    return o >= 0 ? Ref{kVertex, o} : resolve({kTriple, tetFace_[t][lf]});
  }
};

} // namespace tetflow::cleaving_detail
