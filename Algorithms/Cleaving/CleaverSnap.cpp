// Lattice cleaving, snapping and warping (seed §4.5) and the generalized stencil (see CleaverStages.h).
#include "Algorithms/Cleaving/CleaverStages.h"

namespace tetflow::cleaving_detail {

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
  std::vector<std::pair<int32_t, int32_t>> pulled;
  std::vector<MaterialSample> s;
  int64_t done = 0;
  for (int32_t v = 0; v < nv; ++v) {
    if (vtStart_[v] == vtStart_[v + 1]) continue;
    if (++done % 4096 == 0) {
      progress_.checkCancel();
      progress_.report(double(v) / double(nv)); // the stage is this loop
    }
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
    // The material pairs of the violating cuts (seed §4.7: a cut of the same type as one that
    // caused the warp is pulled into the snap).
    pulled.clear();
    for (const Ref& r : viol)
      if (r.kind == kCut) pulled.push_back(cutPair(r.index));
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
      // With linear points the projection does this by itself (v's values now make the cut
      // fall at v); exact points follow the functions, which need not cross at the centre of
      // mass of several cuts, and an interface of the warp's own type left on an edge next to v
      // pinches a material at v. Only the cuts on v's half of the edge: one nearer the far end
      // is that end's (pulling it too thinned one-voxel sheets to nothing: -60 % against -1.7 %).
      if (exact_ && r.kind == kCut && (edgeV_[r.index][0] == v || edgeV_[r.index][1] == v) &&
          std::find(pulled.begin(), pulled.end(), cutPair(r.index)) != pulled.end() &&
          (edgeV_[r.index][0] == v ? cutT_[r.index] : 1.0f - cutT_[r.index]) < 0.5f) {
        setAlias(r, Ref{kVertex, v});
        ++stats_.snaps;
        return;
      }
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
  progress_.checkCancel();
  for (int32_t f = 0; f < nf; ++f) {
    if ((f & 0xffff) == 0) {
      progress_.checkCancel();
      progress_.report(double(f) / double(nf)); // the bulk of the stage
    }
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

} // namespace tetflow::cleaving_detail
