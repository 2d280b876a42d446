#include "VolumeCorrection.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Geometry.h"
#include "Algorithms/Quality/LabelTopology.h"
#include "Algorithms/Quality/TetQuality.h"

namespace tetflow {

uint8_t DomainBox::fixedAxes(const Vec3& p) const {
  if (empty()) return 0;
  const Vec3 d = p - origin;
  uint8_t bits = 0;
  for (int a = 0; a < 3; ++a) {
    const double l = frame[0][a] * d[0] + frame[1][a] * d[1] + frame[2][a] * d[2];
    const double eps = 1e-9 * (hi[a] - lo[a]);
    if (std::abs(l - lo[a]) <= eps || std::abs(l - hi[a]) <= eps) bits |= uint8_t(1u << a);
  }
  return bits;
}

DomainBox domainBoxOf(const TetMesh& bg, const Mat3& frame, const Vec3& origin) {
  DomainBox b;
  b.frame = frame;
  b.origin = origin;
  b.lo = {1e300, 1e300, 1e300};
  b.hi = {-1e300, -1e300, -1e300};
  for (const Vec3& p : bg.points) {
    const Vec3 d = p - origin;
    for (int a = 0; a < 3; ++a) {
      const double l = frame[0][a] * d[0] + frame[1][a] * d[1] + frame[2][a] * d[2];
      b.lo[a] = std::min(b.lo[a], l);
      b.hi[a] = std::max(b.hi[a], l);
    }
  }
  if (bg.points.empty()) b.lo = b.hi = {0, 0, 0};
  return b;
}

namespace {

constexpr int64_t kBlock = 65536;

// Area normal of face f of tet t (half the cross product), pointing out of t.
Vec3 outwardAreaNormal(const TetMesh& m, size_t t, int f) {
  const auto& q = m.tets[t];
  const Vec3& a = m.points[size_t(q[kTetFaceVertices[f][0]])];
  const Vec3& b = m.points[size_t(q[kTetFaceVertices[f][1]])];
  const Vec3& c = m.points[size_t(q[kTetFaceVertices[f][2]])];
  Vec3 n = 0.5 * cross(b - a, c - a);
  if (dot(n, m.points[size_t(q[f])] - a) > 0) n = -1.0 * n;
  return n;
}

struct Quality {
  double mn, mx;
  bool positive;
};
Quality qualityOf(const TetMesh& m, size_t t) {
  const auto& q = m.tets[t];
  const Vec3 &a = m.points[size_t(q[0])], &b = m.points[size_t(q[1])], &c = m.points[size_t(q[2])],
             &d = m.points[size_t(q[3])];
  const auto ang = dihedralAngles(a, b, c, d);
  return {*std::min_element(ang.begin(), ang.end()), *std::max_element(ang.begin(), ang.end()),
          signedTetVolume(a, b, c, d) > 0};
}

} // namespace

VolumeCorrectionStats correctVolumes(TetMesh& mesh, const std::vector<int32_t>& labels,
                                     const std::vector<double>& targets, const DomainBox& box,
                                     const VolumeCorrectionParams& p, Progress& progress,
                                     const std::vector<int32_t>* faceNeighbours) {
  if (labels.size() != targets.size()) throw InputError("volume correction: one target per label is needed");
  if (!(p.tolerance >= 0.0) || !std::isfinite(p.tolerance)) throw InputError("volume correction: tolerance must be >= 0");
  if (p.rounds < 0 || p.rounds > 20) throw InputError("volume correction: rounds must be in [0, 20]");
  progress.beginStage("correct volumes");
  VolumeCorrectionStats st;
  // Nodes: the materials with a target (0..K-1); K = everything else (other labels, nothing).
  std::vector<std::pair<int32_t, int>> order;
  for (size_t i = 0; i < labels.size(); ++i)
    if (targets[i] > 0) order.emplace_back(labels[i], int(i));
  std::sort(order.begin(), order.end());
  const int K = int(order.size());
  std::vector<int32_t> nodeLabel(static_cast<size_t>(K));
  std::vector<double> target(static_cast<size_t>(K));
  for (int k = 0; k < K; ++k) {
    nodeLabel[size_t(k)] = order[size_t(k)].first;
    target[size_t(k)] = targets[size_t(order[size_t(k)].second)];
  }
  st.labels = nodeLabel;
  auto nodeOf = [&](int32_t label) {
    const auto it = std::lower_bound(nodeLabel.begin(), nodeLabel.end(), label);
    return it != nodeLabel.end() && *it == label ? int(it - nodeLabel.begin()) : K;
  };
  const int64_t nt = int64_t(mesh.numTets()), blocks = (nt + kBlock - 1) / kBlock;
  std::vector<int32_t> node(static_cast<size_t>(nt));
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < nt; ++t) node[size_t(t)] = nodeOf(mesh.materials[size_t(t)]);

  auto volumes = [&] {
    std::vector<std::vector<double>> part(static_cast<size_t>(blocks), std::vector<double>(static_cast<size_t>(K) + 1, 0.0));
#pragma omp parallel for schedule(dynamic, 1)
    for (int64_t b = 0; b < blocks; ++b)
      for (int64_t t = b * kBlock; t < std::min(nt, (b + 1) * kBlock); ++t)
        part[size_t(b)][size_t(node[size_t(t)])] += mesh.tetVolume(size_t(t));
    std::vector<double> v(static_cast<size_t>(K), 0.0);
    for (const auto& pb : part)
      for (int k = 0; k < K; ++k) v[size_t(k)] += pb[size_t(k)];
    return v;
  };
  auto relErrors = [&](const std::vector<double>& v) {
    std::vector<double> e(static_cast<size_t>(K));
    for (int k = 0; k < K; ++k) e[size_t(k)] = (v[size_t(k)] - target[size_t(k)]) / target[size_t(k)];
    return e;
  };
  std::vector<double> vol = volumes();
  st.errorBefore = relErrors(vol);
  st.shift.assign(static_cast<size_t>(K), 0.0);
  // Built at the first round that moves anything (connectivity does not change afterwards): the
  // interface faces (tet, face, node pair oriented low -> high, sign of the tet's side), and per
  // vertex the interface faces holding it.
  struct IFace {
    int32_t t;
    int8_t f;
    int8_t flip; // 1 when the tet is on the pair's high side (its outward normal points to low)
    int32_t pair;
  };
  std::vector<IFace> faces;
  std::vector<std::pair<int, int>> pairs;
  std::vector<int64_t> vfStart;
  std::vector<int32_t> vfList;
  std::vector<uint8_t> fixedAxes;
  VertexStars stars;
  const size_t np = mesh.numPoints();
  const double cosMin = std::cos(p.min_angle * M_PI / 180.0), cosMax = std::cos(p.max_angle * M_PI / 180.0);
  auto build = [&] {
    std::vector<int32_t> own;
    if (!faceNeighbours || faceNeighbours->empty()) own = tetFaceNeighbours(mesh, progress);
    const std::vector<int32_t>& nb = faceNeighbours && !faceNeighbours->empty() ? *faceNeighbours : own;
    stars = vertexStars(mesh);
    fixedAxes.resize(np);
#pragma omp parallel for schedule(static)
    for (int64_t v = 0; v < int64_t(np); ++v) fixedAxes[size_t(v)] = box.fixedAxes(mesh.points[size_t(v)]);
    // A face is an interface when it separates two nodes, or is on the boundary but not on the box.
    std::vector<std::vector<IFace>> part(static_cast<size_t>(blocks));
    std::map<std::pair<int, int>, int32_t> pairId;
#pragma omp parallel for schedule(dynamic, 1)
    for (int64_t b = 0; b < blocks; ++b)
      for (int64_t t = b * kBlock; t < std::min(nt, (b + 1) * kBlock); ++t)
        for (int f = 0; f < 4; ++f) {
          const int32_t o = nb[4 * size_t(t) + size_t(f)];
          if (o >= 0 && o < t) continue; // each face once
          int c;
          if (o >= 0) {
            c = node[size_t(o)];
          } else {
            if (o != kNoNeighbour) continue;
            const auto& q = mesh.tets[size_t(t)];
            const uint8_t common = fixedAxes[size_t(q[kTetFaceVertices[f][0]])] &
                                   fixedAxes[size_t(q[kTetFaceVertices[f][1]])] &
                                   fixedAxes[size_t(q[kTetFaceVertices[f][2]])];
            if (common) continue; // on the box
            c = K;
          }
          const int a = node[size_t(t)];
          if (c == a) continue;
          part[size_t(b)].push_back({int32_t(t), int8_t(f), int8_t(a > c ? 1 : 0),
                                     int32_t(std::min(a, c) * (K + 1) + std::max(a, c))});
        }
    for (auto& pb : part) {
      for (IFace& x : pb) {
        const std::pair<int, int> pr{x.pair / (K + 1), x.pair % (K + 1)};
        const auto [it, fresh] = pairId.try_emplace(pr, int32_t(pairs.size()));
        if (fresh) pairs.push_back(pr);
        x.pair = it->second;
      }
      faces.insert(faces.end(), pb.begin(), pb.end());
      std::vector<IFace>().swap(pb);
    }
    vfStart.assign(np + 1, 0);
    for (const IFace& x : faces)
      for (int k = 0; k < 3; ++k) ++vfStart[size_t(mesh.tets[size_t(x.t)][kTetFaceVertices[x.f][k]]) + 1];
    for (size_t v = 0; v < np; ++v) vfStart[v + 1] += vfStart[v];
    vfList.resize(size_t(vfStart[np]));
    std::vector<int64_t> fill(vfStart.begin(), vfStart.end() - 1);
    for (size_t i = 0; i < faces.size(); ++i)
      for (int k = 0; k < 3; ++k) vfList[size_t(fill[size_t(mesh.tets[size_t(faces[i].t)][kTetFaceVertices[faces[i].f][k]])]++)] = int32_t(i);
  };
  std::vector<uint8_t> moved;
  std::vector<Vec3> move;
  for (int round = 0; round < p.rounds && K > 0; ++round) {
    double worst = 0;
    for (int k = 0; k < K; ++k) worst = std::max(worst, std::abs(vol[size_t(k)] - target[size_t(k)]) / target[size_t(k)]);
    if (worst <= p.tolerance) break;
    progress.checkCancel();
    if (vfStart.empty()) build();
    // Interface areas per node pair, summed in face order.
    std::vector<double> pairArea(pairs.size(), 0.0);
    for (const IFace& x : faces) pairArea[size_t(x.pair)] += norm(outwardAreaNormal(mesh, size_t(x.t), x.f));
    // Potentials: sum_M A_LM (phi_L - phi_M) = -(V_L - T_L); node K (and a held node) at 0.
    std::vector<double> areaOf(static_cast<size_t>(K), 0.0);
    bool anchored = false;
    for (size_t i = 0; i < pairs.size(); ++i) {
      const auto [x, y] = pairs[i];
      if (x < K) areaOf[size_t(x)] += pairArea[i];
      if (y < K) areaOf[size_t(y)] += pairArea[i];
      anchored = anchored || y == K;
    }
    int held = -1;
    if (!anchored) {
      held = 0;
      for (int k = 1; k < K; ++k)
        if (target[size_t(k)] > target[size_t(held)]) held = k;
    }
    Eigen::MatrixXd Lm = Eigen::MatrixXd::Zero(K, K);
    Eigen::VectorXd rhs(K);
    for (int k = 0; k < K; ++k) rhs[k] = -(vol[size_t(k)] - target[size_t(k)]);
    for (size_t i = 0; i < pairs.size(); ++i) {
      const auto [x, y] = pairs[i];
      const double a = pairArea[i];
      if (x < K) Lm(x, x) += a;
      if (y < K) Lm(y, y) += a;
      if (x < K && y < K) {
        Lm(x, y) -= a;
        Lm(y, x) -= a;
      }
    }
    for (int k = 0; k < K; ++k)
      if (areaOf[size_t(k)] <= 0 || k == held) { // no interface, or held: phi = 0
        Lm.row(k).setZero();
        Lm.col(k).setZero();
        Lm(k, k) = 1.0;
        rhs[k] = 0.0;
      }
    const Eigen::VectorXd phiK = Lm.ldlt().solve(rhs);
    std::vector<double> phi(static_cast<size_t>(K) + 1, 0.0);
    for (int k = 0; k < K; ++k) phi[size_t(k)] = std::isfinite(phiK[k]) ? phiK[k] : 0.0;
    for (size_t i = 0; i < pairs.size(); ++i) {
      const auto [x, y] = pairs[i];
      const double d = phi[size_t(x)] - phi[size_t(y)];
      if (x < K && areaOf[size_t(x)] > 0) st.shift[size_t(x)] += d * pairArea[i] / areaOf[size_t(x)];
      if (y < K && areaOf[size_t(y)] > 0) st.shift[size_t(y)] -= d * pairArea[i] / areaOf[size_t(y)];
    }
    // Vertex moves: for each interface at the vertex, the displacement phi_low - phi_high along its
    // normal (out of low); least squares over the interfaces.
    move.assign(np, Vec3{0, 0, 0});
    moved.assign(np, 0);
    LoopCancel cancel(progress);
#pragma omp parallel for schedule(dynamic, 4096)
    for (int64_t v = 0; v < int64_t(np); ++v) {
      if (cancel.skip(v)) continue;
      if (vfStart[size_t(v)] == vfStart[size_t(v) + 1] || fixedAxes[size_t(v)] == 7) continue;
      int32_t pid[12];
      Vec3 pn[12];
      int npn = 0;
      for (int64_t i = vfStart[size_t(v)]; i < vfStart[size_t(v) + 1]; ++i) {
        const IFace& x = faces[size_t(vfList[size_t(i)])];
        Vec3 n = outwardAreaNormal(mesh, size_t(x.t), x.f);
        if (x.flip) n = -1.0 * n;
        int w = 0;
        while (w < npn && pid[w] != x.pair) ++w;
        if (w == npn) {
          if (npn == 12) continue;
          pid[npn] = x.pair;
          pn[npn++] = n;
        } else {
          pn[w] = pn[w] + n;
        }
      }
      Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
      Eigen::Vector3d r = Eigen::Vector3d::Zero();
      double wsum = 0;
      for (int w = 0; w < npn; ++w) {
        const double len = norm(pn[w]);
        if (len <= 0) continue;
        const Eigen::Vector3d n(pn[w][0] / len, pn[w][1] / len, pn[w][2] / len);
        const auto [x, y] = pairs[size_t(pid[w])];
        const double d = phi[size_t(x)] - phi[size_t(y)];
        A += len * n * n.transpose();
        r += len * d * n;
        wsum += len;
      }
      if (wsum <= 0) continue;
      A += 1e-6 * wsum * Eigen::Matrix3d::Identity();
      const Eigen::Vector3d u = A.ldlt().solve(r);
      Vec3 m{u[0], u[1], u[2]};
      if (const uint8_t fx = fixedAxes[size_t(v)]) { // stay on the box faces
        Vec3 l{0, 0, 0};
        for (int x = 0; x < 3; ++x)
          if (!(fx >> x & 1)) l[x] = box.frame[0][x] * m[0] + box.frame[1][x] * m[1] + box.frame[2][x] * m[2];
        m = mul(box.frame, l);
      }
      if (!(norm(m) > 0) || !std::isfinite(norm(m))) continue;
      move[size_t(v)] = m;
      moved[size_t(v)] = 1;
    }
    cancel.rethrow();
    for (size_t v = 0; v < np; ++v)
      if (moved[v]) mesh.points[v] = mesh.points[v] + move[v];
    // Undo the moves of the vertices of tets that left the bounds (or went further out of them
    // than they were), until none does. Tets within the bounds after the move need no "before".
    auto tetBad = [&](size_t t) {
      const auto& q = mesh.tets[t];
      const Vec3 &a = mesh.points[size_t(q[0])], &b = mesh.points[size_t(q[1])], &c = mesh.points[size_t(q[2])],
                 &d = mesh.points[size_t(q[3])];
      double lo, hi;
      if (dihedralCosineRange(a, b, c, d, lo, hi) && hi <= cosMin && lo >= cosMax) return false;
      const Quality now = qualityOf(mesh, t);
      if (!now.positive) return true;
      Vec3 o[4];
      for (int k = 0; k < 4; ++k) o[k] = mesh.points[size_t(q[k])] - (moved[size_t(q[k])] ? move[size_t(q[k])] : Vec3{0, 0, 0});
      const auto ang = dihedralAngles(o[0], o[1], o[2], o[3]);
      const double bmn = *std::min_element(ang.begin(), ang.end()), bmx = *std::max_element(ang.begin(), ang.end());
      return now.mn < std::min(bmn, p.min_angle) || now.mx > std::max(bmx, p.max_angle);
    };
    std::vector<int32_t> check; // tets to check: around the moved vertices
    {
      std::vector<uint8_t> mark(static_cast<size_t>(nt), 0);
      for (size_t v = 0; v < np; ++v)
        if (moved[v])
          for (int64_t i = stars.offset[v]; i < stars.offset[v + 1]; ++i) mark[size_t(stars.tets[size_t(i)])] = 1;
      for (int64_t t = 0; t < nt; ++t)
        if (mark[size_t(t)]) check.push_back(int32_t(t));
    }
    for (int pass = 0; pass < 8 && !check.empty(); ++pass) {
      std::vector<uint8_t> bad(check.size(), 0);
#pragma omp parallel for schedule(dynamic, 4096)
      for (int64_t i = 0; i < int64_t(check.size()); ++i) bad[size_t(i)] = tetBad(size_t(check[size_t(i)]));
      std::vector<int32_t> undone;
      for (size_t i = 0; i < check.size(); ++i) {
        if (!bad[i]) continue;
        for (int32_t v : mesh.tets[size_t(check[i])])
          if (moved[size_t(v)]) {
            mesh.points[size_t(v)] = mesh.points[size_t(v)] - move[size_t(v)];
            moved[size_t(v)] = 0;
            undone.push_back(v);
          }
      }
      st.undoneMoves += int64_t(undone.size());
      // Next: the tets around the vertices just put back (their other vertices may still move).
      check.clear();
      for (int32_t v : undone)
        for (int64_t i = stars.offset[size_t(v)]; i < stars.offset[size_t(v) + 1]; ++i) check.push_back(stars.tets[size_t(i)]);
      std::sort(check.begin(), check.end());
      check.erase(std::unique(check.begin(), check.end()), check.end());
    }
    int64_t count = 0;
    for (size_t v = 0; v < np; ++v) count += moved[v];
    st.movedVertices = count;
    if (count == 0) break;
    ++st.rounds;
    vol = volumes();
  }
  st.errorAfter = relErrors(vol);
  progress.endStage();
  return st;
}

void writeVolumeCorrectionReport(const VolumeCorrectionStats& s, Report& r) {
  r.set("volume_correction_rounds", ReportValue(int64_t(s.rounds)));
  r.set("volume_correction_moved_vertices", ReportValue(s.movedVertices));
  r.set("volume_correction_undone_moves", ReportValue(s.undoneMoves));
  for (size_t k = 0; k < s.labels.size(); ++k) {
    const std::string key = "material_" + std::to_string(s.labels[k]) + "_";
    r.set(key + "error_before_correction", ReportValue(s.errorBefore[k]));
    r.set(key + "correction_shift_mm", ReportValue(s.shift[k]));
  }
}

} // namespace tetflow
