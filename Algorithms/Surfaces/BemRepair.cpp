// Manifold, nested BEM surfaces by moving the tets around pinch vertices (see BemRepair.h).
#include "Algorithms/Surfaces/BemRepair.h"

#include <algorithm>

namespace tetflow {

namespace {

// Rounds in which a pinch may be filled; later rounds only carve, which shrinks the union every
// round, so the rounds end.
constexpr int kFillRounds = 8;

} // namespace

UnionRepair repairUnion(const TetMesh& mesh, const std::vector<int32_t>& nb, const VertexStars& stars,
                        std::vector<uint8_t>& inside, const std::vector<uint8_t>* enclosing,
                        const TriSurface* enclosingSurface, int maxRounds) {
  const std::vector<uint8_t> before = inside;
  const size_t nP = mesh.points.size();
  // Vertices on the mesh's own boundary: their star is not whole, so filling cannot close them.
  std::vector<uint8_t> onHull(nP, 0);
  for (size_t t = 0; t < mesh.numTets(); ++t)
    for (int f = 0; f < 4; ++f)
      if (nb[4 * t + size_t(f)] < 0)
        for (int k : kTetFaceVertices[f]) onHull[size_t(mesh.tets[t][size_t(k)])] = 1;
  std::vector<uint8_t> onEnclosing;
  if (enclosing) {
    for (size_t t = 0; t < inside.size(); ++t)
      if (!(*enclosing)[t]) inside[t] = 0;
    if (enclosingSurface) {
      onEnclosing.assign(nP, 0);
      for (int32_t v : enclosingSurface->meshVertex) onEnclosing[size_t(v)] = 1;
    }
  }
  auto touchesEnclosing = [&](int32_t v) { return !onEnclosing.empty() && onEnclosing[size_t(v)]; };
  auto star = [&](int32_t v) {
    return std::pair(stars.tets.begin() + stars.offset[size_t(v)], stars.tets.begin() + stars.offset[size_t(v) + 1]);
  };

  UnionRepair r;
  std::vector<int32_t> defective, fill, carve;
  for (int round = 0;; ++round) {
    r.surface = maskBoundary(mesh, inside, nb);
    defective.clear();
    checkSurface(r.surface, &defective);
    std::vector<int32_t> touching;
    for (int32_t v : r.surface.meshVertex)
      if (touchesEnclosing(v)) touching.push_back(v);
    if ((defective.empty() && touching.empty()) || round == maxRounds) {
      r.defectsLeft = int64_t(defective.size());
      r.touchesLeft = int64_t(touching.size());
      break;
    }
    r.pinchesMended += int64_t(defective.size());
    r.touchesMended += int64_t(touching.size());
    fill.clear();
    carve.clear();
    for (int32_t v : touching) {
      auto [b, e] = star(v);
      carve.insert(carve.end(), b, e);
    }
    for (int32_t p : defective) {
      const int32_t v = r.surface.meshVertex[size_t(p)];
      // The star's tets in pieces: face neighbours (across a face through v) of one side join.
      auto [b, e] = star(v);
      const size_t n = size_t(e - b);
      std::vector<int32_t> tet(b, e);
      DisjointSets pieces(n);
      for (size_t i = 0; i < n; ++i)
        for (int f = 0; f < 4; ++f) {
          const int32_t o = nb[4 * size_t(tet[i]) + size_t(f)];
          if (o < 0 || mesh.tets[size_t(tet[i])][size_t(f)] == v || !inside[size_t(o)] != !inside[size_t(tet[i])]) continue;
          const size_t j = size_t(std::lower_bound(tet.begin(), tet.end(), o) - tet.begin());
          if (j < n && tet[j] == o) pieces.unite(int32_t(i), int32_t(j));
        }
      std::vector<double> pieceVolume(n, 0.0);
      double in = 0, out = 0;
      bool canFill = round < kFillRounds && !onHull[size_t(v)];
      for (size_t i = 0; i < n; ++i) {
        const size_t t = size_t(tet[i]);
        const double vol = std::abs(mesh.tetVolume(t));
        pieceVolume[size_t(pieces.find(int32_t(i)))] += vol;
        (inside[t] ? in : out) += vol;
        if (inside[t]) continue;
        if (enclosing && !(*enclosing)[t]) canFill = false;
        if (canFill && !onEnclosing.empty())
          for (int32_t w : mesh.tets[t])
            if (onEnclosing[size_t(w)]) canFill = false;
      }
      // The cheapest of: all of one side but its largest piece (two pieces or more), or all of
      // one side (a figure-eight link, one piece each side).
      auto allButLargest = [&](bool side, double& cost) {
        int32_t largest = -1;
        int pieceCount = 0;
        for (size_t i = 0; i < n; ++i)
          if (bool(inside[size_t(tet[i])]) == side && pieces.find(int32_t(i)) == int32_t(i)) {
            ++pieceCount;
            if (largest < 0 || pieceVolume[i] > pieceVolume[size_t(largest)]) largest = int32_t(i);
          }
        cost = (side ? in : out) - (largest >= 0 ? pieceVolume[size_t(largest)] : 0.0);
        return pieceCount >= 2 ? largest : -2;
      };
      double carveSome = 0, fillSome = 0;
      const int32_t keepIn = allButLargest(true, carveSome), keepOut = allButLargest(false, fillSome);
      struct Choice {
        double cost;
        bool fill;
        int32_t keep; // the piece left as it is, -1: none
      };
      std::vector<Choice> choices{{in, false, -1}};
      if (keepIn != -2) choices.push_back({carveSome, false, keepIn});
      if (canFill) {
        choices.push_back({out, true, -1});
        if (keepOut != -2) choices.push_back({fillSome, true, keepOut});
      }
      const Choice best = *std::min_element(choices.begin(), choices.end(),
                                            [](const Choice& x, const Choice& y) { return x.cost < y.cost; });
      for (size_t i = 0; i < n; ++i) {
        const bool in_i = inside[size_t(tet[i])];
        if (in_i == best.fill || (best.keep >= 0 && pieces.find(int32_t(i)) == best.keep)) continue;
        (best.fill ? fill : carve).push_back(tet[i]);
      }
    }
    for (int32_t t : fill) inside[size_t(t)] = 1;
    for (int32_t t : carve) inside[size_t(t)] = 0;
    ++r.rounds;
  }
  for (size_t t = 0; t < inside.size(); ++t) {
    if (inside[t] == before[t]) continue;
    const double vol = std::abs(mesh.tetVolume(t));
    if (inside[t]) {
      ++r.tetsAdded;
      r.volumeAdded += vol;
    } else {
      ++r.tetsRemoved;
      r.volumeRemoved += vol;
    }
  }
  return r;
}

} // namespace tetflow
