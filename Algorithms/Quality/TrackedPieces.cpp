#include "TrackedPieces.h"

#include <algorithm>
#include <limits>
#include <map>
#include <unordered_map>
#include <unordered_set>

#include <omp.h>

namespace tetflow {

TrackedPieces::TrackedPieces(const TetMesh& mesh, const std::vector<int32_t>& nb, const TetJoins* joins)
    : mesh_(mesh), nb_(nb), joins_(joins) {
  if (!joins || joins->empty()) return;
  const size_t n = mesh.numTets();
  joinStart_.assign(n + 1, 0);
  for (const auto& [a, b] : *joins) {
    ++joinStart_[size_t(a) + 1];
    ++joinStart_[size_t(b) + 1];
  }
  for (size_t t = 0; t < n; ++t) joinStart_[t + 1] += joinStart_[t];
  joinList_.resize(size_t(joinStart_[n]));
  std::vector<int64_t> fill(joinStart_.begin(), joinStart_.end() - 1);
  for (const auto& [a, b] : *joins) {
    joinList_[size_t(fill[size_t(a)]++)] = b;
    joinList_[size_t(fill[size_t(b)]++)] = a;
  }
}

template <class F>
void TrackedPieces::forNeighbours(int32_t t, F&& f) const {
  for (int k = 0; k < 4; ++k)
    if (const int32_t o = nb_[4 * size_t(t) + size_t(k)]; o >= 0) f(o);
  if (!joinStart_.empty())
    for (int64_t i = joinStart_[size_t(t)]; i < joinStart_[size_t(t) + 1]; ++i) f(joinList_[size_t(i)]);
}

DisjointSets TrackedPieces::now() {
  if (labels_.size() != mesh_.numTets() || !update()) {
    DisjointSets sets = sameLabelPieces(mesh_, nb_, joins_);
    root_ = sets.parent;
    labels_ = mesh_.materials;
    ++whole_;
    return sets;
  }
  DisjointSets out(0);
  out.parent = root_;
  return out;
}

bool TrackedPieces::update() {
  const auto& mats = mesh_.materials;
  const int64_t n = int64_t(mats.size());
  auto changed = [&](int32_t t) { return mats[size_t(t)] != labels_[size_t(t)]; };
  // The tets whose label changed, ascending (each thread's share in order).
  std::vector<int32_t> R;
  {
    std::vector<std::vector<int32_t>> part(static_cast<size_t>(omp_get_max_threads()));
#pragma omp parallel
    {
      std::vector<int32_t>& mine = part[size_t(omp_get_thread_num())];
#pragma omp for schedule(static)
      for (int64_t t = 0; t < n; ++t)
        if (changed(int32_t(t))) mine.push_back(int32_t(t));
    }
    for (const auto& p : part) R.insert(R.end(), p.begin(), p.end());
  }
  if (R.empty()) return true;
  if (int64_t(R.size()) > std::max<int64_t>(1024, n / 32)) return false;

  const auto indexOf = [&](int32_t t) { return int32_t(std::lower_bound(R.begin(), R.end(), t) - R.begin()); };
  // What is left of a piece some tets left (its tets that stay) may be in pieces. The tets that
  // left are taken in clusters: those of one old piece joined through each other; the tets next to
  // a cluster that stay are its seeds. Every part of what is left holds a seed, and a path in the
  // old piece between two tets that stay leaves and re-enters them at seeds of one cluster. So from
  // the seeds of each cluster searches run side by side (one tet each in turn; two that meet are
  // one group) until at most one group is still growing: the others have run out, each a whole
  // part ("closed"); the one growing is "open", and the seeds in no closed part are all in it.
  // What is left besides the closed parts is then one part, the "rest", unless two clusters' open
  // groups are in different parts; a path between those passes from cluster to cluster through
  // parts, so it passes a closed part that seeds of two clusters are in. Only when there is such a
  // part and two open groups is every tet joined again.
  DisjointSets clusters(R.size());
  for (size_t i = 0; i < R.size(); ++i)
    forNeighbours(R[i], [&](int32_t o) {
      if (changed(o) && root_[size_t(o)] == root_[size_t(R[i])]) clusters.unite(int32_t(i), indexOf(o));
    });
  std::map<int32_t, std::vector<int32_t>> seedsOf; // cluster -> seeds
  for (size_t i = 0; i < R.size(); ++i) {
    const int32_t A = root_[size_t(R[i])];
    auto& seeds = seedsOf[clusters.find(int32_t(i))];
    forNeighbours(R[i], [&](int32_t o) {
      if (!changed(o) && root_[size_t(o)] == A) seeds.push_back(o);
    });
  }
  struct Part {
    int32_t piece;             // old root
    std::vector<int32_t> tets; // the whole part
    int32_t smallest;
  };
  std::vector<Part> closed;
  std::unordered_map<int32_t, int32_t> closedOf; // tet -> its closed part
  std::vector<std::pair<int32_t, int32_t>> openSeed; // per cluster with an open group: (old root, a seed in it)
  int64_t budget = 64 * int64_t(R.size()) + 4096; // tets searched in all; past it, join every tet
  constexpr size_t kMaxSeeds = 256;
  for (auto& [cluster, seeds] : seedsOf) {
    std::sort(seeds.begin(), seeds.end());
    seeds.erase(std::unique(seeds.begin(), seeds.end()), seeds.end());
    const int32_t A = root_[size_t(R[size_t(cluster)])];
    std::vector<int32_t> start;
    for (int32_t x : seeds)
      if (!closedOf.count(x)) start.push_back(x); // else in a part found whole already
    if (start.empty()) continue;
    if (start.size() == 1) {
      openSeed.push_back({A, start[0]});
      continue;
    }
    if (start.size() > kMaxSeeds) return false;
    const size_t k = start.size();
    std::vector<std::vector<int32_t>> queue(k);
    std::vector<size_t> head(k, 0);
    std::unordered_map<int32_t, int32_t> owner;
    DisjointSets groups(k);
    for (size_t i = 0; i < k; ++i) {
      queue[i].push_back(start[i]);
      owner.emplace(start[i], int32_t(i));
    }
    std::vector<int32_t> growing;
    for (;;) {
      growing.clear();
      for (size_t i = 0; i < k; ++i)
        if (head[i] < queue[i].size()) growing.push_back(groups.find(int32_t(i)));
      std::sort(growing.begin(), growing.end());
      if (std::unique(growing.begin(), growing.end()) - growing.begin() <= 1) break;
      for (size_t i = 0; i < k; ++i) {
        if (head[i] == queue[i].size()) continue;
        if (--budget < 0) return false;
        const int32_t x = queue[i][head[i]++];
        forNeighbours(x, [&](int32_t o) {
          if (changed(o) || root_[size_t(o)] != A) return;
          const auto [it, fresh] = owner.try_emplace(o, int32_t(i));
          if (fresh) queue[i].push_back(o);
          else groups.unite(int32_t(i), it->second);
        });
      }
    }
    std::map<int32_t, bool> ranOut; // group -> all its searches ran out
    for (size_t i = 0; i < k; ++i) {
      const auto [it, fresh] = ranOut.try_emplace(groups.find(int32_t(i)), true);
      it->second = it->second && head[i] == queue[i].size();
    }
    for (const auto& [g, whole] : ranOut) {
      if (!whole) {
        openSeed.push_back({A, start[size_t(g)]}); // g: a front of the group (its smallest)
        continue;
      }
      Part part{A, {}, std::numeric_limits<int32_t>::max()};
      for (size_t i = 0; i < k; ++i)
        if (groups.find(int32_t(i)) == g) part.tets.insert(part.tets.end(), queue[i].begin(), queue[i].end());
      for (int32_t t : part.tets) {
        closedOf.emplace(t, int32_t(closed.size()));
        part.smallest = std::min(part.smallest, t);
      }
      closed.push_back(std::move(part));
    }
  }
  // Per old piece: its open groups (an open group whose seed is in a closed part found later is that
  // part), and whether a closed part of it holds seeds of two clusters.
  std::map<int32_t, int> open;
  for (const auto& [A, seed] : openSeed)
    if (!closedOf.count(seed)) ++open[A];
  std::vector<int32_t> clusterOf(closed.size(), -1); // -2: seeds of two clusters
  for (const auto& [cluster, seeds] : seedsOf)
    for (int32_t x : seeds)
      if (const auto c = closedOf.find(x); c != closedOf.end()) {
        int32_t& by = clusterOf[size_t(c->second)];
        by = by == -1 || by == cluster ? cluster : -2;
      }
  for (size_t c = 0; c < closed.size(); ++c)
    if (clusterOf[c] == -2 && open[closed[c].piece] > 1) return false;

  // The changed tets (elements 0 .. |R| - 1) join each other and the parts they touch (an element
  // per old piece's rest, keyed by its old root, and per closed part, keyed by -1 - its index) where
  // they share a label now.
  DisjointSets sets(R.size());
  std::vector<int32_t> smallest(R.begin(), R.end()); // per element: its smallest tet (rests: below)
  std::unordered_map<int64_t, int32_t> partElement;
  auto elementOf = [&](int32_t o) { // o: a tet that stays
    const auto c = closedOf.find(o);
    const int64_t key = c != closedOf.end() ? -1 - int64_t(c->second) : int64_t(root_[size_t(o)]);
    const auto [it, fresh] = partElement.try_emplace(key, int32_t(smallest.size()));
    if (fresh) {
      smallest.push_back(c != closedOf.end() ? closed[size_t(c->second)].smallest : root_[size_t(o)]);
      sets.parent.push_back(it->second);
    }
    return it->second;
  };
  for (size_t i = 0; i < R.size(); ++i) {
    const int32_t q = R[i];
    forNeighbours(q, [&](int32_t o) {
      if (mats[size_t(o)] == mats[size_t(q)]) sets.unite(int32_t(i), changed(o) ? indexOf(o) : elementOf(o));
    });
  }

  // Rests whose smallest tet is no longer theirs (it left, or is in a closed part): their smallest
  // tet now.
  std::vector<int32_t> rerooted;
  for (const auto& [A, groupsOpen] : open) // ascending (a map)
    if (groupsOpen > 0 && (changed(A) || closedOf.count(A))) rerooted.push_back(A);
  std::vector<int32_t> newRoot(rerooted.size(), std::numeric_limits<int32_t>::max());
  if (!rerooted.empty()) {
#pragma omp parallel
    {
      std::vector<int32_t> mine(rerooted.size(), std::numeric_limits<int32_t>::max());
      int32_t lastRoot = -1;
      size_t lastAt = rerooted.size();
#pragma omp for schedule(static) nowait
      for (int64_t t = 0; t < n; ++t) {
        const int32_t r = root_[size_t(t)];
        if (r != lastRoot) { // tets of a piece come in runs
          lastRoot = r;
          const auto it = std::lower_bound(rerooted.begin(), rerooted.end(), r);
          lastAt = it != rerooted.end() && *it == r ? size_t(it - rerooted.begin()) : rerooted.size();
        }
        if (lastAt < rerooted.size() && int32_t(t) < mine[lastAt] && !changed(int32_t(t)) && !closedOf.count(int32_t(t)))
          mine[lastAt] = int32_t(t);
      }
#pragma omp critical
      for (size_t j = 0; j < mine.size(); ++j) newRoot[j] = std::min(newRoot[j], mine[j]);
    }
  }
  auto restRoot = [&](int32_t A) {
    const auto it = std::lower_bound(rerooted.begin(), rerooted.end(), A);
    return it != rerooted.end() && *it == A ? newRoot[size_t(it - rerooted.begin())] : A;
  };
  for (const auto& [key, e] : partElement)
    if (key >= 0) smallest[size_t(e)] = restRoot(int32_t(key));

  // Every set's root: the smallest tet of its elements. Then the new roots: of the changed tets,
  // of the closed parts, and of the rests (old root -> new root).
  std::vector<int32_t> setRoot(smallest.size(), std::numeric_limits<int32_t>::max());
  for (size_t e = 0; e < smallest.size(); ++e) {
    const int32_t r = sets.find(int32_t(e));
    setRoot[size_t(r)] = std::min(setRoot[size_t(r)], smallest[e]);
  }
  auto joinedRoot = [&](int64_t key, int32_t alone) {
    const auto it = partElement.find(key);
    return it == partElement.end() ? alone : setRoot[size_t(sets.find(it->second))];
  };
  std::vector<std::pair<int32_t, int32_t>> renumber; // the rests joined to changed tets, or rerooted
  for (const auto& [key, e] : partElement)
    if (key >= 0) renumber.push_back({int32_t(key), setRoot[size_t(sets.find(e))]});
  for (size_t j = 0; j < rerooted.size(); ++j)
    if (!partElement.count(rerooted[j])) renumber.push_back({rerooted[j], newRoot[j]});
  std::sort(renumber.begin(), renumber.end());
  std::vector<int32_t> rootOfChanged(R.size());
  for (size_t i = 0; i < R.size(); ++i) rootOfChanged[i] = setRoot[size_t(sets.find(int32_t(i)))];
#pragma omp parallel
  {
    int32_t lastRoot = -1, lastTo = -1;
#pragma omp for schedule(static)
    for (int64_t t = 0; t < n; ++t) {
      if (changed(int32_t(t))) {
        root_[size_t(t)] = rootOfChanged[size_t(indexOf(int32_t(t)))];
        continue;
      }
      const int32_t r = root_[size_t(t)];
      if (r != lastRoot) {
        lastRoot = r;
        const auto it = std::lower_bound(renumber.begin(), renumber.end(), std::pair{r, std::numeric_limits<int32_t>::min()});
        lastTo = it != renumber.end() && it->first == r ? it->second : r;
      }
      root_[size_t(t)] = lastTo;
    }
  }
  for (size_t c = 0; c < closed.size(); ++c) {
    const int32_t to = joinedRoot(-1 - int64_t(c), closed[c].smallest);
    for (int32_t t : closed[c].tets) root_[size_t(t)] = to;
  }
  for (int32_t q : R) labels_[size_t(q)] = mats[size_t(q)];
  cutOff_ += int64_t(closed.size());
  return true;
}

} // namespace tetflow
