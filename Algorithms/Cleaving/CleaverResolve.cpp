// Lattice cleaving, resolving degeneracies: virtual quadruples and the closure (see CleaverStages.h).
#include "Algorithms/Cleaving/CleaverStages.h"

namespace tetflow::cleaving_detail {

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
  int64_t popped = 0;
  while (!work_.empty()) {
    progress_.checkCancelEvery(++popped, 16);
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

} // namespace tetflow::cleaving_detail
