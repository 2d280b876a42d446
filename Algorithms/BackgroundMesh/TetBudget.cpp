#include "TetBudget.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Quality/TetQuality.h"

namespace tetflow {

namespace {

std::string show(double x) {
  std::ostringstream o;
  o.precision(3);
  o << x;
  return o.str();
}

std::string labelText(const LabelVolume& labels, int32_t l) {
  const auto it = labels.labelNames.find(l);
  return it != labels.labelNames.end() && !it->second.empty() ? it->second + " (label " + std::to_string(l) + ")"
                                                                : "label " + std::to_string(l);
}

} // namespace

TetCountPrediction predictCleavedTets(const TetMesh& bg, const LabelVolume& labels,
                                      std::optional<int32_t> stripped, Progress& progress) {
  TetCountPrediction p;
  const GridGeometry& g = labels.grid;
  Mat3 toIndex;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) toIndex[r][c] = g.direction[c][r] / g.spacing[r];
  const int64_t nv = int64_t(bg.numPoints()), nt = int64_t(bg.numTets());
  std::vector<int32_t> vl(static_cast<size_t>(nv));
  LoopCancel cancel(progress);
#pragma omp parallel for schedule(static)
  for (int64_t v = 0; v < nv; ++v) {
    if (cancel.skip(v)) continue;
    const Vec3 u = mul(toIndex, bg.points[size_t(v)] - g.origin);
    int64_t i[3];
    for (int x = 0; x < 3; ++x) i[x] = std::clamp<int64_t>(std::llround(u[x]), 0, g.dims[size_t(x)] - 1);
    vl[size_t(v)] = labels.at(i[0], i[1], i[2]);
  }
  cancel.rethrow();
  std::vector<float> edge(static_cast<size_t>(nt));
  int64_t uniform = 0, strip = 0, cut = 0, cutStrip = 0;
  double shortest = 1e300;
#pragma omp parallel for schedule(static) reduction(+ : uniform, strip, cut, cutStrip) reduction(min : shortest)
  for (int64_t t = 0; t < nt; ++t) {
    if (cancel.skip(t)) continue;
    const auto& q = bg.tets[size_t(t)];
    const int32_t a = vl[size_t(q[0])], b = vl[size_t(q[1])], c = vl[size_t(q[2])], d = vl[size_t(q[3])];
    const bool one = a == b && a == c && a == d;
    const bool hasStrip = stripped && (a == *stripped || b == *stripped || c == *stripped || d == *stripped);
    if (one) (hasStrip ? strip : uniform) += 1;
    else (hasStrip ? cutStrip : cut) += 1;
    edge[size_t(t)] = float(longestEdge(bg.points[size_t(q[0])], bg.points[size_t(q[1])], bg.points[size_t(q[2])],
                                        bg.points[size_t(q[3])]));
    shortest = std::min(shortest, double(edge[size_t(t)]));
  }
  cancel.rethrow();
  p.backgroundTets = nt;
  p.uniformTets = uniform;
  p.strippedTets = strip;
  p.cutTets = cut;
  p.cutStrippedTets = cutStrip;
  p.tets = double(uniform) + kCutTets * double(cut) + kCutStrippedTets * double(cutStrip);
  {
    std::map<int32_t, int64_t> perLabel;
    for (const int32_t l : vl) ++perLabel[l];
    p.vertexLabels.assign(perLabel.begin(), perLabel.end());
  }
  if (nt == 0) return p;
  // The finest tets and the labels they hold (sequential: a map per label, deterministic).
  p.finestEdge = shortest;
  std::map<int32_t, int64_t> held;
  const float limit = float(1.5 * shortest);
  for (int64_t t = 0; t < nt; ++t) {
    if (edge[size_t(t)] > limit) continue;
    ++p.finestTets;
    const auto& q = bg.tets[size_t(t)];
    int32_t seen[4];
    int ns = 0;
    for (int k = 0; k < 4; ++k) {
      const int32_t l = vl[size_t(q[k])];
      if (std::find(seen, seen + ns, l) == seen + ns) seen[ns++] = l;
    }
    for (int k = 0; k < ns; ++k) ++held[seen[k]];
  }
  for (const auto& [l, n] : held)
    if (n > p.finestLabelTets && (!stripped || l != *stripped)) {
      p.finestLabel = l;
      p.finestLabelTets = n;
    }
  return p;
}

TetBudgetResult fitTetBudget(const std::function<BackgroundMesh(double)>& build, const LabelVolume& labels,
                             const TetBudgetParams& params, Progress& progress) {
  if (params.maxTets <= 0) throw InputError("max_tets must be > 0 (0 = no budget)");
  TetBudgetResult r;
  double scale = 1.0;
  int stalled = 0;
  std::vector<std::pair<int32_t, int64_t>> asked; // vertices per label with the sizes asked for
  for (;;) {
    BackgroundMesh bg = build(scale);
    TetCountPrediction pred = predictCleavedTets(bg.tets(), labels, params.strippedLabel, progress);
    r.tries.push_back({scale, pred.backgroundTets, pred.tets});
    if (r.tries.size() == 1) {
      asked = pred.vertexLabels;
    } else {
      for (const auto& [l, n] : asked) {
        if (n < kKeptVertices || (params.strippedLabel && l == *params.strippedLabel)) continue;
        const auto it = std::lower_bound(pred.vertexLabels.begin(), pred.vertexLabels.end(), std::pair{l, int64_t(0)});
        const int64_t now = it != pred.vertexLabels.end() && it->first == l ? it->second : 0;
        if (now >= kKeptVertices) continue;
        const double kept = r.tries[r.tries.size() - 2].predicted;
        std::ostringstream m;
        m << "max_tets " << params.maxTets << " cannot be met without losing " << labelText(labels, l) << ": with "
          << params.scaledWhat << " x " << show(scale) << " only " << now
          << " background vertices lie in it (cleaving keeps a label where vertices carry it); the sizes before ("
          << params.scaledWhat << " x " << show(r.tries[r.tries.size() - 2].scale) << ") keep it with about "
          << int64_t(std::ceil(kept)) << " tets; raise max_tets to at least " << int64_t(std::ceil(kept * 1.05));
        throw InputError(m.str());
      }
    }
    if (pred.tets <= double(params.maxTets)) {
      r.background = std::move(bg);
      r.prediction = pred;
      r.scale = scale;
      return r;
    }
    // The same background as the try before (a lattice's cells move in steps of two): a larger
    // step, not a stall.
    const bool same = r.tries.size() >= 2 && r.tries[r.tries.size() - 2].backgroundTets == pred.backgroundTets &&
                      r.tries[r.tries.size() - 2].predicted == pred.tets;
    if (r.tries.size() >= 2 && !same) {
      const double before = r.tries[r.tries.size() - 2].predicted;
      stalled = pred.tets > 0.95 * before ? stalled + 1 : 0;
    }
    const bool atEnd = scale >= params.maxScale * (1 - 1e-9);
    if (stalled >= 3 || atEnd) {
      std::ostringstream m;
      m << "max_tets " << params.maxTets << " cannot be met: with " << params.scaledWhat << " x " << show(scale)
        << " the mesh needs about " << int64_t(std::ceil(pred.tets)) << " tets";
      if (pred.finestLabelTets > 0 && pred.finestTets > 0.05 * double(pred.backgroundTets)) {
        m << ", " << int64_t(100.0 * double(pred.finestTets) / double(pred.backgroundTets))
          << " % of its background in the finest tets (" << show(pred.finestEdge) << " mm edges), which "
          << labelText(labels, pred.finestLabel) << " holds in " << pred.finestLabelTets
          << ": that layer is thinner than the cells and its refinement does not shrink with them; raise max_tets to at least "
          << int64_t(std::ceil(pred.tets * 1.05)) << (params.refinementAdvice.empty() ? "" : ", or " + params.refinementAdvice);
      } else {
        m << "; raise max_tets to at least " << int64_t(std::ceil(pred.tets * 1.05));
      }
      throw InputError(m.str());
    }
    const double grow = same ? 2.0 : std::clamp(std::cbrt(pred.tets / double(params.maxTets)) * 1.02, 1.05, 2.0);
    scale = std::min(params.maxScale, scale * grow);
  }
}

void reportTetPrediction(const TetCountPrediction& p, Report& r) {
  r.set("predicted_tets", ReportValue(int64_t(std::llround(p.tets))));
  r.set("predicted_cut_tets", ReportValue(p.cutTets + p.cutStrippedTets));
}

} // namespace tetflow
