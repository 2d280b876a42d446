// Lattice cleaving, angle optimisation of the output (see CleaverStages.h).
#include "Algorithms/Cleaving/CleaverStages.h"
#include "Algorithms/Core/PatternSearch.h"

namespace tetflow::cleaving_detail {

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
    return dihedralScore(out.points[q[0]], out.points[q[1]], out.points[q[2]], out.points[q[3]]);
  };
  const int64_t np = static_cast<int64_t>(out.points.size());
  std::vector<uint8_t> candidate(static_cast<size_t>(np), 0);
  int64_t bad = 0;
  LoopCancel scanCancel(progress_);
#pragma omp parallel for schedule(static) reduction(+ : bad)
  for (int64_t t = 0; t < nt; ++t) {
    if (scanCancel.skip(t)) continue;
    const auto& q = out.tets[t];
    if (tetMin(q) >= kTarget) continue;
    ++bad;
    for (int32_t v : q)
      if (v < nv ? fixedAxes_[v] == 0 : !onBox(out.points[v])) {
        // Tets sharing v may set it on two threads at once (a race ThreadSanitizer reported).
#pragma omp atomic write
        candidate[v] = 1;
      }
  }
  scanCancel.rethrow();
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
  for (int64_t t = 0; t < nt; ++t) {
    progress_.checkCancelEvery(t);
    for (int32_t v : out.tets[t])
      if (slot[v] >= 0) around[slot[v]].push_back(static_cast<int32_t>(t));
  }
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
  // `floor`: stop early (returning -1) once a tet is no better than this. `ts` is the vertex's
  // tets in any order: the one a trial fails on moves to the front, where the next trial most
  // likely fails too. The smallest score is acos of the largest max(cos, -cos) over the tets
  // (acos falls), so acos runs only when that largest value changes. The volumes are summed in
  // `all`'s order, so no decision depends on the order of `ts`.
  auto worst = [&](std::vector<int32_t>& ts, const std::vector<int32_t>& all, double volume, double floor = -1.0) {
    double w = 180.0, c = -2.0;
    for (size_t i = 0; i < ts.size(); ++i) {
      const auto& q = out.tets[ts[i]];
      const Vec3 &a = out.points[q[0]], &b = out.points[q[1]], &d = out.points[q[2]], &e = out.points[q[3]];
      double lo, hi;
      if (signedTetVolume(a, b, d, e) <= 0 || !dihedralCosineRange(a, b, d, e, lo, hi)) {
        std::swap(ts[i], ts[0]);
        return -1.0; // dihedralScore -1: at or below any floor
      }
      const double m = std::max(hi, -lo);
      if (m > c) {
        c = m;
        w = std::min(w, std::acos(std::clamp(c, -1.0, 1.0)) * (180.0 / M_PI));
        if (w <= floor) {
          std::swap(ts[i], ts[0]);
          return -1.0;
        }
      }
    }
    double s = 0;
    for (int32_t t : all) {
      const auto& q = out.tets[t];
      s += signedTetVolume(out.points[q[0]], out.points[q[1]], out.points[q[2]], out.points[q[3]]);
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
      std::vector<int32_t> order = ts;
      double best = worst(order, ts, volume);
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
      PatternSearch search;
      search.dof = tangent ? 2 : alongCurve ? 1 : 3;
      search.dir = tangent ? normal : curveDir;
      search.initialStep = 0.15 * len;
      search.finalStep = 0.005 * len;
      search.maxMove = (tangent || alongCurve) ? 0.1 * len : 0.3 * len;
      search.minGain = 1e-6;
      const Vec3 bestPos = search.run(
          start, best,
          [&](const Vec3& at, double floor) {
            out.points[v] = at;
            return worst(order, ts, volume, floor);
          },
          [](Vec3&) {}, [] {});
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
      LoopCancel cancel(progress_);
#pragma omp parallel reduction(+ : m)
      {
        std::vector<MaterialSample> smp;
#pragma omp for schedule(dynamic, 16)
        for (int64_t k = 0; k < static_cast<int64_t>(batch.size()); ++k) {
          // Polled before every vertex: each is a local search of a few hundred tets.
          if (cancel.skip()) continue;
          m += optimizeOne(batch[k], smp) ? 1 : 0;
        }
      }
      cancel.rethrow();
      moved += m;
      pending.swap(rest);
      progress_.checkCancel();
    }
    stats_.optimizedVertices += moved;
    if (moved == 0) break;
  }
}

} // namespace tetflow::cleaving_detail
