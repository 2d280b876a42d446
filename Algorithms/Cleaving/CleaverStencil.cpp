// Lattice cleaving, the stencil tets (see CleaverStages.h).
#include "Algorithms/Cleaving/CleaverStages.h"

namespace tetflow::cleaving_detail {

CleaveResult Cleaver::stencil() {
  progress_.beginStage("stencil");
  const int64_t nv = static_cast<int64_t>(m_.points.size());
  const int64_t ne = static_cast<int64_t>(edgeV_.size()), nf = static_cast<int64_t>(faceV_.size());
  const int64_t ni = static_cast<int64_t>(itet_.size());
  // Output ids: lattice vertices, then free cuts, triples, quadruples.
  std::vector<int32_t> cutId(static_cast<size_t>(ne), -1), triId(static_cast<size_t>(nf), -1),
      quadId(static_cast<size_t>(ni), -1);
  int64_t next = nv;
  progress_.checkCancel();
  for (int64_t e = 0; e < ne; ++e)
    if (cutAlias_[e].none()) cutId[e] = static_cast<int32_t>(next++);
  for (int64_t f = 0; f < nf; ++f)
    if (triAlias_[f].none()) triId[f] = static_cast<int32_t>(next++);
  for (int64_t t = 0; t < ni; ++t)
    if (quadAlias_[t].none()) quadId[t] = static_cast<int32_t>(next++);
  if (next > (int64_t(1) << 31) - 1) throw ProcessingError("cleaving: too many output vertices");

  progress_.checkCancel();
  CleaveResult r;
  TetMesh& out = r.mesh;
  out.points.resize(static_cast<size_t>(next));
  for (int64_t v = 0; v < nv; ++v) out.points[v] = pos_[v];
  progress_.checkCancel();
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
  progress_.checkCancel();
  const int64_t nt = static_cast<int64_t>(m_.tets.size());
  // Pass 1: count output tets per background tet (at most 24: one byte each); pass 2: fill, each
  // block of background tets from its block's prefix offset (8 bytes per block, not per tet).
  constexpr int64_t kBlock = 1024;
  const int64_t blocks = (nt + kBlock - 1) / kBlock;
  std::vector<uint8_t> count(static_cast<size_t>(nt), 0);
  std::vector<int64_t> blockStart(static_cast<size_t>(blocks) + 1, 0);
  for (int pass = 0; pass < 2; ++pass) {
    progress_.checkCancel();
    LoopCancel cancel(progress_);
#pragma omp parallel for schedule(dynamic, 1)
    for (int64_t blk = 0; blk < blocks; ++blk) {
      if (cancel.skip()) continue;
      int64_t k = blockStart[blk]; // pass 2: where this block's tets go
      int64_t inBlock = 0;         // pass 1: this block's total
      for (int64_t b = blk * kBlock; b < std::min(nt, (blk + 1) * kBlock); ++b) {
        const auto& q = m_.tets[b];
        const int32_t it = bgToInterface_[b];
        if (it < 0) {
          if (!cull_.empty() && cull_[b]) continue; // no output tet
          if (pass == 0) {
            count[b] = 1;
            ++inBlock;
          } else {
            out.tets[k] = q;
            out.materials[k] = mats_.labels()[label_[q[0]]];
            ++k;
          }
          continue;
        }
        if (pass == 1 && count[b] == 0) continue;
        const int32_t qid = idOf({kQuad, it});
        int n = 0;
        for (const Flag& fl : flags_) {
          const int32_t a = q[fl.v];
          const int32_t c = idOf({kCut, tetEdge_[it][fl.e]});
          const int32_t ov = triOverride_[it][fl.f];
          const int32_t tr = ov >= 0 ? ov : idOf({kTriple, tetFace_[it][fl.f]});
          if (a == c || a == tr || a == qid || c == tr || c == qid || tr == qid) continue;
          if (pass == 1) {
            out.tets[k] = fl.swapVE ? TetMesh::Tet{c, a, tr, qid} : TetMesh::Tet{a, c, tr, qid};
            out.materials[k] = mats_.labels()[label_[a]];
            ++k;
          }
          ++n;
        }
        if (pass == 0) {
          count[b] = static_cast<uint8_t>(n);
          inBlock += n;
        }
      }
      if (pass == 0) blockStart[blk + 1] = inBlock;
    }
    cancel.rethrow();
    if (pass == 0) {
      for (int64_t blk = 0; blk < blocks; ++blk) blockStart[blk + 1] += blockStart[blk];
      progress_.checkCancel();
      out.tets.resize(static_cast<size_t>(blockStart[blocks]));
      out.materials.resize(static_cast<size_t>(blockStart[blocks]));
    }
  }
  return r;
}

void Cleaver::joinAroundCulled(CleaveResult& r) const {
  if (cull_.empty()) return;
  const int64_t nv = static_cast<int64_t>(m_.points.size());
  const int64_t nt = static_cast<int64_t>(m_.tets.size());
  // The culled region's connected parts (through shared vertices), as sets of background vertices.
  DisjointSets parts(static_cast<size_t>(nv));
  std::vector<uint8_t> onCulled(static_cast<size_t>(nv), 0);
  for (int64_t t = 0; t < nt; ++t) {
    if (!cull_[t]) continue;
    const auto& q = m_.tets[t];
    for (int32_t v : q) onCulled[v] = 1;
    parts.unite(q[0], q[1]);
    parts.unite(q[0], q[2]);
    parts.unite(q[0], q[3]);
  }
  // The first kept tet at each vertex of the culled region's boundary, chained per part.
  std::vector<int32_t> firstTet(static_cast<size_t>(nv), -1), lastOfPart(static_cast<size_t>(nv), -1);
  const TetMesh& out = r.mesh;
  for (size_t t = 0; t < out.tets.size(); ++t)
    for (int32_t v : out.tets[t])
      if (v < nv && onCulled[v] && firstTet[v] < 0) firstTet[v] = static_cast<int32_t>(t);
  for (int64_t v = 0; v < nv; ++v) {
    if (firstTet[v] < 0) continue;
    int32_t& last = lastOfPart[parts.find(static_cast<int32_t>(v))];
    if (last >= 0 && last != firstTet[v]) r.exteriorJoins.emplace_back(last, firstTet[v]);
    last = firstTet[v];
  }
}

} // namespace tetflow::cleaving_detail
