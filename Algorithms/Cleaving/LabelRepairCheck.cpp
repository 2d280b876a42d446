// The label repair's check (LabelRepair.h: checkLabelRepair): whether any repair step could
// change a label, and where. It runs on every cleave, and on most meshes finds nothing, so it is
// built to cost little more than reading the tets twice:
// - one pass finds the mixed vertices (where two labels meet);
// - a second (both threads) joins the tets with no mixed vertex through their vertices (a
//   union-find over vertices, not tets) and lists the others, the band around the interfaces;
// - at each mixed vertex the tets of its star are grouped through the faces they share, which are
//   the edges its link's triangles share; this gives the forbidden pairs, the edges a label
//   touches itself along, and one union-find element per group, which the band's tets join;
// - each label is then in one piece when all its elements have one root. Only when some label is
//   not are the tets of the pieces counted (to list the small ones).
#include <algorithm>
#include <array>
#include <cmath>
#include <atomic>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <string>
#include <unordered_map>

#include <omp.h>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Quality/LabelTopology.h"
#include "LabelRepair.h"

namespace tetflow {

namespace {

// checkLabelRepair lists the tets of extra pieces up to this size (dissolvePieces).
constexpr int64_t kSmallPieceTets = 16;

// MakeTouch() gives, in each thread, a function touch(a, b, v): whether labels a and b touch in the
// image (asked at the mixed vertex v).
template <class MakeTouch>
LabelRepairCheck checkWith(const TetMesh& mesh, const MakeTouch& makeTouch, Progress& progress,
                           const std::vector<std::pair<int32_t, int32_t>>* joins) {
  LabelRepairCheck check;
  const int64_t nt = int64_t(mesh.numTets());
  const int64_t np = int64_t(mesh.numPoints());
  if (nt == 0) return check;
  const auto& tets = mesh.tets;
  const auto& mats = mesh.materials;
  // Vertices where labels meet: the first label seen at each vertex, then a second one. Each
  // thread reads its share of the tets into its own labels (no atomics), and the shares are
  // merged.
  constexpr int32_t kUnset = std::numeric_limits<int32_t>::min();
  const int threads = omp_get_max_threads();
  std::vector<std::vector<int32_t>> firsts(static_cast<size_t>(threads));
  std::vector<uint8_t> mixed(size_t(np), 0);
#pragma omp parallel num_threads(threads)
  {
    std::vector<int32_t>& first = firsts[size_t(omp_get_thread_num())];
    first.assign(size_t(np), kUnset);
#pragma omp for schedule(static)
    for (int64_t t = 0; t < nt; ++t) {
      const int32_t L = mats[size_t(t)];
      for (int32_t v : tets[size_t(t)]) {
        int32_t& f = first[size_t(v)];
        if (f == kUnset) f = L;
        else if (f != L) std::atomic_ref<uint8_t>(mixed[size_t(v)]).store(1, std::memory_order_relaxed);
      }
    }
#pragma omp for schedule(static)
    for (int64_t v = 0; v < np; ++v)
      for (int th = 1; th < threads; ++th) {
        if (firsts[size_t(th)].empty()) continue; // a thread the team did not get
        const int32_t a = firsts[0][size_t(v)], b = firsts[size_t(th)][size_t(v)];
        if (a == kUnset) firsts[0][size_t(v)] = b;
        else if (b != kUnset && b != a) mixed[size_t(v)] = 1;
      }
  }
  progress.checkCancel();
  const std::vector<int32_t>& first = firsts[0];
  std::vector<int32_t> slot(size_t(np), -1), mixedList;
  for (int64_t v = 0; v < np; ++v)
    if (mixed[size_t(v)]) {
      slot[size_t(v)] = int32_t(mixedList.size());
      mixedList.push_back(int32_t(v));
    }
  const int64_t nm = int64_t(mixedList.size());
  // Union-find elements: the vertices (an unmixed one stands for all its tets), then one per star
  // entry of a mixed vertex (the entry that is its group's root stands for the group).
  // Tets with no mixed vertex join their vertices here; the others (the band) are listed, in order.
  std::vector<int64_t> offset(size_t(nm) + 1, 0);
  std::vector<int32_t> band;
  ConcurrentSets sets(static_cast<size_t>(np));
  {
    std::vector<std::vector<int32_t>> bands(static_cast<size_t>(omp_get_max_threads()));
#pragma omp parallel
    {
      std::vector<int32_t>& mine = bands[size_t(omp_get_thread_num())];
#pragma omp for schedule(static)
      for (int64_t t = 0; t < nt; ++t) {
        const auto& q = tets[size_t(t)];
        if (slot[size_t(q[0])] >= 0 || slot[size_t(q[1])] >= 0 || slot[size_t(q[2])] >= 0 || slot[size_t(q[3])] >= 0) {
          mine.push_back(int32_t(t));
        } else {
          int32_t* par = sets.parent.data(); // most tets join vertices joined already
          auto parentOf = [&](int32_t v) { return std::atomic_ref<int32_t>(par[v]).load(std::memory_order_relaxed); };
          const int32_t p0 = parentOf(q[0]);
          if (parentOf(q[1]) == p0 && parentOf(q[2]) == p0 && parentOf(q[3]) == p0) continue;
          const int32_t r = sets.unite(sets.unite(q[0], q[1]), q[2]);
          sets.unite(r, q[3]);
        }
      }
    }
    for (const auto& b : bands) band.insert(band.end(), b.begin(), b.end()); // static: in order
  }
  progress.checkCancel();
  // Star entries: counted per share of the band (contiguous, in order; one share per thread, any
  // thread may take any), so that each share fills its own places in every star, and a star lists
  // its tets in band order.
  const int shares = omp_get_max_threads();
  const int64_t nb = int64_t(band.size());
  auto shareBegin = [&](int sh) { return nb * sh / shares; };
  std::vector<std::vector<int64_t>> place(static_cast<size_t>(shares)); // per share: count, then next place
#pragma omp parallel for schedule(static, 1)
  for (int sh = 0; sh < shares; ++sh) {
    std::vector<int64_t>& mine = place[size_t(sh)];
    mine.assign(size_t(nm), 0);
    for (int64_t b = shareBegin(sh); b < shareBegin(sh + 1); ++b)
      for (int32_t v : tets[size_t(band[size_t(b)])])
        if (const int32_t s = slot[size_t(v)]; s >= 0) ++mine[size_t(s)];
  }
  progress.checkCancel();
  for (int64_t m = 0; m < nm; ++m) {
    int64_t at = offset[size_t(m)];
    for (auto& mine : place) {
      const int64_t c = mine[size_t(m)];
      mine[size_t(m)] = at;
      at += c;
    }
    offset[size_t(m) + 1] = at;
  }
  const int64_t entries = offset[size_t(nm)];
  if (np + entries > std::numeric_limits<int32_t>::max())
    throw InputError("label repair check: the mesh has too many vertices and star entries (" +
                     std::to_string(np + entries) + ") for 32-bit indices");
  // Not value-initialised: every place is written by the fill below.
  const auto entryOf = std::make_unique_for_overwrite<int64_t[]>(4 * band.size()); // per band tet and corner: its star entry
  // The stars: their tets' vertices and labels, copied in star order (read one star after
  // another, not scattered over the mesh).
  struct StarTet {
    std::array<int32_t, 4> v;
    int32_t label;
  };
  const auto starTet = std::make_unique_for_overwrite<StarTet[]>(static_cast<size_t>(entries));
#pragma omp parallel for schedule(static, 1)
  for (int sh = 0; sh < shares; ++sh) {
    std::vector<int64_t>& fill = place[size_t(sh)];
    for (int64_t b = shareBegin(sh); b < shareBegin(sh + 1); ++b)
      for (int c = 0; c < 4; ++c) {
        const int32_t t = band[size_t(b)];
        if (const int32_t s = slot[size_t(tets[size_t(t)][size_t(c)])]; s >= 0) {
          const int64_t e = fill[size_t(s)]++;
          starTet[size_t(e)] = {tets[size_t(t)], mats[size_t(t)]};
          entryOf[4 * size_t(b) + size_t(c)] = e;
        } else {
          entryOf[4 * size_t(b) + size_t(c)] = -1;
        }
      }
  }
  std::vector<std::vector<int64_t>>().swap(place);
  progress.checkCancel();
  // At each mixed vertex v: forbidden pairs; the groups of its tets joined through faces, which
  // are the edges of v's link that two tets (triangles of the link) share; and two groups of one
  // label sharing an edge through v, a vertex of the link.
  std::vector<uint8_t> badFlag(size_t(nm), 0);
  std::vector<int32_t> group(static_cast<size_t>(entries)); // per entry: the star entry at its group's root
#pragma omp parallel
  {
    std::vector<int32_t> parent, labels, link, tri, head;
    struct Item { int32_t key, value, next; }; // per link vertex, lists of (other vertex, tet) or (label, group)
    std::vector<Item> pool;
    auto touch = makeTouch();
#pragma omp for schedule(dynamic, 256)
    for (int64_t m = 0; m < nm; ++m) {
      const int64_t o = offset[size_t(m)];
      const int32_t k = int32_t(offset[size_t(m) + 1] - o);
      const int32_t v = mixedList[size_t(m)];
      const StarTet* t0 = starTet.get() + o;
      auto label = [&](int32_t a) { return t0[a].label; };
      bool bad = false;
      labels.clear();
      for (int32_t a = 0; a < k; ++a)
        if (std::find(labels.begin(), labels.end(), label(a)) == labels.end()) labels.push_back(label(a));
      for (size_t a = 0; a < labels.size() && !bad; ++a)
        for (size_t b = a + 1; b < labels.size() && !bad; ++b) bad = !touch(labels[a], labels[b], v);
      // The link: each tet's other three vertices, numbered.
      link.clear();
      tri.resize(3 * size_t(k));
      for (int32_t a = 0; a < k; ++a) {
        int n = 0;
        for (int32_t x : t0[a].v) {
          if (x == v) continue;
          // A link has a few dozen vertices: a search in it stays in the cache.
          const int32_t l = int32_t(std::find(link.begin(), link.end(), x) - link.begin());
          if (l == int32_t(link.size())) link.push_back(x);
          tri[3 * size_t(a) + size_t(n++)] = l;
        }
      }
      parent.resize(size_t(k));
      for (int32_t a = 0; a < k; ++a) parent[size_t(a)] = a;
      auto find = [&](int32_t x) {
        while (parent[size_t(x)] != x) x = parent[size_t(x)] = parent[size_t(parent[size_t(x)])];
        return x;
      };
      // Link edges, listed at their smaller end: the second tet on one joins the first.
      head.assign(link.size(), -1);
      pool.clear();
      for (int32_t a = 0; a < k; ++a)
        for (int e = 0; e < 3; ++e) {
          const int32_t i = tri[3 * size_t(a) + size_t(e)], j = tri[3 * size_t(a) + size_t((e + 1) % 3)];
          const int32_t lo = std::min(i, j), hi = std::max(i, j);
          int32_t it = head[size_t(lo)];
          while (it >= 0 && pool[size_t(it)].key != hi) it = pool[size_t(it)].next;
          if (it < 0) {
            pool.push_back({hi, a, head[size_t(lo)]});
            head[size_t(lo)] = int32_t(pool.size()) - 1;
          } else if (label(a) == label(pool[size_t(it)].value)) {
            const int32_t ra = find(a), rb = find(pool[size_t(it)].value);
            if (ra != rb) parent[size_t(std::max(ra, rb))] = std::min(ra, rb);
          }
        }
      // Link vertices (edges through v): the (label, group) pairs of their tets. Two groups of one
      // label there touch each other along the edge, which the edges step closes. Groups that
      // share only v (a pinch at a point) are left: no step changes them, and the certificate
      // only counts them.
      int32_t groups = 0; // with one group per label (most vertices), no label meets itself
      for (int32_t a = 0; a < k; ++a) groups += parent[size_t(a)] == a;
      head.assign(link.size(), -1);
      pool.clear();
      for (int32_t a = 0; a < k && !bad && groups > int32_t(labels.size()); ++a) {
        const int32_t L = label(a), g = find(a);
        for (int e = 0; e < 3 && !bad; ++e) {
          const int32_t i = tri[3 * size_t(a) + size_t(e)];
          int32_t it = head[size_t(i)];
          while (it >= 0 && pool[size_t(it)].key != L) it = pool[size_t(it)].next;
          if (it < 0) {
            pool.push_back({L, g, head[size_t(i)]});
            head[size_t(i)] = int32_t(pool.size()) - 1;
          } else {
            bad = pool[size_t(it)].value != g;
          }
        }
      }
      for (int32_t a = 0; a < k; ++a) group[size_t(o + a)] = int32_t(o + find(a));
      if (bad) badFlag[size_t(m)] = 1;
    }
  }
  progress.checkCancel();
  for (int64_t m = 0; m < nm; ++m)
    if (badFlag[size_t(m)]) check.badVertices.push_back(mixedList[size_t(m)]);
  // The band's tets join their elements: unmixed vertices and their groups at mixed ones.
  sets.parent.resize(size_t(np + entries));
  for (int64_t e = 0; e < entries; ++e) sets.parent[size_t(np + e)] = int32_t(np + e);
  auto element = [&](size_t b, int c) {
    const int64_t e = entryOf[4 * b + size_t(c)];
    return e >= 0 ? int32_t(np + group[size_t(e)]) : tets[size_t(band[b])][size_t(c)];
  };
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < int64_t(band.size()); ++b) {
    int32_t r = element(size_t(b), 0);
    for (int c = 1; c < 4; ++c) r = sets.unite(r, element(size_t(b), c));
  }
  if (joins) { // tets joined through a part left out: their elements (a band tet's, or a vertex)
    auto elementOfTet = [&](int32_t t) {
      const auto it = std::lower_bound(band.begin(), band.end(), t);
      return it != band.end() && *it == t ? element(size_t(it - band.begin()), 0) : tets[size_t(t)][0];
    };
    for (const auto& [a, b] : *joins)
      if (mats[size_t(a)] == mats[size_t(b)]) sets.unite(elementOfTet(a), elementOfTet(b));
  }
  progress.checkCancel();
  // One root per label: its tets are in one piece (the elements of a label are its tets' only).
  std::unordered_map<int32_t, int32_t> rootOfLabel;
  auto see = [&](int32_t label, int32_t e) {
    const int32_t r = sets.find(e);
    auto [it, fresh] = rootOfLabel.try_emplace(label, r);
    if (!fresh && it->second != r) check.extraPieces = true;
  };
  for (int64_t v = 0; v < np && !check.extraPieces; ++v)
    if (!mixed[size_t(v)] && first[size_t(v)] != kUnset) see(first[size_t(v)], int32_t(v));
  for (int64_t e = 0; e < entries && !check.extraPieces; ++e)
    if (group[size_t(e)] == e) see(starTet[size_t(e)].label, int32_t(np + e));
  if (!check.extraPieces) return check;
  // Pieces per label: the largest stays; the others are extra (their tets listed when small).
  std::vector<int32_t> pieceOf(static_cast<size_t>(nt)), size(sets.parent.size(), 0), low(sets.parent.size(), -1);
  // Each tet's element's root, on both threads: a tet off the band by its first vertex (the band's
  // tets are given theirs after).
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < nt; ++t) pieceOf[size_t(t)] = sets.find(tets[size_t(t)][0]);
#pragma omp parallel for schedule(static)
  for (int64_t b = 0; b < int64_t(band.size()); ++b) pieceOf[size_t(band[size_t(b)])] = sets.find(element(size_t(b), 0));
  progress.checkCancel();
  for (size_t t = 0; t < size_t(nt); ++t) {
    const int32_t r = pieceOf[t];
    ++size[size_t(r)];
    if (low[size_t(r)] < 0) low[size_t(r)] = int32_t(t); // the piece's first tet
  }
  std::map<int32_t, int32_t> largest; // label -> its largest piece (ties: the one whose first tet comes first)
  for (size_t t = 0; t < size_t(nt); ++t) {
    const int32_t r = pieceOf[t];
    if (low[size_t(r)] != int32_t(t)) continue;
    auto [it, fresh] = largest.try_emplace(mats[t], r);
    if (!fresh && size[size_t(r)] > size[size_t(it->second)]) it->second = r;
  }
  std::vector<uint8_t> kept(sets.parent.size(), 0);
  for (const auto& [label, r] : largest) kept[size_t(r)] = 1;
  std::map<int32_t, std::vector<int32_t>> extra; // first tet -> tets
  for (size_t t = 0; t < size_t(nt); ++t) {
    const int32_t r = pieceOf[t];
    if (kept[size_t(r)]) continue;
    if (size[size_t(r)] <= kSmallPieceTets) extra[low[size_t(r)]].push_back(int32_t(t));
    else check.largeExtraPieces = true;
  }
  for (auto& [r, piece] : extra) check.smallPieces.push_back(std::move(piece));
  return check;
}

} // namespace

LabelRepairCheck checkLabelRepair(const TetMesh& mesh, const std::vector<std::pair<int32_t, int32_t>>& contacts,
                                  Progress& progress, const std::vector<std::pair<int32_t, int32_t>>* joins) {
  return checkWith(
      mesh,
      [&] {
        return [&](int32_t a, int32_t b, int32_t) {
          return std::binary_search(contacts.begin(), contacts.end(), std::pair{std::min(a, b), std::max(a, b)});
        };
      },
      progress, joins);
}

LabelRepairCheck checkLabelRepair(const TetMesh& mesh, LabelContactOracle& contacts, Progress& progress,
                                  const std::vector<std::pair<int32_t, int32_t>>* joins) {
  return checkWith(
      mesh,
      [&] {
        // The pairs this thread has asked about (a few: a search stays in the cache).
        return [&, seen = std::vector<std::pair<uint64_t, bool>>{}](int32_t a, int32_t b, int32_t v) mutable {
          const uint64_t key = labelPairKey(a, b);
          for (const auto& [k, answer] : seen)
            if (k == key) return answer;
          seen.emplace_back(key, contacts.touch(a, b, mesh.points[size_t(v)]));
          return seen.back().second;
        };
      },
      progress, joins);
}

bool LabelContactOracle::touch(int32_t a, int32_t b, const Vec3& near) {
  const std::pair key{std::min(a, b), std::max(a, b)};
  std::lock_guard lock(mutex_);
  if (const auto it = known_.find(key); it != known_.end()) return it->second;
  // The voxels within 2 of the nearest voxel centre (index coordinates put centres at integers);
  // not there: the whole image.
  const Vec3 c = IndexFrame{labels_.grid}.toIndex(near);
  const auto& d = labels_.grid.dims;
  int64_t lo[3], hi[3];
  for (int x = 0; x < 3; ++x) {
    const double r = std::round(c[x]);
    lo[x] = std::clamp<int64_t>(int64_t(std::isfinite(r) ? r : 0) - 2, 0, d[x] - 1);
    hi[x] = std::clamp<int64_t>(int64_t(std::isfinite(r) ? r : 0) + 2, 0, d[x] - 1);
  }
  const bool found = labelsTouchInBox(labels_, a, b, lo, hi) || std::binary_search(scan().begin(), scan().end(), key);
  known_.emplace(key, found);
  return found;
}

const std::vector<std::pair<int32_t, int32_t>>& LabelContactOracle::scan() {
  if (!scanned_) {
    all_ = labelContactPairs(labels_);
    scanned_ = true;
  }
  return all_;
}

const std::vector<std::pair<int32_t, int32_t>>& LabelContactOracle::all() {
  std::lock_guard lock(mutex_);
  return scan();
}

bool labelRepairNeeded(const TetMesh& mesh, const std::vector<std::pair<int32_t, int32_t>>& contacts,
                       Progress& progress) {
  return checkLabelRepair(mesh, contacts, progress).needed();
}

} // namespace tetflow
