// Mesh improvement: the topological operations (see MeshImprovement.h). Each builds its new tets
// on the side, keeps them only when every one is positive and the worst of them scores above the
// worst of the tets they replace, and then re-tiles the same region with them.
#include <algorithm>
#include <cmath>
#include <limits>

#include "Algorithms/MeshImprovement/Improver.h"

namespace tetflow::improve_detail {

bool samePermutationParity(const Tet& q, int32_t a, int32_t b, int32_t c, int32_t d) {
  const int32_t w[4] = {a, b, c, d};
  int pos[4];
  for (int i = 0; i < 4; ++i) {
    pos[i] = -1;
    for (int j = 0; j < 4; ++j)
      if (q[j] == w[i]) pos[i] = j;
  }
  int inversions = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) inversions += pos[i] > pos[j];
  return inversions % 2 == 0;
}

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

// Best triangulation of a polygon of ring vertices (in ring order) around the edge (a, b), by
// dynamic programming over its sub-polygons: triangle (i, k, j), i < k < j, gives the tets
// (p_k, p_i, p_j, a) and (p_i, p_k, p_j, b). Returns the worst score of those tets (+inf for a
// polygon of two vertices) and appends the triangles to *tris.
double Improver::triangulateRing(const std::vector<int32_t>& poly, int32_t a, int32_t b,
                                 std::vector<std::array<int32_t, 3>>* tris) const {
  const size_t n = poly.size();
  if (n < 3) return kInf;
  auto tri = [&](size_t i, size_t k, size_t j) {
    return std::min(score({poly[k], poly[i], poly[j], a}), score({poly[i], poly[k], poly[j], b}));
  };
  double Q[kMaxRing + 1][kMaxRing + 1];
  int K[kMaxRing + 1][kMaxRing + 1];
  for (size_t i = 0; i + 1 < n; ++i) Q[i][i + 1] = kInf;
  for (size_t len = 2; len < n; ++len)
    for (size_t i = 0; i + len < n; ++i) {
      const size_t j = i + len;
      Q[i][j] = -kInf;
      K[i][j] = -1;
      for (size_t k = i + 1; k < j; ++k) {
        const double q = std::min({Q[i][k], Q[k][j], tri(i, k, j)});
        if (q > Q[i][j]) {
          Q[i][j] = q;
          K[i][j] = int(k);
        }
      }
    }
  if (tris) {
    std::vector<std::pair<size_t, size_t>> stack{{0, n - 1}};
    while (!stack.empty()) {
      const auto [i, j] = stack.back();
      stack.pop_back();
      if (j < i + 2) continue;
      const size_t k = size_t(K[i][j]);
      tris->push_back({poly[k], poly[i], poly[j]});
      stack.push_back({i, k});
      stack.push_back({k, j});
    }
  }
  return Q[0][n - 1];
}

bool Improver::removeEdge(int32_t a, int32_t b, bool acrossInterface, std::vector<int32_t>& touched) {
  std::vector<int32_t> around, ring;
  starOf(a, around);
  for (int32_t t : around)
    if (std::find(m_.tets[t].begin(), m_.tets[t].end(), b) != m_.tets[t].end()) ring.push_back(t);
  const size_t n = ring.size();
  if (n < 3 || n > size_t(kMaxRing)) return false;
  // The ring of vertices around the edge, in the order c -> d of the positive tets (a, b, c, d);
  // ringTet[i] lies between r[i] and r[i + 1].
  std::vector<std::pair<int32_t, int32_t>> next; // (c, d)
  for (int32_t t : ring) {
    int32_t o[2], k = 0;
    for (int32_t u : m_.tets[t])
      if (u != a && u != b) o[k++] = u;
    if (!samePermutationParity(m_.tets[t], a, b, o[0], o[1])) std::swap(o[0], o[1]);
    next.push_back({o[0], o[1]});
  }
  std::vector<int32_t> r{next[0].first}, ringTet;
  for (size_t i = 0; i < n; ++i) {
    auto it = std::find_if(next.begin(), next.end(), [&](const auto& e) { return e.first == r.back(); });
    if (it == next.end()) return false; // open ring: the edge is on the boundary
    ringTet.push_back(ring[size_t(it - next.begin())]);
    r.push_back(it->second);
  }
  if (r.back() != r[0]) return false;
  r.pop_back();
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j)
      if (r[i] == r[j]) return false;
  // Materials along the ring: one material, or two arcs of at least two tets each (the edge lies
  // on the interface between them, which the removal re-diagonalises: the interface triangles
  // (a, b, r_s) and (a, b, r_e) become (r_s, r_e, a) and (r_s, r_e, b)).
  std::vector<size_t> changes;
  for (size_t i = 0; i < n; ++i)
    if (m_.materials[size_t(ringTet[i])] != m_.materials[size_t(ringTet[(i + n - 1) % n])]) changes.push_back(i);
  std::vector<std::vector<int32_t>> polys;
  std::vector<int32_t> polyMat, polyOrigin; // material, and the tet whose cell values it takes
  if (changes.empty() != !acrossInterface) return false;
  if (changes.empty()) {
    polys.push_back(r);
    polyMat.push_back(m_.materials[size_t(ringTet[0])]);
    polyOrigin.push_back(origin_[size_t(ringTet[0])]);
  } else if (changes.size() == 2) {
    for (int arc = 0; arc < 2; ++arc) {
      const size_t from = changes[size_t(arc)], to = changes[size_t(1 - arc)];
      const size_t tets = (to + n - from) % n;
      if (tets < 2) return false; // the arc would vanish
      std::vector<int32_t> poly;
      for (size_t i = from;; i = (i + 1) % n) {
        poly.push_back(r[i]);
        if (i == to) break;
      }
      polys.push_back(poly);
      polyMat.push_back(m_.materials[size_t(ringTet[from])]);
      polyOrigin.push_back(origin_[size_t(ringTet[from])]);
    }
  } else {
    return false;
  }
  const double before = worstOf(ring);
  double after = kInf;
  std::vector<std::vector<std::array<int32_t, 3>>> tris(polys.size());
  for (size_t p = 0; p < polys.size(); ++p) after = std::min(after, triangulateRing(polys[p], a, b, &tris[p]));
  if (!(after > before + 1e-9) || !(after > 0)) return false;
  // Volumes: re-tiling one material changes nothing; moving the interface moves the volume of the
  // tet (a, b, r_s, r_e) from one material to the other, which must fit the budget.
  std::vector<double> delta(labels_.size(), 0.0);
  if (polys.size() == 2) {
    for (int32_t t : ring) delta[labelIndex(m_.materials[size_t(t)])] -= m_.tetVolume(size_t(t));
    for (size_t p = 0; p < polys.size(); ++p)
      for (const auto& tr : tris[p]) {
        const Tet ta{tr[0], tr[1], tr[2], a}, tb{tr[1], tr[0], tr[2], b};
        for (const Tet& q : {ta, tb})
          delta[labelIndex(polyMat[p])] += signedTetVolume(m_.points[q[0]], m_.points[q[1]], m_.points[q[2]], m_.points[q[3]]);
      }
    for (size_t l = 0; l < labels_.size(); ++l)
      if (delta[l] != 0.0 && std::abs(change_[l] + delta[l]) > budget_[l]) return false;
  }
  for (int32_t t : ring) killTet(t);
  for (size_t p = 0; p < polys.size(); ++p)
    for (const auto& tr : tris[p]) {
      // tr = (p_k, p_i, p_j): the tets (p_k, p_i, p_j, a) and (p_i, p_k, p_j, b).
      touched.push_back(addTet({tr[0], tr[1], tr[2], a}, polyMat[p], polyOrigin[p]));
      touched.push_back(addTet({tr[1], tr[0], tr[2], b}, polyMat[p], polyOrigin[p]));
    }
  commitVolumeChange(delta);
  ++(polys.size() == 2 ? st_.interfaceFlips : st_.edgeRemovals);
  return true;
}

bool Improver::flip23(int32_t t, int face, std::vector<int32_t>& touched) {
  const int32_t u = oppositeTet(t, face);
  if (u < 0 || m_.materials[u] != m_.materials[t]) return false;
  const Tet& q = m_.tets[t];
  const int32_t p = q[face];
  int32_t x = q[kTetFaceVertices[face][0]], y = q[kTetFaceVertices[face][1]];
  const int32_t z = q[kTetFaceVertices[face][2]];
  if (!samePermutationParity(q, x, y, z, p)) std::swap(x, y); // (x, y, z, p) positive
  int32_t apex = -1;
  for (int32_t w : m_.tets[u])
    if (w != x && w != y && w != z) apex = w;
  const Tet n0{x, y, apex, p}, n1{y, z, apex, p}, n2{z, x, apex, p};
  const double after = std::min({score(n0), score(n1), score(n2)});
  const double before = std::min(score(q), score(m_.tets[u]));
  if (!(after > before + 1e-9) || !(after > 0)) return false;
  const int32_t mat = m_.materials[t], origin = origin_[t];
  killTet(t);
  killTet(u);
  for (const Tet& nt : {n0, n1, n2}) touched.push_back(addTet(nt, mat, origin));
  ++st_.flips23;
  return true;
}

bool Improver::collapseInto(int32_t t, std::vector<int32_t>& touched) {
  // A vertex of t whose tets are all of one material and off the boundary goes into another
  // corner of t: the best of those merges that improves its star.
  const Tet q = m_.tets[t];
  int32_t bestU = -1, bestV = -1;
  double bestScore = -kInf;
  std::vector<int32_t> star;
  for (int32_t u : q) {
    starOf(u, star);
    const LocalStar s = localStar(star);
    if (classify(u, s).dof != 3) continue;
    const double before = worstOf(star);
    for (int32_t v : q) {
      if (v == u) continue;
      double w = kInf;
      for (const Tet& st : s.tets) {
        if (std::find(st.begin(), st.end(), v) != st.end()) continue;
        w = std::min(w, scoreWith(st, u, m_.points[v]));
        if (w <= before) break;
      }
      if (w > before + 1e-9 && w > 0 && w > bestScore) {
        bestScore = w;
        bestU = u;
        bestV = v;
      }
    }
  }
  if (bestU < 0) return false;
  starOf(bestU, star);
  const int32_t mat = m_.materials[star[0]], origin = origin_[t];
  std::vector<Tet> created;
  for (int32_t s : star) {
    Tet nt = m_.tets[s];
    if (std::find(nt.begin(), nt.end(), bestV) != nt.end()) continue;
    for (auto& w : nt)
      if (w == bestU) w = bestV;
    created.push_back(nt);
  }
  for (int32_t s : star) killTet(s);
  for (const Tet& nt : created) touched.push_back(addTet(nt, mat, origin));
  ++st_.collapses;
  return true;
}

bool Improver::splitEdge(int32_t t, std::vector<int32_t>& touched) {
  // Edges of t longest first; the first split whose new vertex can be placed so that the halves
  // beat the tets they replace is kept.
  const Tet q = m_.tets[t];
  std::array<std::pair<double, int>, 6> order;
  for (int e = 0; e < 6; ++e) {
    const auto [i, j] = kTetEdges[size_t(e)];
    order[size_t(e)] = {-norm(m_.points[q[size_t(i)]] - m_.points[q[size_t(j)]]), e};
  }
  std::sort(order.begin(), order.end());
  std::vector<int32_t> around, ring;
  for (const auto& [negLen, e] : order) {
    const int32_t a = q[size_t(kTetEdges[size_t(e)][0])], b = q[size_t(kTetEdges[size_t(e)][1])];
    starOf(a, around);
    ring.clear();
    for (int32_t s : around)
      if (std::find(m_.tets[s].begin(), m_.tets[s].end(), b) != m_.tets[s].end()) ring.push_back(s);
    const double before = worstOf(ring);
    const int32_t mid = int32_t(m_.points.size());
    m_.points.push_back(0.5 * (m_.points[a] + m_.points[b]));
    LocalStar s;
    for (int32_t r : ring)
      for (int32_t end : {a, b}) {
        Tet nt = m_.tets[r];
        for (auto& w : nt)
          if (w == end) w = mid;
        s.tets.push_back(nt);
        s.mats.push_back(m_.materials[r]);
      }
    if (p_.fixSurfaces && classify(mid, s).dof != 3) { // the edge is on a kept surface
      m_.points.pop_back();
      continue;
    }
    Vec3 pos;
    std::vector<double> delta;
    const double after = optimizePosition(mid, s, pos, delta);
    if (!(after > before + 1e-9) || !(after > 0)) {
      m_.points.pop_back();
      continue;
    }
    m_.points[size_t(mid)] = pos;
    commitVolumeChange(delta);
    splitEnds_.push_back({a, b});
    std::vector<int32_t> origins;
    for (int32_t r : ring) origins.push_back(origin_[r]);
    for (int32_t r : ring) killTet(r);
    for (size_t i = 0; i < s.tets.size(); ++i) touched.push_back(addTet(s.tets[i], s.mats[i], origins[i / 2]));
    ++st_.insertions;
    return true;
  }
  return false;
}

bool Improver::onAxisPlane(int32_t x, int32_t y, int32_t z) const {
  const Vec3 n = cross(m_.points[size_t(y)] - m_.points[size_t(x)], m_.points[size_t(z)] - m_.points[size_t(x)]);
  for (int ax = 0; ax < 3; ++ax)
    if (std::abs(n[size_t(ax)]) >= (1.0 - 1e-12) * norm(n)) return true;
  return false;
}

bool Improver::peelCap(int32_t t, std::vector<int32_t>& touched) {
  // A cap on a curved boundary: three faces on the boundary, none on an axis-aligned plane (a box
  // face stays the domain), the fourth corner in no other tet, and the remaining face against a
  // tet of the same material (so no component or contact goes with it). Removing it hands its
  // volume to the outside, within the material's volume budget.
  const Tet q = m_.tets[size_t(t)];
  int inner = -1, innerCount = 0;
  int32_t neighbour = -1;
  for (int f = 0; f < 4; ++f)
    if (const int32_t o = oppositeTet(t, f); o >= 0) {
      inner = f;
      neighbour = o;
      ++innerCount;
    }
  if (innerCount != 1) return false;
  const int32_t apex = q[size_t(inner)];
  std::vector<int32_t> star;
  starOf(apex, star);
  if (star.size() != 1) return false;
  const int32_t mat = m_.materials[size_t(t)];
  if (m_.materials[size_t(neighbour)] != mat) return false;
  for (int f = 0; f < 4; ++f)
    if (f != inner && onAxisPlane(q[size_t(kTetFaceVertices[f][0])], q[size_t(kTetFaceVertices[f][1])],
                                  q[size_t(kTetFaceVertices[f][2])]))
      return false;
  (void)touched; // nothing created: the tet's neighbour keeps its score
  if (!removeWithinBudget(t)) return false;
  ++st_.capsRemoved;
  return true;
}

bool Improver::removeWithinBudget(int32_t t) {
  const Tet& q = m_.tets[size_t(t)];
  const size_t l = labelIndex(m_.materials[size_t(t)]);
  const double vol = signedTetVolume(m_.points[size_t(q[0])], m_.points[size_t(q[1])], m_.points[size_t(q[2])],
                                     m_.points[size_t(q[3])]);
  if (std::abs(change_[l] - vol) > budget_[l]) return false;
  change_[l] -= vol;
  killTet(t);
  return true;
}

bool Improver::peelBoundaryTet(int32_t t) {
  // A tet with one to three faces on a curved boundary whose other faces lie against tets of its
  // own material (see MeshImprovement.h, "peel", the last resort). It goes when the boundary stays
  // a manifold at each of its corners (the boundary faces around the corner, after, form one
  // cycle: no edge or corner where two sheets of the surface touch), its material stays connected
  // around it, no face on an axis-aligned plane is involved (a box face stays the domain), and its
  // volume fits the material's budget.
  const Tet q = m_.tets[size_t(t)];
  const int32_t mat = m_.materials[size_t(t)];
  std::vector<int32_t> sameNeighbours;
  int onBoundary = 0;
  for (int f = 0; f < 4; ++f) {
    const int32_t o = oppositeTet(t, f);
    if (o < 0) {
      ++onBoundary;
      continue;
    }
    if (m_.materials[size_t(o)] != mat) return false;
    sameNeighbours.push_back(o);
  }
  if (onBoundary == 0 || onBoundary == 4) return false;
  std::vector<int32_t> star, region;
  std::vector<std::array<int32_t, 2>> link;
  for (int32_t v : q) {
    starOf(v, star);
    link.clear();
    for (int32_t u : star) {
      if (u != t && m_.materials[size_t(u)] == mat) region.push_back(u);
      if (u == t) continue;
      const Tet& w = m_.tets[size_t(u)];
      for (int g = 0; g < 4; ++g) {
        if (w[size_t(g)] == v) continue; // the face omitting v
        const int32_t o = oppositeTet(u, g);
        if (o >= 0 && o != t) continue;
        const int* fv = kTetFaceVertices[g];
        if (onAxisPlane(w[size_t(fv[0])], w[size_t(fv[1])], w[size_t(fv[2])])) return false;
        std::array<int32_t, 2> e{};
        int k = 0;
        for (int j = 0; j < 3; ++j)
          if (w[size_t(fv[j])] != v) e[size_t(k++)] = w[size_t(fv[j])];
        link.push_back(e);
      }
    }
    if (star.size() == 1) continue; // v goes with the tet
    // One cycle: every link vertex on exactly two link edges, and a walk covers every edge.
    std::vector<int32_t> ends;
    for (const auto& e : link) ends.insert(ends.end(), e.begin(), e.end());
    std::sort(ends.begin(), ends.end());
    if (ends.empty()) return false;
    for (size_t i = 0; i < ends.size(); i += 2)
      if (i + 1 >= ends.size() || ends[i] != ends[i + 1] || (i + 2 < ends.size() && ends[i + 2] == ends[i])) return false;
    std::vector<uint8_t> used(link.size(), 0);
    int32_t at = link[0][1];
    used[0] = 1;
    size_t walked = 1;
    for (bool moved = true; moved;) {
      moved = false;
      for (size_t i = 0; i < link.size(); ++i)
        if (!used[i] && (link[i][0] == at || link[i][1] == at)) {
          at = link[i][0] == at ? link[i][1] : link[i][0];
          used[i] = 1;
          ++walked;
          moved = true;
          break;
        }
    }
    if (walked != link.size()) return false;
  }
  // The material stays connected: its tets around the corners, without t, join every neighbour.
  if (sameNeighbours.size() > 1) {
    std::sort(region.begin(), region.end());
    region.erase(std::unique(region.begin(), region.end()), region.end());
    std::vector<uint8_t> seen(region.size(), 0);
    std::vector<int32_t> queue{sameNeighbours[0]};
    seen[size_t(std::lower_bound(region.begin(), region.end(), sameNeighbours[0]) - region.begin())] = 1;
    for (size_t h = 0; h < queue.size(); ++h)
      for (int g = 0; g < 4; ++g) {
        const int32_t o = oppositeTet(queue[h], g);
        if (o < 0) continue;
        const auto it = std::lower_bound(region.begin(), region.end(), o);
        if (it == region.end() || *it != o || seen[size_t(it - region.begin())]) continue;
        seen[size_t(it - region.begin())] = 1;
        queue.push_back(o);
      }
    for (int32_t n : sameNeighbours)
      if (!seen[size_t(std::lower_bound(region.begin(), region.end(), n) - region.begin())]) return false;
  }
  if (!removeWithinBudget(t)) return false;
  ++st_.boundaryPeels;
  return true;
}

} // namespace tetflow::improve_detail
