#include "LabelRepair.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <queue>
#include <set>
#include <unordered_map>
#include <unordered_set>

#include <omp.h>

#include "Algorithms/Core/CancellableSort.h"
#include "Algorithms/Core/Errors.h"
#include "Algorithms/Quality/LabelTopology.h"
#include "Algorithms/Quality/TrackedPieces.h"

namespace tetflow {

namespace {

// Pieces that are no primary piece of an image component may go when smaller than this share of
// the component they vote for (or of their label, voting for none), whatever fragment_voxels says:
// on cells coarser than the voxels, the bits of a thin structure that cleaving cut off are several
// voxels each, and a mesh can only keep such a structure in one piece.
constexpr double kFragmentShare = 0.01;
// Connections: the longest chain of tets of other labels that may join two pieces, and the tets a
// search for one may settle.
constexpr int kMaxChain = 6;
constexpr size_t kMaxSettled = 4096;

struct Allowed {
  std::unordered_set<uint64_t> pairs;
  bool ok(int32_t a, int32_t b) const { return a == b || pairs.count(labelPairKey(a, b)) > 0; }
};

// Adds tet t's faces towards tets of other labels to `border` (neighbour label -> area).
void addBorder(const TetMesh& mesh, const std::vector<int32_t>& nb, int64_t t, std::map<int32_t, double>& border) {
  for (int f = 0; f < 4; ++f) {
    const int32_t o = nb[size_t(4 * t + f)];
    if (o < 0 || mesh.materials[size_t(o)] == mesh.materials[size_t(t)]) continue;
    border[mesh.materials[size_t(o)]] += tetFaceArea(mesh, size_t(t), f);
  }
}

// The label a piece with this border takes when it goes: the neighbouring label it shares the
// most area with, among those allowed next to all its neighbours; none when there is none.
std::optional<int32_t> dissolveInto(const std::map<int32_t, double>& border, const Allowed& allowed) {
  std::optional<int32_t> best;
  double bestArea = 0.0;
  for (const auto& [L, area] : border) {
    bool ok = true;
    for (const auto& [M, unused] : border) ok = ok && allowed.ok(L, M);
    if (ok && area > bestArea) {
      bestArea = area;
      best = L;
    }
  }
  return best;
}

// Value of every material (by label) at p.
std::map<int32_t, float> valuesAt(const MaterialSet& mats, const Vec3& p) {
  std::vector<MaterialSample> s;
  mats.sample(p, s);
  std::map<int32_t, float> v;
  for (int32_t m = 0; m < mats.numMaterials(); ++m) v[mats.labels()[size_t(m)]] = mats.absentValue();
  for (const auto& x : s) v[mats.labels()[size_t(x.material)]] = x.value;
  return v;
}

struct Choice {
  bool forbidden = false; // the tet has a forbidden face
  bool has = false;       // an allowed label exists
  int32_t label = 0;
  double margin = 0.0;    // own value - best allowed value
};

Choice choose(const TetMesh& mesh, const std::vector<int32_t>& nb, const Allowed& allowed,
              const MaterialSet& mats, int64_t t) {
  Choice c;
  const int32_t own = mesh.materials[size_t(t)];
  std::array<int32_t, 4> around{};
  int na = 0;
  for (int f = 0; f < 4; ++f) {
    const int32_t o = nb[size_t(4 * t + f)];
    if (o < 0) continue;
    around[size_t(na++)] = mesh.materials[size_t(o)];
    if (!allowed.ok(own, mesh.materials[size_t(o)])) c.forbidden = true;
  }
  if (!c.forbidden) return c;
  const auto values = valuesAt(mats, tetCentroid(mesh, size_t(t)));
  double best = -std::numeric_limits<double>::infinity();
  for (const auto& [L, v] : values) {
    if (L == own) continue;
    bool ok = true;
    for (int i = 0; i < na; ++i) ok = ok && allowed.ok(L, around[size_t(i)]);
    if (ok && double(v) > best) {
      best = double(v);
      c.has = true;
      c.label = L;
    }
  }
  if (c.has) c.margin = double(values.at(own)) - best;
  return c;
}

// Adds to the entry of a key in a node-based map, keeping the last entry at hand: the tets of a
// piece come in long runs, so most additions skip the lookup. The same sums, added in the same
// order, as looking every key up.
struct RunningSums {
  std::unordered_map<uint64_t, double>& map;
  uint64_t key = 0;
  double* at = nullptr;
  void add(uint64_t k, double v) {
    if (!at || k != key) {
      at = &map[k];
      key = k;
    }
    *at += v;
  }
};

// The voting volume of every (piece, image component): key root << 32 | component.
std::unordered_map<uint64_t, double> pieceVoteSums(const TetMesh& mesh, const std::vector<double>& size,
                                                   DisjointSets& sets, const std::vector<int32_t>& vote) {
  std::unordered_map<uint64_t, double> votes;
  RunningSums sums{votes};
  for (size_t t = 0; t < mesh.numTets(); ++t)
    if (vote[t] >= 0)
      sums.add((uint64_t(uint32_t(sets.find(int32_t(t)))) << 32) | uint32_t(vote[t]), size[t]);
  return votes;
}

// Per root (from the sums of pieceVoteSums): 1 when the piece is a primary piece of an image
// component: the one with the most voting volume (ties to the smaller root), or with `keepCores`,
// the max(1, cores) pieces with the most (a component may be in as many pieces as it has cores). `pairs`, when given,
// receives the (image component << 32 | root) of every primary piece.
std::vector<uint8_t> primaryPiecesOf(const std::unordered_map<uint64_t, double>& pieceVotes, size_t nTets,
                                     const LabelImageTopology* keepCores = nullptr,
                                     std::unordered_set<uint64_t>* pairs = nullptr) {
  std::vector<std::pair<uint64_t, double>> sorted; // (image comp << 32 | root, volume)
  sorted.reserve(pieceVotes.size());
  for (const auto& [k, v] : pieceVotes) sorted.push_back({(k << 32) | (k >> 32), v});
  std::sort(sorted.begin(), sorted.end());
  std::vector<uint8_t> primary(nTets, 0);
  for (size_t i = 0; i < sorted.size();) {
    size_t j = i;
    while (j < sorted.size() && (sorted[j].first >> 32) == (sorted[i].first >> 32)) ++j;
    const int32_t comp = int32_t(sorted[i].first >> 32);
    const size_t keep = keepCores ? size_t(std::max(1, keepCores->comps[size_t(comp)].cores)) : 1;
    std::vector<size_t> order(j - i);
    for (size_t k = 0; k < order.size(); ++k) order[k] = i + k;
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return sorted[a].second > sorted[b].second; });
    for (size_t k = 0; k < std::min(keep, order.size()); ++k) {
      primary[size_t(uint32_t(sorted[order[k]].first))] = 1;
      if (pairs) pairs->insert(sorted[order[k]].first);
    }
    i = j;
  }
  return primary;
}

// The same, one primary piece per component, from the tets' votes.
std::vector<uint8_t> primaryPieces(const TetMesh& mesh, const std::vector<double>& size, DisjointSets& sets,
                                   const std::vector<int32_t>& vote) {
  return primaryPiecesOf(pieceVoteSums(mesh, size, sets, vote), mesh.numTets());
}

void countForbidden(const TetMesh& mesh, const std::vector<int32_t>& nb, const Allowed& allowed, int64_t& faces,
                    double& area) {
  // Fixed blocks summed in order: the same total for any thread count.
  constexpr int64_t kBlock = 65536;
  const int64_t n = static_cast<int64_t>(mesh.numTets()), blocks = (n + kBlock - 1) / kBlock;
  std::vector<int64_t> count(size_t(blocks), 0);
  std::vector<double> sum(size_t(blocks), 0.0);
#pragma omp parallel for schedule(dynamic, 4)
  for (int64_t b = 0; b < blocks; ++b)
    for (int64_t t = b * kBlock; t < std::min(n, (b + 1) * kBlock); ++t)
      for (int f = 0; f < 4; ++f) {
        const int32_t o = nb[size_t(4 * t + f)];
        if (o <= t || allowed.ok(mesh.materials[size_t(t)], mesh.materials[size_t(o)])) continue;
        ++count[size_t(b)];
        sum[size_t(b)] += tetFaceArea(mesh, size_t(t), f);
      }
  faces = 0;
  area = 0.0;
  for (int64_t b = 0; b < blocks; ++b) {
    faces += count[size_t(b)];
    area += sum[size_t(b)];
  }
}

// Tets with a forbidden face (ascending).
std::vector<int64_t> forbiddenTets(const TetMesh& mesh, const std::vector<int32_t>& nb, const Allowed& allowed) {
  const int64_t n = static_cast<int64_t>(mesh.numTets());
  std::vector<uint8_t> bad(size_t(n), 0);
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < n; ++t)
    for (int f = 0; f < 4; ++f) {
      const int32_t o = nb[size_t(4 * t + f)];
      if (o >= 0 && !allowed.ok(mesh.materials[size_t(t)], mesh.materials[size_t(o)])) bad[size_t(t)] = 1;
    }
  std::vector<int64_t> out;
  for (int64_t t = 0; t < n; ++t)
    if (bad[size_t(t)]) out.push_back(t);
  return out;
}

// The chain of up to kMaxChain tets, none of label L and none in the piece, from a face of the
// piece's tets to a tet for which target() holds, with the least volume: Dijkstra over at most
// kMaxSettled tets (ties to the smaller tet index), each step allowed by fits(tet, the chain's tet
// before it or -1, the one after it). Empty when there is none.
template <class InPiece, class Target, class Fits>
std::vector<int32_t> leastVolumeChain(const TetMesh& mesh, const std::vector<int32_t>& nb,
                                      const std::vector<int64_t>& piece, int32_t L, InPiece&& inPiece,
                                      Target&& target, Fits&& fits) {
  struct Reached {
    double dist;
    int32_t pred;
    int depth;
  };
  auto open = [&](int32_t b) { return b >= 0 && mesh.materials[size_t(b)] != L && !inPiece(b); };
  std::unordered_map<int32_t, Reached> reached;
  using Item = std::pair<double, int32_t>; // (volume so far, tet): least volume first, then index
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  for (int64_t t : piece)
    for (int f = 0; f < 4; ++f) {
      const int32_t a = nb[size_t(4 * t + f)];
      if (!open(a)) continue;
      const double v = std::abs(mesh.tetVolume(size_t(a)));
      const auto it = reached.find(a);
      if (it != reached.end() && it->second.dist <= v) continue;
      reached[a] = {v, -1, 1};
      queue.push({v, a});
    }
  std::unordered_set<int32_t> settled;
  while (!queue.empty() && settled.size() < kMaxSettled) {
    const auto [d, a] = queue.top();
    queue.pop();
    if (!settled.insert(a).second) continue;
    const Reached here = reached.at(a);
    for (int f = 0; f < 4; ++f) {
      const int32_t b = nb[size_t(4 * a + f)];
      if (b < 0 || !target(b) || !fits(a, here.pred, b)) continue;
      std::vector<int32_t> path;
      for (int32_t q = a; q >= 0; q = reached.at(q).pred) path.push_back(q);
      return path;
    }
    if (here.depth == kMaxChain) continue;
    for (int f = 0; f < 4; ++f) {
      const int32_t b = nb[size_t(4 * a + f)];
      if (!open(b) || settled.count(b)) continue;
      const double nd = d + std::abs(mesh.tetVolume(size_t(b)));
      const auto it = reached.find(b);
      if ((it != reached.end() && it->second.dist <= nd) || !fits(a, here.pred, b)) continue;
      reached[b] = {nd, a, here.depth + 1};
      queue.push({nd, b});
    }
  }
  return {};
}

// What every step works on.
struct Steps {
  TetMesh& mesh;
  const MaterialSet& materials;
  const LabelRepairParams& params;
  Progress& progress;
  LabelRepairStats& st;
  const LabelVolume& labels;
  const LabelImageTopology& img;
  const Allowed& allowed;
  const std::vector<int32_t>& nb;
  int64_t n;
  IndexFrame frame;
  const VertexStars* stars = nullptr; // the mesh's vertex stars when already built (else built where needed)
  const TetJoins* joins = nullptr;    // pieces joined through a part left out (repairLabels)
  // Per tet, |volume| (the geometry stays as it is): for the connections and the fragments.
  const std::vector<double>* size = nullptr;
  // The same-label pieces, round after round (the connections and the fragments).
  TrackedPieces* pieces = nullptr;
};

// Gives tet t label L; its volume counts as relabelled, and its vote (`vote`: per tet, the image
// component at its centroid when that voxel carries the tet's label) follows the new label.
void relabel(Steps& s, std::vector<int32_t>& vote, int64_t t, int32_t L) {
  s.st.relabelledVolume += std::abs(s.mesh.tetVolume(size_t(t)));
  s.mesh.materials[size_t(t)] = L;
  vote[size_t(t)] = voteImageComponent(s.labels, s.img.comp, s.frame.toIndex(tetCentroid(s.mesh, size_t(t))), L);
}

void repairContacts(Steps& s) {
  // Named references (clang 14 cannot capture structured bindings in lambdas).
  auto& mesh = s.mesh;
  auto& materials = s.materials;
  auto& progress = s.progress;
  auto& st = s.st;
  auto& allowed = s.allowed;
  auto& nb = s.nb;
  using Item = std::pair<double, int64_t>; // (margin, tet): smallest margin first, then index
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  for (int64_t t : forbiddenTets(mesh, nb, allowed)) {
    const Choice c = choose(mesh, nb, allowed, materials, t);
    if (c.has) queue.push({c.margin, t});
  }
  int64_t steps = 0;
  while (!queue.empty()) {
    const auto [margin, t] = queue.top();
    queue.pop();
    if ((++steps & 1023) == 0) progress.checkCancel();
    const Choice c = choose(mesh, nb, allowed, materials, t);
    if (!c.forbidden || !c.has) continue;
    if (c.margin > margin + 1e-12) { // its neighbourhood changed: wait for its turn
      queue.push({c.margin, t});
      continue;
    }
    st.relabelledVolume += std::abs(mesh.tetVolume(size_t(t)));
    mesh.materials[size_t(t)] = c.label;
    ++st.contactTets;
    for (int f = 0; f < 4; ++f) {
      const int32_t o = nb[size_t(4 * t + f)];
      if (o < 0) continue;
      const Choice d = choose(mesh, nb, allowed, materials, o);
      if (d.forbidden && d.has) queue.push({d.margin, o});
    }
  }
  st.unresolvedTets = static_cast<int64_t>(forbiddenTets(mesh, nb, allowed).size());
}

void repairPointContacts(Steps& s) {
  // Named references (clang 14 cannot capture structured bindings in lambdas).
  auto& mesh = s.mesh;
  auto& materials = s.materials;
  auto& progress = s.progress;
  auto& st = s.st;
  auto& allowed = s.allowed;
  auto& nb = s.nb;
  progress.beginStage("repair point contacts");
  const size_t nP = mesh.numPoints();
  VertexStars own; // relabelling leaves the stars as they are: the caller's serve when it has them
  if (!s.stars) own = vertexStars(mesh);
  const VertexStars& stars = s.stars ? *s.stars : own;
  const std::vector<int64_t>& off = stars.offset;
  const std::vector<int32_t>& star = stars.tets;
  for (int round = 0; round < 4; ++round) {
    progress.checkCancel();
    int64_t fixed = 0;
    for (size_t p = 0; p < nP; ++p) {
      const int32_t* first = star.data() + off[p];
      const int64_t k = off[p + 1] - off[p];
      // Labels in the star, and a forbidden pair among them.
      std::array<int32_t, 64> seen{};
      int ns = 0;
      for (int64_t a = 0; a < k && ns < 64; ++a) {
        const int32_t L = mesh.materials[size_t(first[a])];
        if (std::find(seen.begin(), seen.begin() + ns, L) == seen.begin() + ns) seen[size_t(ns++)] = L;
      }
      int32_t la = 0, lb = 0;
      bool forbidden = false;
      for (int x = 0; x < ns && !forbidden; ++x)
        for (int y = x + 1; y < ns && !forbidden; ++y)
          if (!allowed.ok(seen[size_t(x)], seen[size_t(y)])) {
            forbidden = true;
            la = seen[size_t(x)];
            lb = seen[size_t(y)];
          }
      if (!forbidden) continue;
      // Relabel the smaller side's tets in the star (the other side if that fails), each to the
      // label with the largest indicator at its centroid that may touch every label left in the
      // star and every face neighbour.
      int64_t na = 0, nb2 = 0;
      for (int64_t a = 0; a < k; ++a) {
        na += mesh.materials[size_t(first[a])] == la ? 1 : 0;
        nb2 += mesh.materials[size_t(first[a])] == lb ? 1 : 0;
      }
      for (int32_t side : na <= nb2 ? std::array<int32_t, 2>{la, lb} : std::array<int32_t, 2>{lb, la}) {
        std::vector<std::pair<int32_t, int32_t>> plan; // (tet, new label)
        bool ok = true;
        for (int64_t a = 0; a < k && ok; ++a) {
          const int32_t t = first[a];
          if (mesh.materials[size_t(t)] != side) continue;
          const auto values = valuesAt(materials, tetCentroid(mesh, size_t(t)));
          double best = -std::numeric_limits<double>::infinity();
          int32_t pick = side;
          for (const auto& [L, v] : values) {
            if (L == side) continue;
            bool fits = true;
            for (int x = 0; x < ns && fits; ++x)
              if (seen[size_t(x)] != side) fits = allowed.ok(L, seen[size_t(x)]);
            for (int f = 0; f < 4 && fits; ++f) {
              const int32_t o = nb[size_t(4 * t + f)];
              if (o >= 0) fits = allowed.ok(L, mesh.materials[size_t(o)]);
            }
            if (fits && double(v) > best) {
              best = double(v);
              pick = L;
            }
          }
          if (pick == side) ok = false;
          else plan.push_back({t, pick});
        }
        if (!ok || plan.empty()) continue;
        for (const auto& [t, L] : plan) {
          st.relabelledVolume += std::abs(mesh.tetVolume(size_t(t)));
          mesh.materials[size_t(t)] = L;
          ++st.pointTets;
        }
        ++fixed;
        break;
      }
    }
    st.pointContacts += fixed;
    if (fixed == 0) break;
  }
}

// The volume [mm^3] below which a piece that is not primary for image component c may go (the
// fragments step): fragment_voxels voxels, or kFragmentShare of the component.
double fragmentLimit(const LabelImageTopology& img, int32_t c, double fragmentVoxels, double voxel) {
  return std::max(fragmentVoxels * voxel, kFragmentShare * double(img.comps[size_t(c)].voxels) * voxel);
}

// `lastingOnly`: only the pieces the fragments step would keep (at least their component's
// fragment limit, of a component with a core): the pass after the edges step, which may cut a
// thin piece off again where it closes a non-manifold edge; what it cuts off below the limit the
// fragments step removes, as before.
void repairConnections(Steps& s, bool lastingOnly = false) {
  // Named references (clang 14 cannot capture structured bindings in lambdas).
  auto& mesh = s.mesh;
  auto& progress = s.progress;
  auto& st = s.st;
  auto& labels = s.labels;
  auto& img = s.img;
  auto& allowed = s.allowed;
  auto& nb = s.nb;
  auto& n = s.n;
  const std::vector<double>& size = *s.size;
  progress.beginStage("repair connections");
  std::vector<int32_t> vote = tetVotes(mesh, labels, img.comp);
  // Where no one- or two-tet path joins a piece: a chain (leastVolumeChain) whose tets may all take
  // label L: each one's faces off the chain allowed next to L, and no face on a tet of L outside
  // the piece and its targets (that would merge a piece of another component). A voxel component
  // joined only through voxel edges or corners (26-connected, as the certificate counts) has no
  // face-connected tets voting for it between its parts; the chain takes the fewest other tets'
  // volume instead. Empty when there is none.
  auto chain = [&](const std::vector<int64_t>& piece, int32_t L, int32_t me, auto&& target,
                   DisjointSets& sets) -> std::vector<int32_t> {
    auto fits = [&](int32_t a, int32_t pred, int32_t succ) {
      for (int f = 0; f < 4; ++f) {
        const int32_t o = nb[size_t(4 * a + f)];
        if (o < 0 || o == pred || o == succ) continue;
        const int32_t M = mesh.materials[size_t(o)];
        if (M == L ? sets.find(o) != me && !target(o) : !allowed.ok(L, M)) return false;
      }
      return true;
    };
    return leastVolumeChain(mesh, nb, piece, L, [](int32_t) { return false; }, target, fits);
  };
  // Rounds of one- and two-tet paths until nothing joins (at most 8). Then the pieces left that the
  // fragments step would keep (at least their component's fragment limit, of a component with a
  // core: the ones the certificate would count as a split) may lay chains, in that round and the
  // ones after it (8 rounds in all).
  bool chains = false;
  for (int round = 0; round < 8; ++round) {
    progress.checkCancel();
    DisjointSets sets = s.pieces->now();
    progress.checkCancel();
    // The primary piece of every image component, then the other pieces that vote for one, with
    // their tets, the components they vote for, their volume and their voting volume by component.
    const std::vector<uint8_t> primary = primaryPieces(mesh, size, sets, vote);
    progress.checkCancel();
    std::map<int32_t, std::vector<int64_t>> tetsOf;
    std::map<int32_t, std::set<int32_t>> compsOf;
    std::map<int32_t, double> volumeOf;
    std::map<int32_t, std::map<int32_t, double>> votesOf;
    for (int64_t t = 0; t < n; ++t) {
      progress.checkCancelEvery(t);
      const int32_t r = sets.find(int32_t(t));
      if (primary[size_t(r)]) continue;
      const double v = size[size_t(t)];
      volumeOf[r] += v;
      if (vote[size_t(t)] < 0) continue;
      compsOf[r].insert(vote[size_t(t)]);
      tetsOf[r].push_back(t);
      votesOf[r][vote[size_t(t)]] += v;
    }
    auto lasting = [&](int32_t root) {
      int32_t c = -1;
      double most = -1.0;
      for (const auto& [comp, v] : votesOf[root])
        if (v > most) {
          most = v;
          c = comp;
        }
      return img.comps[size_t(c)].cores > 0 &&
             volumeOf[root] >= fragmentLimit(img, c, s.params.fragment_voxels, labels.grid.voxelVolume());
    };
    // Joins the piece to another piece of its component, if a path is found: one or two tets, or
    // (withChain) a chain.
    auto tryJoin = [&](int32_t root, const std::vector<int64_t>& tets, bool withChain) {
      const int32_t L = mesh.materials[size_t(tets.front())];
      const int32_t me = sets.find(root);
      const std::set<int32_t>& comps = compsOf[root];
      // Does tet q (label L) belong to another piece of one of our image components?
      auto target = [&](int32_t q) {
        return mesh.materials[size_t(q)] == L && sets.find(q) != me && vote[size_t(q)] >= 0 &&
               comps.count(vote[size_t(q)]) > 0;
      };
      auto allowedAs = [&](int32_t t, int32_t skip) {
        for (int f = 0; f < 4; ++f) {
          const int32_t o = nb[size_t(4 * t + f)];
          if (o >= 0 && o != skip && !allowed.ok(L, mesh.materials[size_t(o)])) return false;
        }
        return true;
      };
      // Paths of one or two tets of other labels from this piece to another one, tet by tet of
      // the piece (ascending), one-tet paths first.
      std::vector<int32_t> path;
      for (int64_t t : tets) {
        for (int f = 0; f < 4 && path.empty(); ++f) {
          const int32_t a = nb[size_t(4 * t + f)];
          if (a < 0 || mesh.materials[size_t(a)] == L) continue;
          for (int g2 = 0; g2 < 4 && path.empty(); ++g2) {
            const int32_t b = nb[size_t(4 * a + g2)];
            if (b >= 0 && target(b) && allowedAs(a, -1)) path = {a};
          }
          for (int g2 = 0; g2 < 4 && path.empty(); ++g2) {
            const int32_t b = nb[size_t(4 * a + g2)];
            if (b < 0 || mesh.materials[size_t(b)] == L) continue;
            for (int h = 0; h < 4 && path.empty(); ++h) {
              const int32_t c = nb[size_t(4 * b + h)];
              if (c >= 0 && target(c) && allowedAs(a, b) && allowedAs(b, a)) path = {a, b};
            }
          }
        }
        if (!path.empty()) break;
      }
      if (path.empty() && withChain) path = chain(tets, L, me, target, sets);
      if (path.empty()) return false;
      if (path.size() > 2) ++st.chainConnections;
      for (int32_t q : path) {
        relabel(s, vote, q, L);
        ++st.connectTets;
        for (int f = 0; f < 4; ++f) {
          const int32_t o = nb[size_t(4 * q + f)];
          if (o >= 0 && mesh.materials[size_t(o)] == L) sets.unite(q, o);
        }
      }
      return true;
    };
    int64_t joined = 0;
    std::vector<int32_t> failed; // lasting pieces no short path joined
    for (const auto& [root, tets] : tetsOf) {
      if (lastingOnly && !lasting(root)) continue;
      if (tryJoin(root, tets, false)) ++joined;
      else if (lasting(root)) failed.push_back(root);
    }
    if (joined == 0 || chains) {
      chains = true;
      for (int32_t root : failed) joined += tryJoin(root, tetsOf[root], true) ? 1 : 0;
    }
    st.connections += joined;
    if (joined == 0) break;
    ++st.connectRounds;
  }
}

void repairEdges(Steps& s) {
  // Named references (clang 14 cannot capture structured bindings in lambdas).
  auto& mesh = s.mesh;
  auto& progress = s.progress;
  auto& st = s.st;
  auto& allowed = s.allowed;
  auto& nb = s.nb;
  auto& n = s.n;
  progress.beginStage("repair edges");
  // Rings of tets around every edge that lies in faces of two or more labels.
  static constexpr int kEdgeEnds[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  auto edgeKey = [&](int32_t t, const int (&e)[2]) {
    const auto& q = mesh.tets[size_t(t)];
    const int32_t a = std::min(q[size_t(e[0])], q[size_t(e[1])]), b = std::max(q[size_t(e[0])], q[size_t(e[1])]);
    return (uint64_t(uint32_t(a)) << 32) | uint32_t(b);
  };
  // The edges looked at are those of tets with a face on another label when the step starts (an
  // edge in faces of two or more labels is an edge of such a tet), each with the ring of tets
  // around it walked from the smallest such tet (ringOf): found through the vertex stars, from the
  // edge's smaller end.
  std::vector<uint8_t> mixed(size_t(n), 0);
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < n; ++t)
    for (int f = 0; f < 4; ++f) {
      const int32_t o = nb[size_t(4 * t + f)];
      if (o >= 0 && mesh.materials[size_t(o)] != mesh.materials[size_t(t)]) mixed[size_t(t)] = 1;
    }
  progress.checkCancel();
  VertexStars own; // relabelling leaves the stars as they are: the caller's serve when it has them
  if (!s.stars) own = vertexStars(mesh);
  const VertexStars& stars = s.stars ? *s.stars : own;
  auto hasVertex = [&](int32_t t, int32_t v) {
    const auto& q = mesh.tets[size_t(t)];
    return q[0] == v || q[1] == v || q[2] == v || q[3] == v;
  };
  // The smallest mixed tet with both ends of the edge (a < b), or -1 when none.
  auto firstTet = [&](uint64_t edge) {
    const int32_t a = int32_t(edge >> 32), b = int32_t(uint32_t(edge));
    for (int64_t i = stars.offset[size_t(a)]; i < stars.offset[size_t(a) + 1]; ++i) {
      const int32_t t = stars.tets[size_t(i)];
      if (mixed[size_t(t)] && hasVertex(t, b)) return t;
    }
    return int32_t(-1);
  };
  // The complete ring of tets around an edge, from its first tet through the faces that contain
  // the edge (`stack`: a buffer); ringOf: sorted.
  auto walkRing = [&](uint64_t edge, int32_t first, std::vector<int32_t>& tets, std::vector<int32_t>& stack) {
    const uint32_t ea = uint32_t(edge >> 32), eb = uint32_t(edge);
    tets.clear();
    stack.assign(1, first);
    while (!stack.empty()) {
      const int32_t t = stack.back();
      stack.pop_back();
      if (std::find(tets.begin(), tets.end(), t) != tets.end()) continue;
      tets.push_back(t);
      const auto& q = mesh.tets[size_t(t)];
      for (int f = 0; f < 4; ++f) {
        const int32_t o = nb[size_t(4 * t + f)];
        if (o >= 0 && uint32_t(q[size_t(f)]) != ea && uint32_t(q[size_t(f)]) != eb) stack.push_back(o);
      }
    }
  };
  auto ringOf = [&](uint64_t edge, int32_t first, std::vector<int32_t>& tets) {
    std::vector<int32_t> stack;
    walkRing(edge, first, tets, stack);
    std::sort(tets.begin(), tets.end());
  };
  auto linked = [&](int32_t x, int32_t y) {
    for (int f = 0; f < 4; ++f)
      if (nb[size_t(4 * x + f)] == y) return true;
    return false;
  };
  // Groups (arcs) of the ring's tets in `inSet`, joined through the faces at the edge.
  auto groupsOf = [&](const std::vector<int32_t>& tets, auto inSet) {
    std::vector<std::vector<int32_t>> out;
    std::vector<char> seen(tets.size(), 0);
    for (size_t a = 0; a < tets.size(); ++a) {
      if (seen[a] || !inSet(tets[a])) continue;
      std::vector<int32_t> g{tets[a]};
      seen[a] = 1;
      for (size_t k = 0; k < g.size(); ++k)
        for (size_t b = 0; b < tets.size(); ++b)
          if (!seen[b] && inSet(tets[b]) && linked(g[k], tets[b])) {
            seen[b] = 1;
            g.push_back(tets[b]);
          }
      out.push_back(std::move(g));
    }
    return out;
  };
  struct Work {
    uint64_t edge;
    int32_t first; // the tet its ring is walked from
  };
  std::unordered_set<uint64_t> dirty; // edges of tets relabelled in the last round
  for (int round = 0; round < 4; ++round) {
    progress.checkCancel();
    int64_t closed = 0;
    std::unordered_set<uint64_t> touched;
    // Which rings need work: found on both threads on the round's labels (the first round: every
    // edge of a mixed tet, by the stars of the vertices; then the edges of the tets relabelled),
    // fixed in the order of their edges below.
    std::vector<uint64_t> recheck(dirty.begin(), dirty.end());
    std::sort(recheck.begin(), recheck.end());
    const int64_t items = round == 0 ? int64_t(mesh.numPoints()) : int64_t(recheck.size());
    std::vector<std::vector<Work>> found(static_cast<size_t>(omp_get_max_threads()));
    LoopCancel cancel(progress);
#pragma omp parallel
    {
      std::vector<int32_t> tets, stack;
      std::vector<std::pair<int32_t, int32_t>> ends; // (other end, tet)
      std::vector<int> parent;
      std::vector<Work>& mine = found[size_t(omp_get_thread_num())];
      // Whether some label touches itself along the edge: the ring's tets joined where they share
      // a face and a label; more such groups than labels means a label has two arcs there.
      auto look = [&](uint64_t edge, int32_t first) {
        walkRing(edge, first, tets, stack);
        const size_t k = tets.size();
        parent.resize(k);
        size_t groups = k, labelsHere = 0;
        for (size_t x = 0; x < k; ++x) {
          parent[x] = int(x);
          const int32_t L = mesh.materials[size_t(tets[x])];
          bool firstOfLabel = true;
          for (size_t y = 0; y < x; ++y) {
            if (mesh.materials[size_t(tets[y])] != L) continue;
            firstOfLabel = false;
            if (!linked(tets[x], tets[y])) continue;
            int rx = int(x), ry = int(y);
            while (parent[size_t(rx)] != rx) rx = parent[size_t(rx)];
            while (parent[size_t(ry)] != ry) ry = parent[size_t(ry)];
            if (rx == ry) continue;
            parent[size_t(std::max(rx, ry))] = std::min(rx, ry);
            --groups;
          }
          labelsHere += firstOfLabel ? 1 : 0;
        }
        if (groups > labelsHere) mine.push_back({edge, first});
      };
#pragma omp for schedule(dynamic, 1024)
      for (int64_t g = 0; g < items; ++g) {
        if (cancel.skip(g)) continue;
        if (round > 0) {
          const int32_t first = firstTet(recheck[size_t(g)]);
          if (first >= 0) look(recheck[size_t(g)], first);
          continue;
        }
        const int32_t a = int32_t(g);
        ends.clear();
        for (int64_t i = stars.offset[size_t(a)]; i < stars.offset[size_t(a) + 1]; ++i) {
          const int32_t t = stars.tets[size_t(i)];
          if (!mixed[size_t(t)]) continue;
          for (int32_t v : mesh.tets[size_t(t)])
            if (v > a) ends.push_back({v, t});
        }
        std::sort(ends.begin(), ends.end());
        for (size_t i = 0; i < ends.size(); ++i)
          if (i == 0 || ends[i].first != ends[i - 1].first)
            look((uint64_t(uint32_t(a)) << 32) | uint32_t(ends[i].first), ends[i].second);
      }
    }
    cancel.rethrow();
    std::vector<Work> work;
    for (auto& f : found) work.insert(work.end(), f.begin(), f.end());
    std::sort(work.begin(), work.end(), [](const Work& x, const Work& y) { return x.edge < y.edge; });
    std::vector<int32_t> tets;
    for (size_t g = 0; g < work.size(); ++g) {
      if ((g & 1023) == 0) progress.checkCancel();
      ringOf(work[g].edge, work[g].first, tets);
      auto groups = [&](auto inSet) { return groupsOf(tets, inSet); };
      std::set<int32_t> labelsHere;
      for (int32_t t : tets) labelsHere.insert(mesh.materials[size_t(t)]);
      for (int32_t L : labelsHere) {
        auto isL = [&](int32_t t) { return mesh.materials[size_t(t)] == L; };
        if (groups(isL).size() < 2) continue;
        // Fill the smallest gap between two arcs of L whose tets may all take L.
        auto gaps = groups([&](int32_t t) { return !isL(t); });
        std::sort(gaps.begin(), gaps.end(), [](const auto& x, const auto& y) { return x.size() < y.size(); });
        for (const auto& gap : gaps) {
          bool ok = true;
          for (int32_t t : gap)
            for (int f = 0; f < 4 && ok; ++f) {
              const int32_t o = nb[size_t(4 * t + f)];
              if (o < 0 || std::find(gap.begin(), gap.end(), o) != gap.end()) continue;
              ok = allowed.ok(L, mesh.materials[size_t(o)]);
            }
          if (!ok) continue;
          for (int32_t t : gap) {
            st.relabelledVolume += std::abs(mesh.tetVolume(size_t(t)));
            mesh.materials[size_t(t)] = L;
            ++st.edgeTets;
            for (const auto& e : kEdgeEnds) touched.insert(edgeKey(t, e));
          }
          ++closed;
          break;
        }
        break; // the ring changed: its other labels next round
      }
    }
    st.closedEdges += closed;
    if (closed == 0) break;
    dirty.swap(touched);
  }
}

void repairFragments(Steps& s) {
  // Named references (clang 14 cannot capture structured bindings in lambdas).
  auto& mesh = s.mesh;
  auto& params = s.params;
  auto& progress = s.progress;
  auto& st = s.st;
  auto& labels = s.labels;
  auto& img = s.img;
  auto& allowed = s.allowed;
  auto& nb = s.nb;
  auto& n = s.n;
  const std::vector<double>& size = *s.size;
  progress.beginStage("repair fragments");
  const double voxel = labels.grid.voxelVolume();
  const double limit = params.fragment_voxels * voxel;
  std::vector<int32_t> vote = tetVotes(mesh, labels, img.comp);
  std::map<int32_t, double> labelVolume; // voxels of each label [mm^3]
  for (const auto& c : img.comps) labelVolume[c.label] += double(c.voxels) * voxel;
  std::vector<uint8_t> strayDone(size_t(n), 0); // a stray moves once
  for (int round = 0; round < 8; ++round) {
    progress.checkCancel();
    DisjointSets sets = s.pieces->now();
    progress.checkCancel();
    // Pieces (by root), their volume, and the primary piece of every image component.
    std::vector<double> volume(mesh.numTets(), 0.0);
    for (int64_t t = 0; t < n; ++t) {
      progress.checkCancelEvery(t);
      volume[size_t(sets.find(int32_t(t)))] += size[size_t(t)];
    }
    const std::unordered_map<uint64_t, double> pieceVotes = pieceVoteSums(mesh, size, sets, vote); // (root, comp)
    std::unordered_set<uint64_t> primaryOf; // (comp, root) pairs
    const std::vector<uint8_t> primary = primaryPiecesOf(pieceVotes, mesh.numTets(), &img, &primaryOf);
    progress.checkCancel();
    // The image component each piece votes for most (-1: none), and its size limit: fragment_voxels,
    // or kFragmentShare of that component (of its label's voxels when it votes for none).
    std::vector<std::pair<uint64_t, double>> pv(pieceVotes.begin(), pieceVotes.end());
    std::sort(pv.begin(), pv.end());
    std::unordered_map<int32_t, std::pair<int32_t, double>> mainComp; // root -> (comp, votes)
    for (const auto& [k, v] : pv) {
      const int32_t r = int32_t(k >> 32), c = int32_t(uint32_t(k));
      auto it = mainComp.find(r);
      if (it == mainComp.end() || v > it->second.second) mainComp[r] = {c, v};
    }
    // A component without a core may be lost (the certificate's lost_small) but not split: any
    // piece that is not its primary one may go, whatever its size.
    auto compLimit = [&](int32_t c) { return fragmentLimit(img, c, params.fragment_voxels, voxel); };
    auto limitOf = [&](int32_t r, int32_t label) {
      const auto it = mainComp.find(r);
      if (it == mainComp.end()) return std::max(limit, kFragmentShare * labelVolume[label]);
      if (img.comps[size_t(it->second.first)].cores == 0) return std::numeric_limits<double>::infinity();
      return compLimit(it->second.first);
    };
    // Candidates: small, not primary. Their outer faces by neighbour label. Strays too: the tets of
    // a piece that stays which vote for a component it is not primary of, while it votes for that
    // component with less than the component's size limit (a piece of one component reaching into
    // a voxel of another, nearby one: the certificate would count it as a second piece of that
    // one). Each stray is a candidate of its own (key: -1 - tet) when it is on the piece's surface.
    std::map<int32_t, std::map<int32_t, double>> border; // root (or -1 - stray tet) -> label -> shared area
    std::vector<int64_t> candidateTets;
    // Per tet, the answers for its piece (and its vote), kept from the tet before: runs of tets
    // share them, so most tets skip the lookups.
    int32_t lastRoot = -1, lastComp = -1;
    bool stays = false, noStray = false;
    for (int64_t t = 0; t < n; ++t) {
      progress.checkCancelEvery(t);
      const int32_t r = sets.find(int32_t(t));
      if (r != lastRoot) {
        // A piece is one label, so limitOf's label is the same for all its tets.
        stays = primary[size_t(r)] || volume[size_t(r)] >= limitOf(r, mesh.materials[size_t(t)]);
        lastRoot = r;
        lastComp = -1;
      }
      if (stays) {
        const int32_t c = vote[size_t(t)];
        if (c < 0 || strayDone[size_t(t)]) continue;
        if (c != lastComp) {
          // Not a stray: the piece is primary for c, or votes for c with at least c's limit.
          const auto pv = pieceVotes.find((uint64_t(uint32_t(r)) << 32) | uint32_t(c));
          noStray = primaryOf.count((uint64_t(uint32_t(c)) << 32) | uint32_t(r)) || pv == pieceVotes.end() ||
                    pv->second >= compLimit(c);
          lastComp = c;
        }
        if (noStray) continue;
        std::map<int32_t, double> b;
        addBorder(mesh, nb, t, b);
        if (b.empty()) continue;
        candidateTets.push_back(t);
        border[int32_t(-1 - t)] = std::move(b);
        continue;
      }
      candidateTets.push_back(t);
      addBorder(mesh, nb, t, border[r]);
    }
    std::map<int32_t, int32_t> target; // root -> new label
    int64_t kept = 0;
    for (const auto& [r, b] : border) {
      if (const auto into = dissolveInto(b, allowed)) target[r] = *into;
      else if (r >= 0) ++kept;
    }
    std::vector<std::pair<int32_t, int32_t>> keptRoots; // (root, label)
    for (const auto& [r, b] : border)
      if (r >= 0 && !target.count(r)) keptRoots.push_back({r, mesh.materials[size_t(r)]});
    if (!target.empty()) {
      ++st.fragmentRounds;
      for (const auto& [r, unused] : target) st.fragments += r >= 0 ? 1 : 0;
      for (int64_t t : candidateTets) {
        auto it = target.find(int32_t(-1 - t));
        if (it == target.end()) it = target.find(sets.find(int32_t(t)));
        if (it == target.end()) continue;
        relabel(s, vote, t, it->second);
        if (it->first < 0) {
          ++st.strayTets;
          strayDone[size_t(t)] = 1;
        } else {
          ++st.fragmentTets;
        }
      }
    }
    // A piece that no neighbouring label may take (the labels around it may not touch each other:
    // a speck of brain between a tongue of scalp and the CSF) takes the label the image favours
    // over it (the largest indicator function, by volume) among those allowed next to all its
    // neighbours, with a least-volume chain of tets (leastVolumeChain) to that label's nearest
    // tet taking it too: alone it would be an island of that label, another split.
    int64_t chained = 0;
    for (const auto& [r, ownLabel] : keptRoots) {
      const int32_t own = ownLabel; // a copy: lambdas cannot capture a structured binding in clang 14
      std::vector<int64_t> piece;
      for (int64_t t : candidateTets)
        if (sets.find(int32_t(t)) == r) piece.push_back(t);
      // (skipped when an earlier chain ran through it)
      if (piece.empty() || std::any_of(piece.begin(), piece.end(), [&](int64_t t) { return mesh.materials[size_t(t)] != own; }))
        continue;
      std::map<int32_t, double> around, favour;
      for (int64_t t : piece) {
        addBorder(mesh, nb, t, around);
        const double v = std::abs(mesh.tetVolume(size_t(t)));
        for (const auto& [L, value] : valuesAt(s.materials, tetCentroid(mesh, size_t(t)))) favour[L] += v * double(value);
      }
      std::vector<std::pair<double, int32_t>> order; // (-favour, label)
      for (const auto& [L, f] : favour) {
        bool ok = L != own && !around.count(L);
        for (const auto& [M, unused] : around) ok = ok && allowed.ok(L, M);
        if (ok) order.push_back({-f, L});
      }
      std::sort(order.begin(), order.end());
      for (const auto& [unused, label] : order) {
        const int32_t L = label; // a copy, as above
        auto inPiece = [&](int32_t t) { return std::binary_search(piece.begin(), piece.end(), int64_t(t)); };
        auto fits = [&](int32_t a, int32_t pred, int32_t succ) {
          for (int f = 0; f < 4; ++f) {
            const int32_t o = nb[size_t(4 * a + f)];
            if (o < 0 || o == pred || o == succ || inPiece(o)) continue;
            if (!allowed.ok(L, mesh.materials[size_t(o)])) return false;
          }
          return true;
        };
        const std::vector<int32_t> path = leastVolumeChain(
            mesh, nb, piece, L, inPiece, [&](int32_t b) { return mesh.materials[size_t(b)] == L; }, fits);
        if (path.empty()) continue;
        for (int64_t t : piece) relabel(s, vote, t, L);
        for (int32_t t : path) relabel(s, vote, t, L);
        st.fragmentTets += int64_t(piece.size());
        st.fragmentChainTets += int64_t(path.size());
        ++st.fragments;
        ++st.fragmentChains;
        ++chained;
        --kept;
        break;
      }
    }
    st.keptSmallPieces = kept;
    if (target.empty() && chained == 0) break;
  }
}

} // namespace

namespace {
// Face neighbours (as tetFaceNeighbours) of the tets around `vertices` only; every other entry is
// kNoNeighbour. Found through the vertex stars: the tet across a face is in the stars of all three
// of its vertices.
std::vector<int32_t> neighboursAround(const TetMesh& mesh, const VertexStars& stars, const std::vector<int32_t>& vertices,
                                      std::vector<int32_t>& focusTets) {
  std::vector<int32_t> nb(4 * mesh.numTets(), kNoNeighbour);
  for (int32_t v : vertices)
    for (int64_t i = stars.offset[size_t(v)]; i < stars.offset[size_t(v) + 1]; ++i) focusTets.push_back(stars.tets[size_t(i)]);
  std::sort(focusTets.begin(), focusTets.end());
  focusTets.erase(std::unique(focusTets.begin(), focusTets.end()), focusTets.end());
  for (int32_t t : focusTets) {
    const auto& q = mesh.tets[size_t(t)];
    for (int f = 0; f < 4; ++f) {
      const int32_t a = q[kTetFaceVertices[f][0]], b = q[kTetFaceVertices[f][1]], c = q[kTetFaceVertices[f][2]];
      for (int64_t i = stars.offset[size_t(a)]; i < stars.offset[size_t(a) + 1]; ++i) {
        const int32_t o = stars.tets[size_t(i)];
        if (o == t) continue;
        const auto& r = mesh.tets[size_t(o)];
        const bool hasB = r[0] == b || r[1] == b || r[2] == b || r[3] == b;
        const bool hasC = r[0] == c || r[1] == c || r[2] == c || r[3] == c;
        if (hasB && hasC) {
          nb[4 * size_t(t) + size_t(f)] = o;
          break;
        }
      }
    }
  }
  return nb;
}
} // namespace

int64_t dissolvePieces(TetMesh& mesh, const std::vector<std::vector<int32_t>>& pieces,
                       const std::vector<std::pair<int32_t, int32_t>>& contacts, LabelRepairStats& st,
                       const VertexStars* given) {
  Allowed allowed;
  for (const auto& [a, b] : contacts) allowed.pairs.insert(labelPairKey(a, b));
  VertexStars own;
  if (!given) own = vertexStars(mesh);
  const VertexStars& stars = given ? *given : own;
  std::vector<int32_t> vertices, focus;
  for (const auto& p : pieces)
    for (int32_t t : p)
      for (int32_t v : mesh.tets[size_t(t)]) vertices.push_back(v);
  std::sort(vertices.begin(), vertices.end());
  vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
  const std::vector<int32_t> nb = neighboursAround(mesh, stars, vertices, focus);
  int64_t done = 0;
  for (const auto& p : pieces) {
    std::map<int32_t, double> border; // neighbouring label -> shared area
    for (int32_t t : p) addBorder(mesh, nb, t, border);
    const auto into = dissolveInto(border, allowed);
    if (!into) continue;
    for (int32_t t : p) {
      mesh.materials[size_t(t)] = *into;
      st.relabelledVolume += std::abs(mesh.tetVolume(size_t(t)));
      ++st.fragmentTets;
    }
    ++st.fragments;
    ++done;
  }
  return done;
}

LabelRepairStats repairLabelsAround(TetMesh& mesh, const MaterialSet& materials, const LabelRepairParams& params,
                                    const LabelRepairCheck& check, const std::vector<std::pair<int32_t, int32_t>>& contacts,
                                    Progress& progress, const VertexStars* given) {
  LabelRepairStats st;
  if (!check.needed()) {
    st.skipped = true;
    return st;
  }
  progress.beginStage("repair contacts");
  st.local = true;
  const auto shared = materials.sharedDominantLabels();
  const LabelVolume& labels = *shared;
  const LabelImageTopology none; // connections and fragments do not run here
  Allowed allowed;
  for (const auto& [a, b] : contacts) allowed.pairs.insert(labelPairKey(a, b));
  VertexStars own;
  if (!given) own = vertexStars(mesh);
  const VertexStars& stars = given ? *given : own;
  std::vector<int32_t> focus;
  const std::vector<int32_t> nb = neighboursAround(mesh, stars, check.badVertices, focus);
  countForbidden(mesh, nb, allowed, st.forbiddenFacesBefore, st.forbiddenAreaBefore);
  LabelRepairParams p = params;
  p.connect = p.fragments = false;
  Steps s{mesh, materials, p, progress, st, labels, none, allowed, nb, int64_t(mesh.numTets()), IndexFrame{labels.grid}, &stars};
  if (p.contacts && st.forbiddenFacesBefore > 0) repairContacts(s);
  if (p.points) repairPointContacts(s);
  if (p.edges) repairEdges(s);
  countForbidden(mesh, nb, allowed, st.forbiddenFacesAfter, st.forbiddenAreaAfter);
  progress.endStage();
  return st;
}

LabelRepairStats repairLabels(TetMesh& mesh, const MaterialSet& materials, const LabelRepairParams& params,
                              Progress& progress, const LabelImageTopology* image, const TetJoins* joins,
                              std::vector<int32_t>* faceNeighbours) {
  if (!(params.fragment_voxels >= 0.0) || !std::isfinite(params.fragment_voxels))
    throw InputError("fragment_voxels must be a number >= 0");
  mesh.validateStructure("mesh");
  LabelRepairStats st;
  if (mesh.numTets() == 0 || (!params.contacts && !params.fragments && !params.connect && !params.edges &&
                               !params.points)) return st;
  const int64_t n = static_cast<int64_t>(mesh.numTets());

  const auto shared = materials.sharedDominantLabels();
  const LabelVolume& labels = *shared;
  if (!image) {
    progress.beginStage("repair check");
    const auto contacts = labelContactPairs(labels);
    const LabelRepairCheck check = checkLabelRepair(mesh, contacts, progress, joins);
    if (!check.needed() || !check.extraPieces) return repairLabelsAround(mesh, materials, params, check, contacts, progress);
  }
  progress.beginStage(params.contacts || params.points ? "repair contacts" : "repair fragments");
  LabelImageTopology own;
  if (!image) own = analyzeLabelImage(labels, progress);
  const LabelImageTopology& img = image ? *image : own;
  Allowed allowed;
  for (const auto& [k, unused] : img.contacts) allowed.pairs.insert(k);
  std::vector<int32_t> ownNb;
  std::vector<int32_t>& nb = faceNeighbours ? *faceNeighbours : ownNb;
  if (nb.empty()) nb = tetFaceNeighbours(mesh, progress);
  countForbidden(mesh, nb, allowed, st.forbiddenFacesBefore, st.forbiddenAreaBefore);

  // The vertex stars, for the point contacts and the edges (relabelling leaves them as they are).
  VertexStars stars;
  if (params.points || params.edges) stars = vertexStars(mesh);
  std::vector<double> size;
  if (params.connect || params.fragments) {
    size.resize(size_t(n));
#pragma omp parallel for schedule(static)
    for (int64_t t = 0; t < n; ++t) size[size_t(t)] = std::abs(mesh.tetVolume(size_t(t)));
  }
  TrackedPieces pieces(mesh, nb, joins);
  Steps s{mesh, materials, params, progress, st, labels, img, allowed, nb, n, IndexFrame{labels.grid}, &stars, joins, &size,
          &pieces};
  if (params.contacts && st.forbiddenFacesBefore > 0) repairContacts(s);
  if (params.points) repairPointContacts(s);
  if (params.connect) repairConnections(s);
  if (params.edges) {
    const int64_t before = st.edgeTets;
    repairEdges(s);
    if (params.connect && st.edgeTets > before) repairConnections(s, true);
  }
  if (params.fragments) repairFragments(s);

  countForbidden(mesh, nb, allowed, st.forbiddenFacesAfter, st.forbiddenAreaAfter);
  progress.endStage();
  return st;
}

void writeLabelRepairReport(const LabelRepairStats& s, Report& report) {
  report.set("repair_skipped", ReportValue(s.skipped));
  report.set("repair_forbidden_faces_before", s.forbiddenFacesBefore);
  report.set("repair_forbidden_area_before_mm2", s.forbiddenAreaBefore);
  report.set("repair_forbidden_faces_after", s.forbiddenFacesAfter);
  report.set("repair_forbidden_area_after_mm2", s.forbiddenAreaAfter);
  report.set("repair_contact_tets", s.contactTets);
  report.set("repair_unresolved_tets", s.unresolvedTets);
  report.set("repair_fragments", s.fragments);
  report.set("repair_fragment_tets", s.fragmentTets);
  report.set("repair_stray_tets", s.strayTets);
  report.set("repair_kept_small_pieces", s.keptSmallPieces);
  report.set("repair_point_contacts", s.pointContacts);
  report.set("repair_point_tets", s.pointTets);
  report.set("repair_closed_edges", s.closedEdges);
  report.set("repair_edge_tets", s.edgeTets);
  report.set("repair_connections", s.connections);
  report.set("repair_connect_tets", s.connectTets);
  report.set("repair_chain_connections", s.chainConnections);
  report.set("repair_fragment_chains", s.fragmentChains);
  report.set("repair_fragment_chain_tets", s.fragmentChainTets);
  report.set("repair_relabelled_volume_mm3", s.relabelledVolume);
  report.set("repair_local", ReportValue(s.local));
  report.set("repair_local_rounds", int64_t(s.localRounds));
}

} // namespace tetflow
