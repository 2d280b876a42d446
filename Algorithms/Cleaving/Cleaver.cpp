#include "Cleaver.h"

#include <Eigen/Dense>
#include <omp.h>
#include <parallel/algorithm>

#include <algorithm>
#include <cmath>
#include <deque>
#include <sstream>
#include <unordered_map>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Quality/TetQuality.h"

namespace tetflow {

namespace {

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

int localEdge(int a, int b) {
  if (a > b) std::swap(a, b);
  for (int e = 0; e < 6; ++e)
    if (kEdgeVerts[e][0] == a && kEdgeVerts[e][1] == b) return e;
  return -1;
}

bool faceHasVertex(int lf, int lv) { return lf != lv; }
bool edgeHasVertex(int le, int lv) { return kEdgeVerts[le][0] == lv || kEdgeVerts[le][1] == lv; }
bool faceHasEdge(int lf, int le) { return !edgeHasVertex(le, lf); }

// The 24 flags (vertex in edge in face) of the generalized stencil, with the corner order that
// gives positive orientation for a positively oriented background tet.
struct Flag {
  int v, e, f;
  bool swapVE; // emit (cut, vertex, triple, quad) instead of (vertex, cut, triple, quad)
};

std::vector<Flag> buildFlags() {
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

double alphaFraction(double a) { return std::clamp(a, 0.0, 0.49); }

class Cleaver {
public:
  Cleaver(const BackgroundMesh& bg, const MaterialSet& mats, const CleaveParams& p, Progress& progress)
      : bg_(bg), m_(bg.mesh), mats_(mats), p_(p), progress_(progress), flags_(buildFlags()) {}

  CleaveResult run();

private:
  // ---- state ----
  const BackgroundMesh& bg_;
  const TetMesh& m_;
  const MaterialSet& mats_;
  const CleaveParams& p_;
  Progress& progress_;
  const std::vector<Flag> flags_;
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
  // All background tets around each vertex (CSR), to keep warps from flattening any of them.
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

  // ---- interface point computation (linear interpolation of sampled values) ----
  void computeCut(int32_t e) {
    const auto& v = edgeV_[e];
    const int32_t la = label_[v[0]], lb = label_[v[1]];
    const double ga = double(value(v[0], la)) - value(v[0], lb);
    const double gb = double(value(v[1], la)) - value(v[1], lb);
    double t;
    if (ga <= 0) t = 0.0;
    else if (gb >= 0) t = 1.0;
    else t = ga / (ga - gb);
    cutT_[e] = static_cast<float>(std::clamp(t, 0.0, 1.0));
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

void Cleaver::computeBoxConstraints() {
  frame_ = mats_.grid().direction;
  const int64_t nv = static_cast<int64_t>(m_.points.size());
  allStart_.assign(static_cast<size_t>(nv) + 1, 0);
  for (const auto& q : m_.tets)
    for (int32_t v : q) ++allStart_[v + 1];
  for (int64_t v = 0; v < nv; ++v) allStart_[v + 1] += allStart_[v];
  allList_.resize(static_cast<size_t>(allStart_[nv]));
  {
    std::vector<int64_t> fill(allStart_.begin(), allStart_.end() - 1);
    for (size_t t = 0; t < m_.tets.size(); ++t)
      for (int32_t v : m_.tets[t]) allList_[fill[v]++] = static_cast<int32_t>(t);
  }
  fixedAxes_.assign(static_cast<size_t>(nv), 0);
  std::vector<Vec3> local(static_cast<size_t>(nv));
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (int64_t v = 0; v < nv; ++v) {
    const Vec3 d = m_.points[v] - mats_.grid().origin;
    for (int a = 0; a < 3; ++a) {
      local[v][a] = frame_[0][a] * d[0] + frame_[1][a] * d[1] + frame_[2][a] * d[2];
      lo[a] = std::min(lo[a], local[v][a]);
      hi[a] = std::max(hi[a], local[v][a]);
    }
  }
  boxLo_ = lo;
  boxHi_ = hi;
  for (int64_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a) {
      const double eps = 1e-9 * (hi[a] - lo[a]);
      if (std::abs(local[v][a] - lo[a]) <= eps || std::abs(local[v][a] - hi[a]) <= eps)
        fixedAxes_[v] |= static_cast<uint8_t>(1u << a);
    }
}

void Cleaver::sample() {
  progress_.beginStage("sample");
  const int64_t nv = static_cast<int64_t>(m_.points.size());
  pos_ = m_.points;
  label_.assign(static_cast<size_t>(nv), 0);
  warped_.assign(static_cast<size_t>(nv), 0);
  std::vector<int64_t> counts(static_cast<size_t>(nv) + 1, 0);
  const int64_t block = 4096;
  const int64_t nBlocks = (nv + block - 1) / block;
  std::vector<std::vector<MaterialSample>> blockSamples(static_cast<size_t>(nBlocks));
#pragma omp parallel
  {
    std::vector<MaterialSample> s;
#pragma omp for schedule(dynamic, 1)
    for (int64_t bi = 0; bi < nBlocks; ++bi) {
      // Cancellation: skip the remaining blocks; the exception is thrown after the parallel
      // region (an exception leaving an OpenMP region would terminate the process).
      if (progress_.cancelRequested()) continue;
      auto& out = blockSamples[static_cast<size_t>(bi)];
      for (int64_t v = bi * block; v < std::min(nv, (bi + 1) * block); ++v) {
        mats_.sample(pos_[v], s);
        label_[v] = dominantMaterial(s);
        counts[v + 1] = static_cast<int64_t>(s.size());
        out.insert(out.end(), s.begin(), s.end());
      }
      if (bi % 64 == 0) progress_.report(double(bi) / double(nBlocks));
    }
  }
  progress_.checkCancel();
  sampleStart_.assign(static_cast<size_t>(nv) + 1, 0);
  for (int64_t v = 0; v < nv; ++v) sampleStart_[v + 1] = sampleStart_[v] + counts[v + 1];
  samples_.clear();
  samples_.reserve(static_cast<size_t>(sampleStart_[nv]));
  for (auto& b : blockSamples) {
    samples_.insert(samples_.end(), b.begin(), b.end());
    std::vector<MaterialSample>().swap(b);
  }
}

void Cleaver::buildInterfaces() {
  progress_.beginStage("interfaces");
  const int64_t nt = static_cast<int64_t>(m_.tets.size());
  bgToInterface_.assign(static_cast<size_t>(nt), -1);
  for (int64_t t = 0; t < nt; ++t) {
    const auto& q = m_.tets[t];
    const int32_t l0 = label_[q[0]];
    if (label_[q[1]] != l0 || label_[q[2]] != l0 || label_[q[3]] != l0) {
      bgToInterface_[t] = static_cast<int32_t>(itet_.size());
      itet_.push_back(static_cast<int32_t>(t));
    }
  }
  const int64_t ni = static_cast<int64_t>(itet_.size());
  stats_.interfaceTets = ni;
  // Unique edges and faces of interface tets.
  std::vector<uint64_t> ekeys(static_cast<size_t>(ni) * 6);
  std::vector<std::array<int32_t, 3>> fkeys(static_cast<size_t>(ni) * 4);
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < ni; ++t) {
    const auto& q = tv(static_cast<int32_t>(t));
    for (int e = 0; e < 6; ++e) {
      uint32_t a = static_cast<uint32_t>(q[kEdgeVerts[e][0]]), b = static_cast<uint32_t>(q[kEdgeVerts[e][1]]);
      if (a > b) std::swap(a, b);
      ekeys[t * 6 + e] = (uint64_t(a) << 32) | b;
    }
    for (int f = 0; f < 4; ++f) {
      std::array<int32_t, 3> k = {q[kFaceVerts[f][0]], q[kFaceVerts[f][1]], q[kFaceVerts[f][2]]};
      std::sort(k.begin(), k.end());
      fkeys[t * 4 + f] = k;
    }
  }
  std::vector<uint64_t> eu = ekeys;
  __gnu_parallel::sort(eu.begin(), eu.end());
  eu.erase(std::unique(eu.begin(), eu.end()), eu.end());
  std::vector<std::array<int32_t, 3>> fu = fkeys;
  __gnu_parallel::sort(fu.begin(), fu.end());
  fu.erase(std::unique(fu.begin(), fu.end()), fu.end());
  edgeV_.resize(eu.size());
  for (size_t e = 0; e < eu.size(); ++e)
    edgeV_[e] = {static_cast<int32_t>(eu[e] >> 32), static_cast<int32_t>(eu[e] & 0xffffffffu)};
  faceV_ = fu;
  tetEdge_.resize(static_cast<size_t>(ni));
  tetFace_.resize(static_cast<size_t>(ni));
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < ni; ++t) {
    for (int e = 0; e < 6; ++e)
      tetEdge_[t][e] = static_cast<int32_t>(std::lower_bound(eu.begin(), eu.end(), ekeys[t * 6 + e]) - eu.begin());
    for (int f = 0; f < 4; ++f)
      tetFace_[t][f] = static_cast<int32_t>(std::lower_bound(fu.begin(), fu.end(), fkeys[t * 4 + f]) - fu.begin());
  }
  std::vector<uint64_t>().swap(ekeys);
  std::vector<std::array<int32_t, 3>>().swap(fkeys);

  // CSR adjacency: vertex -> tets, edge -> tets, face -> tets.
  auto buildCsr = [&](size_t n, int per, auto key, std::vector<int64_t>& start, std::vector<int32_t>& list) {
    start.assign(n + 1, 0);
    for (int64_t t = 0; t < ni; ++t)
      for (int k = 0; k < per; ++k) ++start[static_cast<size_t>(key(t, k)) + 1];
    for (size_t i = 0; i < n; ++i) start[i + 1] += start[i];
    list.resize(static_cast<size_t>(start[n]));
    std::vector<int64_t> fill(start.begin(), start.end() - 1);
    for (int64_t t = 0; t < ni; ++t)
      for (int k = 0; k < per; ++k) list[fill[key(t, k)]++] = static_cast<int32_t>(t);
  };
  buildCsr(m_.points.size(), 4, [&](int64_t t, int k) { return tv(static_cast<int32_t>(t))[k]; }, vtStart_, vtList_);
  buildCsr(edgeV_.size(), 6, [&](int64_t t, int k) { return tetEdge_[t][k]; }, etStart_, etList_);
  buildCsr(faceV_.size(), 4, [&](int64_t t, int k) { return tetFace_[t][k]; }, ftStart_, ftList_);

  // Real interface points.
  const int64_t ne = static_cast<int64_t>(edgeV_.size()), nf = static_cast<int64_t>(faceV_.size());
  cutT_.assign(static_cast<size_t>(ne), 0.5f);
  cutAlias_.assign(static_cast<size_t>(ne), Ref{});
  cutReal_.assign(static_cast<size_t>(ne), 0);
  triB_.assign(static_cast<size_t>(nf), {1.0f / 3, 1.0f / 3, 1.0f / 3});
  triAlias_.assign(static_cast<size_t>(nf), Ref{});
  triReal_.assign(static_cast<size_t>(nf), 0);
  triOverride_.assign(static_cast<size_t>(ni), {-1, -1, -1, -1});
  quadB_.assign(static_cast<size_t>(ni), {0.25f, 0.25f, 0.25f, 0.25f});
  quadAlias_.assign(static_cast<size_t>(ni), Ref{});
  quadReal_.assign(static_cast<size_t>(ni), 0);
  int64_t nc = 0, ntr = 0, nq = 0;
#pragma omp parallel for schedule(static) reduction(+ : nc)
  for (int64_t e = 0; e < ne; ++e)
    if (label_[edgeV_[e][0]] != label_[edgeV_[e][1]]) {
      cutReal_[e] = 1;
      computeCut(static_cast<int32_t>(e));
      ++nc;
    }
#pragma omp parallel for schedule(static) reduction(+ : ntr)
  for (int64_t f = 0; f < nf; ++f) {
    const auto& v = faceV_[f];
    const int32_t a = label_[v[0]], b = label_[v[1]], c = label_[v[2]];
    if (a != b && a != c && b != c) {
      triReal_[f] = 1;
      computeTriple(static_cast<int32_t>(f));
      ++ntr;
    }
  }
#pragma omp parallel for schedule(static) reduction(+ : nq)
  for (int64_t t = 0; t < ni; ++t) {
    const auto& q = tv(static_cast<int32_t>(t));
    const int32_t l[4] = {label_[q[0]], label_[q[1]], label_[q[2]], label_[q[3]]};
    if (l[0] != l[1] && l[0] != l[2] && l[0] != l[3] && l[1] != l[2] && l[1] != l[3] && l[2] != l[3]) {
      quadReal_[t] = 1;
      computeQuad(static_cast<int32_t>(t));
      ++nq;
    }
  }
  stats_.cuts = nc;
  stats_.triples = ntr;
  stats_.quadruples = nq;
  progress_.checkCancel();
}

void Cleaver::computeVertexAlphas() {
  if (!bg_.kind.empty()) return;
  // §5.5.2: alpha_i = (1/2 - xi) * (shortest altitude of the tets around vertex i).
  const int64_t nv = static_cast<int64_t>(m_.points.size());
  std::vector<float> minAlt(static_cast<size_t>(nv), std::numeric_limits<float>::max());
  for (const auto& q : m_.tets) {
    const double vol6 = std::abs(6.0 * signedTetVolume(m_.points[q[0]], m_.points[q[1]], m_.points[q[2]], m_.points[q[3]]));
    double h = std::numeric_limits<double>::max();
    for (int f = 0; f < 4; ++f) {
      const Vec3& a = m_.points[q[kFaceVerts[f][0]]];
      const Vec3& b = m_.points[q[kFaceVerts[f][1]]];
      const Vec3& c = m_.points[q[kFaceVerts[f][2]]];
      const double area2 = norm(cross(b - a, c - a));
      if (area2 > 0) h = std::min(h, vol6 / area2);
    }
    for (int i = 0; i < 4; ++i) minAlt[q[i]] = std::min(minAlt[q[i]], static_cast<float>(h));
  }
  vertexAlpha_.resize(static_cast<size_t>(nv));
  for (int64_t v = 0; v < nv; ++v)
    vertexAlpha_[v] = minAlt[v] == std::numeric_limits<float>::max() ? 0.0f
                                                                      : static_cast<float>((0.5 - p_.xi) * minAlt[v]);
}

void Cleaver::phaseVertices() {
  progress_.beginStage("snap/warp vertices");
  const int64_t nv = static_cast<int64_t>(m_.points.size());
  std::vector<uint8_t> visited(static_cast<size_t>(nv), 0);
  std::vector<int32_t> edgeStamp(edgeV_.size(), -1), faceStamp(faceV_.size(), -1);
  std::vector<Ref> viol;
  std::vector<MaterialSample> s;
  int64_t done = 0;
  for (int32_t v = 0; v < nv; ++v) {
    if (vtStart_[v] == vtStart_[v + 1]) continue;
    if (++done % 4096 == 0) progress_.checkCancel();
    viol.clear();
    const int32_t stampA = 2 * v, stampB = 2 * v + 1;
    forFreePointsAround(v, stampA, edgeStamp, faceStamp, [&](Ref r) {
      int32_t vs[4];
      const int n = simplexOf(r, vs);
      for (int k = 0; k < n; ++k)
        if (vs[k] == v && violatesVertex(r, k)) viol.push_back(r);
    });
    visited[v] = 1;
    if (viol.empty()) continue;
    Vec3 c{0, 0, 0};
    for (const Ref& r : viol) c = c + positionOf(r);
    c = (1.0 / double(viol.size())) * c;
    for (const Ref& r : viol) setAlias(r, Ref{kVertex, v});
    stats_.snaps += static_cast<int64_t>(viol.size());
    pos_[v] = safeWarp(v, constrainWarp(v, c));
    c = pos_[v];
    warped_[v] = 1;
    if (!(c == m_.points[v])) ++stats_.warpedVertices;
    mats_.sample(c, s);
    resampled_[v] = s;
    // Project the remaining interface points around v onto the surfaces at the new position;
    // one that now violates v, or an already visited vertex, snaps to it.
    forFreePointsAround(v, stampB, edgeStamp, faceStamp, [&](Ref r) {
      recompute(r);
      int32_t vs[4];
      const int n = simplexOf(r, vs);
      for (int k = 0; k < n; ++k)
        if ((vs[k] == v || visited[vs[k]]) && violatesVertex(r, k)) {
          setAlias(r, Ref{kVertex, vs[k]});
          ++stats_.snaps;
          break;
        }
    });
  }
}

void Cleaver::phaseEdges() {
  progress_.beginStage("snap edges");
  const int64_t ne = static_cast<int64_t>(edgeV_.size());
  for (int32_t e = 0; e < ne; ++e) {
    if (!cutReal_[e]) continue; // triples and quadruples only lie on faces/tets with real cuts
    for (int64_t i = etStart_[e]; i < etStart_[e + 1]; ++i) {
      const int32_t t = etList_[i];
      const int la = localVertex(t, edgeV_[e][0]), lb = localVertex(t, edgeV_[e][1]);
      for (int lf = 0; lf < 4; ++lf) {
        if (lf == la || lf == lb) continue; // faces containing both ends
        const int32_t f = tetFace_[t][lf];
        if (triReal_[f] && triAlias_[f].none() &&
            triViolates(f, faceMask(f, edgeV_[e][0]) | faceMask(f, edgeV_[e][1]))) {
          triAlias_[f] = Ref{kCut, e};
          ++stats_.snaps;
        }
      }
      if (quadReal_[t] && quadAlias_[t].none() && quadViolates(t, (1u << la) | (1u << lb))) {
        quadAlias_[t] = Ref{kCut, e};
        ++stats_.snaps;
      }
    }
  }
}

void Cleaver::phaseFaces() {
  progress_.beginStage("snap faces");
  const int64_t nf = static_cast<int64_t>(faceV_.size());
  for (int32_t f = 0; f < nf; ++f) {
    if (!triReal_[f]) continue;
    for (int64_t i = ftStart_[f]; i < ftStart_[f + 1]; ++i) {
      const int32_t t = ftList_[i];
      int lf = -1;
      for (int k = 0; k < 4; ++k)
        if (tetFace_[t][k] == f) lf = k;
      const unsigned mask = 0xFu & ~(1u << lf);
      if (quadReal_[t] && quadAlias_[t].none() && quadViolates(t, mask)) {
        quadAlias_[t] = Ref{kTriple, f};
        ++stats_.snaps;
      }
    }
  }
}

int32_t Cleaver::faceEdge(int32_t f, int32_t a, int32_t b) const {
  const int32_t t = ftList_[ftStart_[f]];
  const int la = localVertex(t, a), lb = localVertex(t, b);
  return tetEdge_[t][localEdge(la, lb)];
}

void Cleaver::generalize() {
  progress_.beginStage("generalize");
  const int64_t ne = static_cast<int64_t>(edgeV_.size()), nf = static_cast<int64_t>(faceV_.size());
  // Virtual cuts go to the lower vertex id (§5.5.1).
  for (int64_t e = 0; e < ne; ++e)
    if (!cutReal_[e]) cutAlias_[e] = Ref{kVertex, edgeV_[e][0]};
  // Virtual triples: among the valid locations (a vertex whose two cuts on this face sit on
  // vertices, or any interior cut), choose the one that puts no unwarped lattice vertex into a
  // triangle of another material (such a vertex is not on the interface: §4.10.1), then the
  // lowest dimension, then the most collocated cuts, then the lowest id.
  for (int32_t f = 0; f < nf; ++f) {
    if (triReal_[f]) continue;
    const auto& v = faceV_[f];
    int32_t edges[3][2];
    for (int k = 0; k < 3; ++k) {
      edges[k][0] = faceEdge(f, v[k], v[(k + 1) % 3]);
      edges[k][1] = faceEdge(f, v[k], v[(k + 2) % 3]);
    }
    auto badFor = [&](Ref T) {
      int bad = 0;
      for (int k = 0; k < 3; ++k)
        for (int j = 0; j < 2; ++j) {
          const Ref V{kVertex, v[k]};
          const Ref C = resolve({kCut, edges[k][j]});
          if (C == V || T == V || C == T) continue;
          if (strayVertex(C, v[k]) || strayVertex(T, v[k])) ++bad;
        }
      return bad;
    };
    Ref best{};
    std::array<int64_t, 4> bestKey{};
    auto consider = [&](Ref cand, int64_t dim, int64_t collocated) {
      const std::array<int64_t, 4> key{badFor(cand), dim, -collocated, cand.index};
      if (best.none() || key < bestKey) {
        best = cand;
        bestKey = key;
      }
    };
    for (int k = 0; k < 3; ++k) {
      const Ref c1 = resolve({kCut, edges[k][0]}), c2 = resolve({kCut, edges[k][1]});
      if (c1.kind == kVertex && c2.kind == kVertex)
        consider(Ref{kVertex, v[k]}, 0, (c1.index == v[k]) + (c2.index == v[k]));
    }
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < 2; ++j) {
        const int32_t e = edges[k][j];
        if (resolve({kCut, e}).kind != kCut) continue;
        // Prefer the cut next to where another cut of the face went (Fig. 5.7), real cuts.
        const Ref co = resolve({kCut, edges[k][1 - j]});
        consider(Ref{kCut, e}, 1, (co == Ref{kVertex, v[k]} ? 2 : 0) + (cutReal_[e] ? 1 : 0));
      }
    triAlias_[f] = best;
  }
}

void Cleaver::placeVirtualQuad(int32_t t) {
  const auto& q = tv(t);
  // Valid locations: a vertex whose three faces have their triple there (or are single
  // triangles, viewed with the triple there); an interior cut whose two faces have their triple
  // on it; a free triple. Choose the one with no stray vertex in the stencil, then the lowest
  // dimension, then the lowest id; failing all, a Steiner point at the centroid.
  std::array<Ref, 4> seen;
  for (int lf = 0; lf < 4; ++lf) seen[lf] = tripleSeen(t, lf);
  Ref best{};
  std::array<int32_t, 4> bestOverride{-1, -1, -1, -1};
  std::array<int64_t, 3> bestKey{};
  auto consider = [&](Ref cand, const std::array<Ref, 4>& view, const std::array<int32_t, 4>& ov, int64_t dim) {
    const std::array<int64_t, 3> key{strayCount(t, cand, view), dim, cand.index};
    if (best.none() || key < bestKey) {
      best = cand;
      bestKey = key;
      bestOverride = ov;
    }
  };
  for (int lv = 0; lv < 4; ++lv) {
    const Ref W{kVertex, q[lv]};
    std::array<Ref, 4> view = seen;
    std::array<int32_t, 4> ov = triOverride_[t];
    bool ok = true;
    for (int lf = 0; lf < 4 && ok; ++lf) {
      if (lf == lv || seen[lf] == W) continue;
      ok = seen[lf].kind == kVertex && cutsOnVertices(t, lf);
      view[lf] = W;
      ov[lf] = q[lv];
    }
    if (ok) consider(W, view, ov, 0);
  }
  for (int le = 0; le < 6; ++le) {
    const int32_t e = tetEdge_[t][le];
    const Ref E{kCut, e};
    if (!(resolve(E) == E)) continue;
    bool ok = true;
    for (int lf = 0; lf < 4 && ok; ++lf)
      if (faceHasEdge(lf, le)) ok = seen[lf] == E;
    if (ok) consider(E, seen, triOverride_[t], 1);
  }
  for (int lf = 0; lf < 4; ++lf) {
    const Ref F{kTriple, tetFace_[t][lf]};
    if (seen[lf] == F) consider(F, seen, triOverride_[t], 2);
  }
  if (best.none()) {
    releaseQuad(t);
    return;
  }
  quadAlias_[t] = best;
  triOverride_[t] = bestOverride;
}

void Cleaver::releaseQuad(int32_t t) {
  // Free the quadruple inside its tet: at its computed position when that is well inside,
  // otherwise at the centroid (a Steiner point).
  quadAlias_[t] = Ref{};
  const auto& b = quadB_[t];
  const float minB = std::min(std::min(b[0], b[1]), std::min(b[2], b[3]));
  if (!quadReal_[t] || minB < 0.05f) {
    quadB_[t] = {0.25f, 0.25f, 0.25f, 0.25f};
    ++stats_.steinerPoints;
  }
  quadReal_[t] = 1; // from now on a free point of its own
}

void Cleaver::checkFace(int32_t f) {
  const Ref T = resolve({kTriple, f});
  if (T.kind != kVertex) return;
  const int32_t w = T.index;
  const auto& v = faceV_[f];
  for (int k = 0; k < 3; ++k) {
    if (v[k] == w) continue;
    const int32_t e = faceEdge(f, w, v[k]);
    if (resolve({kCut, e}).kind == kCut) {
      cutAlias_[e] = Ref{kVertex, w};
      ++stats_.degeneracySnaps;
      cutChanged(e);
    }
  }
}

void Cleaver::checkTet(int32_t t) {
  if (!quadReal_[t] && quadAlias_[t].none()) placeVirtualQuad(t);
  const Ref Q = resolve({kQuad, t});
  if (Q.kind == kVertex) {
    const int lv = localVertex(t, Q.index);
    // Every face at w must have its triple at w; triples can move down to w, never across.
    for (int lf = 0; lf < 4; ++lf) {
      if (lf == lv) continue;
      const Ref Tf = tripleSeen(t, lf);
      if (Tf.kind == kVertex && Tf.index != Q.index && !cutsOnVertices(t, lf)) {
        releaseQuad(t);
        return;
      }
    }
    for (int lf = 0; lf < 4; ++lf) {
      if (lf == lv) continue;
      const int32_t f = tetFace_[t][lf];
      const Ref Tf = tripleSeen(t, lf);
      if (Tf == Q) continue;
      if (Tf.kind == kVertex) {
        triOverride_[t][lf] = Q.index; // a single-triangle face: view its triple at w
      } else {
        triAlias_[f] = Q;
        ++stats_.degeneracySnaps;
        tripleChanged(f);
      }
    }
  } else if (Q.kind == kCut) {
    const int la = localVertex(t, edgeV_[Q.index][0]), lb = localVertex(t, edgeV_[Q.index][1]);
    for (int lf = 0; lf < 4; ++lf) {
      if (lf == la || lf == lb) continue;
      const Ref Tf = resolve({kTriple, tetFace_[t][lf]});
      if (Tf.kind != kTriple && !(Tf == Q)) {
        releaseQuad(t);
        return;
      }
    }
    for (int lf = 0; lf < 4; ++lf) {
      if (lf == la || lf == lb) continue;
      const int32_t f = tetFace_[t][lf];
      if (!(resolve({kTriple, f}) == Q)) {
        triAlias_[f] = Q;
        ++stats_.degeneracySnaps;
        tripleChanged(f);
      }
    }
  }
}

void Cleaver::closure() {
  progress_.beginStage("resolve degeneracies");
  faceQueued_.assign(faceV_.size(), 0);
  tetQueued_.assign(itet_.size(), 0);
  for (int32_t f = 0; f < static_cast<int32_t>(faceV_.size()); ++f) pushFace(f);
  for (int32_t t = 0; t < static_cast<int32_t>(itet_.size()); ++t) pushTet(t);
  while (!work_.empty()) {
    const auto [kind, idx] = work_.front();
    work_.pop_front();
    if (kind == kTriple) {
      faceQueued_[idx] = 0;
      checkFace(idx);
    } else {
      tetQueued_[idx] = 0;
      checkTet(idx);
    }
  }
}

CleaveResult Cleaver::stencil() {
  progress_.beginStage("stencil");
  const int64_t nv = static_cast<int64_t>(m_.points.size());
  const int64_t ne = static_cast<int64_t>(edgeV_.size()), nf = static_cast<int64_t>(faceV_.size());
  const int64_t ni = static_cast<int64_t>(itet_.size());
  // Output ids: lattice vertices, then free cuts, triples, quadruples.
  std::vector<int32_t> cutId(static_cast<size_t>(ne), -1), triId(static_cast<size_t>(nf), -1),
      quadId(static_cast<size_t>(ni), -1);
  int64_t next = nv;
  for (int64_t e = 0; e < ne; ++e)
    if (cutAlias_[e].none()) cutId[e] = static_cast<int32_t>(next++);
  for (int64_t f = 0; f < nf; ++f)
    if (triAlias_[f].none()) triId[f] = static_cast<int32_t>(next++);
  for (int64_t t = 0; t < ni; ++t)
    if (quadAlias_[t].none()) quadId[t] = static_cast<int32_t>(next++);
  if (next > (int64_t(1) << 31) - 1) throw ProcessingError("cleaving: too many output vertices");

  CleaveResult r;
  TetMesh& out = r.mesh;
  out.points.resize(static_cast<size_t>(next));
  for (int64_t v = 0; v < nv; ++v) out.points[v] = pos_[v];
  for (int64_t e = 0; e < ne; ++e)
    if (cutId[e] >= 0) out.points[cutId[e]] = positionOf({kCut, static_cast<int32_t>(e)});
  for (int64_t f = 0; f < nf; ++f)
    if (triId[f] >= 0) out.points[triId[f]] = positionOf({kTriple, static_cast<int32_t>(f)});
  for (int64_t t = 0; t < ni; ++t)
    if (quadId[t] >= 0) out.points[quadId[t]] = positionOf({kQuad, static_cast<int32_t>(t)});

  auto idOf = [&](Ref x) -> int32_t {
    x = resolve(x);
    switch (x.kind) {
      case kVertex: return x.index;
      case kCut: return cutId[x.index];
      case kTriple: return triId[x.index];
      case kQuad: return quadId[x.index];
    }
    return -1;
  };
  const int64_t nt = static_cast<int64_t>(m_.tets.size());
  std::vector<int64_t> counts(static_cast<size_t>(nt) + 1, 0);
  // Pass 1: count output tets per background tet; pass 2: fill at the prefix offsets.
  for (int pass = 0; pass < 2; ++pass) {
#pragma omp parallel for schedule(dynamic, 1024)
    for (int64_t b = 0; b < nt; ++b) {
      const auto& q = m_.tets[b];
      const int32_t it = bgToInterface_[b];
      if (it < 0) {
        if (pass == 0) counts[b + 1] = 1;
        else {
          out.tets[counts[b]] = q;
          out.materials[counts[b]] = mats_.labels()[label_[q[0]]];
        }
        continue;
      }
      int64_t k = pass == 0 ? 0 : counts[b];
      const int32_t qid = idOf({kQuad, it});
      for (const Flag& fl : flags_) {
        const int32_t a = q[fl.v];
        const int32_t c = idOf({kCut, tetEdge_[it][fl.e]});
        const int32_t ov = triOverride_[it][fl.f];
        const int32_t tr = ov >= 0 ? ov : idOf({kTriple, tetFace_[it][fl.f]});
        if (a == c || a == tr || a == qid || c == tr || c == qid || tr == qid) continue;
        if (pass == 0) {
          ++k;
        } else {
          out.tets[k] = fl.swapVE ? TetMesh::Tet{c, a, tr, qid} : TetMesh::Tet{a, c, tr, qid};
          out.materials[k] = mats_.labels()[label_[a]];
          ++k;
        }
      }
      if (pass == 0) counts[b + 1] = k;
    }
    if (pass == 0) {
      for (int64_t b = 0; b < nt; ++b) counts[b + 1] += counts[b];
      out.tets.resize(static_cast<size_t>(counts[nt]));
      out.materials.resize(static_cast<size_t>(counts[nt]));
    }
  }
  return r;
}

void Cleaver::optimizeAngles(TetMesh& out) {
  // Lattice vertices that stayed where they were (not warped onto an interface) and are not on
  // the box are corners of tets of their own material only, so moving them changes no material
  // interface and no boundary. Around tets with small dihedral angles, move such vertices to
  // raise the smallest dihedral angle of the tets around them (never below its current value,
  // never inverting a tet).
  progress_.beginStage("optimize angles");
  const int64_t nv = static_cast<int64_t>(m_.points.size());
  const int64_t nt = static_cast<int64_t>(out.tets.size());
  constexpr double kTarget = 12.0; // degrees: tets scoring below this are worked on
  // Score of a tet: its smallest dihedral angle or 180 minus its largest, whichever is worse.
  auto tetMin = [&](const TetMesh::Tet& q) {
    const auto a = dihedralAngles(out.points[q[0]], out.points[q[1]], out.points[q[2]], out.points[q[3]]);
    const auto [lo, hi] = std::minmax_element(a.begin(), a.end());
    return std::min(*lo, 180.0 - *hi);
  };
  const int64_t np = static_cast<int64_t>(out.points.size());
  std::vector<uint8_t> candidate(static_cast<size_t>(np), 0);
  int64_t bad = 0;
#pragma omp parallel for schedule(static) reduction(+ : bad)
  for (int64_t t = 0; t < nt; ++t) {
    const auto& q = out.tets[t];
    if (tetMin(q) >= kTarget) continue;
    ++bad;
    for (int32_t v : q)
      if (v < nv ? fixedAxes_[v] == 0 : !onBox(out.points[v])) candidate[v] = 1;
  }
  if (bad == 0) return;
  // Incident tets of the candidates (one pass over the mesh).
  std::vector<int32_t> slot(static_cast<size_t>(np), -1);
  std::vector<int32_t> cand;
  for (int64_t v = 0; v < np; ++v)
    if (candidate[v]) {
      slot[v] = static_cast<int32_t>(cand.size());
      cand.push_back(static_cast<int32_t>(v));
    }
  std::vector<std::vector<int32_t>> around(cand.size());
  for (int64_t t = 0; t < nt; ++t)
    for (int32_t v : out.tets[t])
      if (slot[v] >= 0) around[slot[v]].push_back(static_cast<int32_t>(t));
  // Smallest dihedral angle around v, or -1 when a tet would not be positive or the tets
  // around v would no longer fill the same region (their volumes must keep their sum: the
  // region is fixed by the vertices around v, so a changed sum means overlap or a gap).
  auto volumeAround = [&](const std::vector<int32_t>& ts) {
    double s = 0;
    for (int32_t t : ts) {
      const auto& q = out.tets[t];
      s += signedTetVolume(out.points[q[0]], out.points[q[1]], out.points[q[2]], out.points[q[3]]);
    }
    return s;
  };
  // `floor`: stop early (returning -1) once a tet is no better than this.
  auto worst = [&](const std::vector<int32_t>& ts, double volume, double floor = -1.0) {
    double w = 180.0, s = 0;
    for (int32_t t : ts) {
      const auto& q = out.tets[t];
      const double vol = signedTetVolume(out.points[q[0]], out.points[q[1]], out.points[q[2]], out.points[q[3]]);
      if (vol <= 0) return -1.0;
      s += vol;
      w = std::min(w, tetMin(q));
      if (w <= floor) return -1.0;
    }
    if (std::abs(s - volume) > 1e-9 * volume) return -1.0;
    return w;
  };
  const auto& labels = mats_.labels();
  auto denseOf = [&](int32_t label) {
    return static_cast<int32_t>(std::find(labels.begin(), labels.end(), label) - labels.begin());
  };
  auto gap = [&](const Vec3& x, int32_t a, int32_t b, std::vector<MaterialSample>& smp) { // f_a - f_b at x
    mats_.sample(x, smp);
    float fa = mats_.absentValue(), fb = mats_.absentValue();
    for (const auto& s : smp) {
      if (s.material == a) fa = s.value;
      if (s.material == b) fb = s.value;
    }
    return double(fa) - double(fb);
  };
  static const Vec3 dirs[] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1},
                              {1, 1, 1}, {-1, -1, -1}, {1, -1, 1}, {-1, 1, -1}, {1, 1, -1}, {-1, -1, 1},
                              {-1, 1, 1}, {1, -1, -1}};
  // Work on the worst first, and bound the work: at most 2 % of the vertices (plus 2000) per pass.
  std::vector<double> candScore(cand.size());
  for (size_t i = 0; i < cand.size(); ++i) {
    double w = 180.0;
    for (int32_t t : around[i]) w = std::min(w, tetMin(out.tets[t]));
    candScore[i] = w;
  }
  std::vector<size_t> order(cand.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return candScore[a] < candScore[b]; });
  const size_t budget = std::min(order.size(), static_cast<size_t>(2000 + np / 50));
  // One vertex: pattern search; returns whether it moved. Runs in parallel on vertices that
  // share no tet (each reads only its own tets).
  auto optimizeOne = [&](size_t i, std::vector<MaterialSample>& smp) -> bool {
      const int32_t v = cand[i];
      const auto& ts = around[i];
      // Unwarped vertices are corners of their own material's tets only: they move freely.
      // Warped vertices between exactly two materials lie on that interface: they move in its
      // tangent plane (normal = gradient of f_a - f_b), so the surface stays where it is to
      // first order. Junctions of three or more materials do not move.
      std::vector<int32_t> matsAround;
      for (int32_t t : ts)
        if (std::find(matsAround.begin(), matsAround.end(), out.materials[t]) == matsAround.end())
          matsAround.push_back(out.materials[t]);
      // Interface points (ids beyond the lattice) follow the same rule: a cut between two
      // materials slides in the interface's tangent plane, a point on a curve where three
      // materials meet slides along that curve, quadruple points stay.
      Vec3 normal{0, 0, 0};
      bool tangent = false, alongCurve = false;
      if (matsAround.size() == 1) {
        if (v < nv && warped_[v]) return false;
      } else if (matsAround.size() == 2) {
        tangent = true;
      } else if (matsAround.size() == 3) {
        alongCurve = true;
      } else {
        return false;
      }
      const double volume = volumeAround(ts);
      double best = worst(ts, volume);
      if (best >= kTarget) return false;
      double len = 0;
      for (int32_t t : ts)
        for (int32_t u : out.tets[t]) len = std::max(len, norm(out.points[u] - out.points[v]));
      const Vec3 start = out.points[v];
      auto gradient = [&](int32_t a, int32_t b) {
        const double hstep = 0.02 * len;
        Vec3 g{0, 0, 0};
        for (int ax = 0; ax < 3; ++ax) {
          Vec3 e{0, 0, 0};
          e[ax] = hstep;
          g[ax] = (gap(start + e, a, b, smp) - gap(start - e, a, b, smp)) / (2 * hstep);
        }
        return g;
      };
      Vec3 curveDir{0, 0, 0};
      if (tangent) {
        normal = gradient(denseOf(matsAround[0]), denseOf(matsAround[1]));
        const double nn = norm(normal);
        if (!(nn > 0)) return false;
        normal = (1.0 / nn) * normal;
      } else if (alongCurve) {
        const int32_t a = denseOf(matsAround[0]);
        curveDir = cross(gradient(a, denseOf(matsAround[1])), gradient(a, denseOf(matsAround[2])));
        const double nn = norm(curveDir);
        if (!(nn > 0)) return false;
        curveDir = (1.0 / nn) * curveDir;
      }
      const double maxMove = (tangent || alongCurve) ? 0.1 * len : 0.3 * len;
      Vec3 bestPos = start;
      for (double step = 0.15 * len; step > 0.005 * len; step *= 0.5) {
        bool improved = true;
        for (int rounds = 0; improved && rounds < 4; ++rounds) {
          improved = false;
          const Vec3 base = bestPos;
          for (const Vec3& d0 : dirs) {
            Vec3 d = d0;
            if (tangent) d = d - dot(d, normal) * normal;
            if (alongCurve) d = dot(d, curveDir) * curveDir;
            if (!(norm(d) > 1e-6)) continue;
            const Vec3 trial = base + (step / norm(d)) * d;
            if (norm(trial - start) > maxMove) continue;
            out.points[v] = trial;
            const double w = worst(ts, volume, best + 1e-6);
            if (w > best + 1e-6) {
              best = w;
              bestPos = out.points[v];
              improved = true;
            }
          }
          out.points[v] = bestPos;
        }
      }
      out.points[v] = bestPos;
      return !(bestPos == start);
  };
  std::vector<int32_t> tetStamp(static_cast<size_t>(nt), -1);
  int32_t stamp = 0;
  for (int pass = 0; pass < 2; ++pass) {
    int64_t moved = 0;
    std::vector<size_t> pending(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(budget));
    while (!pending.empty()) {
      // A batch of candidates sharing no tet, worst first.
      ++stamp;
      std::vector<size_t> batch, rest;
      for (size_t i : pending) {
        bool free = true;
        for (int32_t t : around[i]) free = free && tetStamp[t] != stamp;
        if (!free) {
          rest.push_back(i);
          continue;
        }
        for (int32_t t : around[i]) tetStamp[t] = stamp;
        batch.push_back(i);
      }
      int64_t m = 0;
#pragma omp parallel reduction(+ : m)
      {
        std::vector<MaterialSample> smp;
#pragma omp for schedule(dynamic, 16)
        for (int64_t k = 0; k < static_cast<int64_t>(batch.size()); ++k) m += optimizeOne(batch[k], smp) ? 1 : 0;
      }
      moved += m;
      pending.swap(rest);
      progress_.checkCancel();
    }
    stats_.optimizedVertices += moved;
    if (moved == 0) break;
  }
}

CleaveResult Cleaver::run() {
  if (m_.tets.empty()) throw InputError("cleaving: the background mesh has no tets");
  for (double a : {p_.alpha_short, p_.alpha_long})
    if (!(a >= 0.0 && a < 0.5)) throw InputError("alpha_short and alpha_long must be in [0, 0.5)");
  if (!(p_.xi > 0.0 && p_.xi <= 0.5)) throw InputError("xi must be in (0, 0.5]");
  stats_.backgroundTets = static_cast<int64_t>(m_.tets.size());
  computeBoxConstraints();
  sample();
  buildInterfaces();
  computeVertexAlphas();
  phaseVertices();
  phaseEdges();
  phaseFaces();
  generalize();
  closure();
  CleaveResult r = stencil();
  if (p_.optimize_angles) optimizeAngles(r.mesh);
  progress_.beginStage("finish");
  TetMesh& out = r.mesh;
  // Per-material outcome, then strip_exterior, then drop unused vertices.
  const auto& labels = mats_.labels();
  r.materials.resize(labels.size());
  for (size_t i = 0; i < labels.size(); ++i) {
    r.materials[i].label = labels[i];
    r.materials[i].inputVolume = mats_.inputVolumes()[i];
  }
  const std::vector<MaterialTally> tally = tallyMaterials(out, labels);
  for (size_t i = 0; i < labels.size(); ++i) {
    r.materials[i].tets = tally[i].tets;
    r.materials[i].meshVolume = tally[i].volume;
  }
  if (p_.strip_exterior) {
    size_t w = 0;
    for (size_t t = 0; t < out.tets.size(); ++t)
      if (out.materials[t] != *p_.strip_exterior) {
        out.tets[w] = out.tets[t];
        out.materials[w] = out.materials[t];
        ++w;
      }
    stats_.strippedTets = static_cast<int64_t>(out.tets.size() - w);
    out.tets.resize(w);
    out.materials.resize(w);
    for (auto& mo : r.materials)
      if (mo.label == *p_.strip_exterior) mo.stripped = true;
  }
  std::vector<int32_t> remap(out.points.size(), -1);
  int32_t used = 0;
  for (const auto& q : out.tets)
    for (int32_t v : q)
      if (remap[v] < 0) remap[v] = 0;
  for (size_t v = 0; v < remap.size(); ++v)
    if (remap[v] == 0) remap[v] = used++;
  std::vector<Vec3> pts(static_cast<size_t>(used));
  for (size_t v = 0; v < remap.size(); ++v)
    if (remap[v] >= 0) pts[remap[v]] = out.points[v];
  out.points.swap(pts);
  for (auto& q : out.tets)
    for (auto& v : q) v = remap[v];
  progress_.endStage();
  r.stats = stats_;
  return r;
}

} // namespace

std::vector<MaterialTally> tallyMaterials(const TetMesh& mesh, const std::vector<int32_t>& labels) {
  std::vector<MaterialTally> tally(labels.size());
  const bool sorted = std::is_sorted(labels.begin(), labels.end());
  for (size_t t = 0; t < mesh.numTets(); ++t) {
    const int32_t L = mesh.materials[t];
    const auto it = sorted ? std::lower_bound(labels.begin(), labels.end(), L) : std::find(labels.begin(), labels.end(), L);
    if (it == labels.end() || *it != L) continue;
    auto& e = tally[size_t(it - labels.begin())];
    ++e.tets;
    e.volume += mesh.tetVolume(t);
  }
  return tally;
}

CleaveResult cleave(const BackgroundMesh& background, const MaterialSet& materials,
                    const CleaveParams& params, Progress& progress) {
  Cleaver c(background, materials, params, progress);
  return c.run();
}

void writeCleaveReport(const CleaveResult& r, Report& rep) {
  const CleaveStats& s = r.stats;
  rep.set("tets", ReportValue(int64_t(r.mesh.numTets())));
  rep.set("vertices", ReportValue(int64_t(r.mesh.numPoints())));
  rep.set("background_tets", ReportValue(s.backgroundTets));
  rep.set("interface_tets", ReportValue(s.interfaceTets));
  rep.set("cuts", ReportValue(s.cuts));
  rep.set("triples", ReportValue(s.triples));
  rep.set("quadruples", ReportValue(s.quadruples));
  rep.set("warped_vertices", ReportValue(s.warpedVertices));
  rep.set("snaps", ReportValue(s.snaps));
  rep.set("degeneracy_snaps", ReportValue(s.degeneracySnaps));
  rep.set("steiner_points", ReportValue(s.steinerPoints));
  rep.set("limited_warps", ReportValue(s.limitedWarps));
  rep.set("optimized_vertices", ReportValue(s.optimizedVertices));
  if (s.strippedTets) rep.set("stripped_tets", ReportValue(s.strippedTets));
  std::string present, lost;
  for (const auto& m : r.materials) {
    const std::string key = "material_" + std::to_string(m.label);
    rep.set(key + "_tets", ReportValue(m.tets));
    rep.set(key + "_volume_mm3", ReportValue(m.meshVolume));
    rep.set(key + "_input_mm3", ReportValue(m.inputVolume));
    if (m.lost()) {
      if (!lost.empty()) lost += ' ';
      lost += std::to_string(m.label);
    } else {
      if (!present.empty()) present += ' ';
      present += std::to_string(m.label);
    }
  }
  rep.set("materials_present", present);
  rep.set("materials_lost", lost.empty() ? std::string("none") : lost);
}

} // namespace tetflow
