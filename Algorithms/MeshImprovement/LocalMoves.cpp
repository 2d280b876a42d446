// Mesh improvement: how a vertex may move (from the labels around it) and the constrained
// pattern search that moves it (see MeshImprovement.h).
#include <algorithm>
#include <cmath>

#include "Algorithms/Core/PatternSearch.h"
#include "Algorithms/MeshImprovement/Improver.h"

namespace tetflow::improve_detail {

namespace {

// Faces of a tet containing its local corner `c`: the three that omit another corner.
struct FaceUse {
  std::array<int32_t, 2> others; // the face's two other vertices, sorted
  size_t tet;                    // index in the LocalStar
  Vec3 areaNormal;               // outward from that tet, length = twice the area
};

bool parallel(const Vec3& a, const Vec3& b) {
  const double na = norm(a), nb = norm(b);
  return na > 0 && nb > 0 && norm(cross(a, b)) <= 1e-6 * na * nb;
}

// Distinct directions (up to sign) among unit-length vectors.
void addDirection(std::vector<Vec3>& dirs, const Vec3& n) {
  for (const Vec3& d : dirs)
    if (parallel(d, n)) return;
  dirs.push_back(n);
}

uint8_t axisAlignedBits(const std::vector<Vec3>& normals) {
  uint8_t bits = 0;
  for (const Vec3& n : normals) {
    const double len = norm(n);
    for (int a = 0; a < 3; ++a)
      if (std::abs(n[a]) >= (1.0 - 1e-12) * len) bits |= uint8_t(1u << a);
  }
  return bits;
}

// A boundary patch around a vertex is smooth when every face's normal is within
// kSmoothBoundaryDeg of the patch's mean normal (a box edge or corner is not: 45 degrees or more).
constexpr double kSmoothBoundaryDeg = 30.0;
bool smoothBoundary(const std::vector<Vec3>& faces, const Vec3& sum) {
  const double ns = norm(sum);
  if (faces.size() < 2 || !(ns > 0)) return false;
  const double c = std::cos(kSmoothBoundaryDeg * 3.14159265358979323846 / 180.0);
  for (const Vec3& n : faces)
    if (dot(n, sum) < c * norm(n) * ns) return false;
  return true;
}

} // namespace

Constraint Improver::classify(int32_t v, const LocalStar& s) const {
  std::vector<FaceUse> faces;
  faces.reserve(3 * s.tets.size());
  std::vector<int32_t> mats;
  for (size_t i = 0; i < s.tets.size(); ++i) {
    const Tet& q = s.tets[i];
    if (std::find(mats.begin(), mats.end(), s.mats[i]) == mats.end()) mats.push_back(s.mats[i]);
    for (int f = 0; f < 4; ++f) {
      const int* fv = kTetFaceVertices[f];
      if (q[f] == v) continue; // the face omitting v does not contain it
      // Outward normal of face f: the face's corners in the order that makes the omitted corner
      // lie on the negative side.
      const Vec3 &a = m_.points[q[fv[0]]], &b = m_.points[q[fv[1]]], &c = m_.points[q[fv[2]]];
      Vec3 n = cross(b - a, c - a);
      if (dot(n, m_.points[q[f]] - a) > 0) n = -1.0 * n;
      std::array<int32_t, 2> others{};
      int k = 0;
      for (int j = 0; j < 3; ++j)
        if (q[fv[j]] != v) others[k++] = q[fv[j]];
      if (others[0] > others[1]) std::swap(others[0], others[1]);
      faces.push_back({others, i, n});
    }
  }
  std::sort(faces.begin(), faces.end(), [](const FaceUse& x, const FaceUse& y) { return x.others < y.others; });
  std::vector<Vec3> boundary; // distinct boundary normals
  std::vector<Vec3> boundaryFaces; // every boundary face's area normal
  Vec3 boundarySum{0, 0, 0};
  // Interface surfaces: per label pair, the summed area normal (oriented out of the lower label).
  std::vector<std::pair<std::array<int32_t, 2>, Vec3>> surfaces;
  for (size_t i = 0; i < faces.size();) {
    size_t j = i;
    while (j < faces.size() && faces[j].others == faces[i].others) ++j;
    if (j - i == 1) {
      addDirection(boundary, faces[i].areaNormal);
      boundaryFaces.push_back(faces[i].areaNormal);
      boundarySum = boundarySum + faces[i].areaNormal;
    } else if (j - i == 2) {
      const int32_t la = s.mats[faces[i].tet], lb = s.mats[faces[i + 1].tet];
      if (la != lb) {
        const std::array<int32_t, 2> key{std::min(la, lb), std::max(la, lb)};
        const Vec3 n = la < lb ? faces[i].areaNormal : faces[i + 1].areaNormal;
        auto it = std::find_if(surfaces.begin(), surfaces.end(), [&](const auto& e) { return e.first == key; });
        if (it == surfaces.end()) surfaces.push_back({key, n});
        else it->second = it->second + n;
      }
    } else {
      return {}; // a face of more than two tets: leave it alone
    }
    i = j;
  }
  if (p_.fixSurfaces && (!boundary.empty() || mats.size() > 1)) return {}; // on a kept surface
  Constraint c;
  c.keepAxes = axisAlignedBits(boundary);
  auto unit = [](const Vec3& d) { return (1.0 / norm(d)) * d; };
  auto usable = [](const Vec3& d) { return norm(d) > 0 && std::isfinite(norm(d)); };
  const size_t km = mats.size(), nb = boundary.size();
  if (nb == 0) {
    if (km == 1) {
      c.dof = 3;
    } else if (km == 2 && surfaces.size() == 1 && usable(surfaces[0].second)) {
      c.dof = 2;
      c.dir = unit(surfaces[0].second);
    } else if (km == 3 && surfaces.size() >= 2) {
      // A curve where three materials meet: along the intersection of its two largest surfaces.
      std::sort(surfaces.begin(), surfaces.end(),
                [](const auto& x, const auto& y) { return norm(x.second) > norm(y.second); });
      const Vec3 d = cross(surfaces[0].second, surfaces[1].second);
      if (usable(d) && norm(d) > 1e-6 * norm(surfaces[0].second) * norm(surfaces[1].second)) {
        c.dof = 1;
        c.dir = unit(d);
      }
    }
  } else if (nb == 1) {
    if (km == 1) {
      c.dof = 2;
      c.dir = unit(boundary[0]);
    } else if (km == 2 && surfaces.size() == 1) {
      const Vec3 d = cross(boundary[0], surfaces[0].second);
      if (usable(d) && norm(d) > 1e-6 * norm(boundary[0]) * norm(surfaces[0].second)) {
        c.dof = 1;
        c.dir = unit(d);
      }
    }
  } else if (smoothBoundary(boundaryFaces, boundarySum)) {
    // A curved but smooth boundary (a stripped exterior): it is a surface between the material(s)
    // and the outside like any interface, so the vertex slides in its mean tangent plane (one
    // material) or along its curve with the one interface (two), under the same volume budget.
    if (km == 1) {
      c.dof = 2;
      c.dir = unit(boundarySum);
    } else if (km == 2 && surfaces.size() == 1) {
      const Vec3 d = cross(boundarySum, surfaces[0].second);
      if (usable(d) && norm(d) > 1e-6 * norm(boundarySum) * norm(surfaces[0].second)) {
        c.dof = 1;
        c.dir = unit(d);
      }
    }
  } else if (nb == 2 && km == 1) {
    c.dof = 1;
    c.dir = unit(cross(boundary[0], boundary[1]));
  }
  if (lastResort_ && c.dof < 3 && c.keepAxes == 0) {
    // The last resort: a vertex on an interface, a curve or corner where materials meet, or a
    // crease of a curved boundary (where a stripped exterior's label repair left a voxel's step)
    // moves freely, as far as a constrained vertex, under the volume budget. Its surroundings'
    // labels and connectivity stay; only the box's planar faces keep their vertices on them.
    c.dof = 3;
    c.constrainedReach = true;
  }
  return c;
}

double Improver::optimizePosition(int32_t v, const LocalStar& s, Vec3& bestPos, std::vector<double>& delta) const {
  delta.assign(labels_.size(), 0.0);
  const Vec3 start = m_.points[v];
  bestPos = start;
  // The worst score of the star with v at `at`; as soon as it is <= floor, that value. Most trials
  // fail, and mostly on the tet the previous one failed on: that tet moves to the front, so a
  // failing trial usually costs one tet. (The order changes no decision: a trial fails when any
  // tet scores <= floor, and the value of one that passes is the minimum over all of them.)
  std::vector<Tet> tets = s.tets;
  auto worstAt = [&](const Vec3& at, double floor) {
    WorstScore w(p_.min_angle, p_.max_angle);
    double worst = 1e9;
    for (size_t i = 0; i < tets.size(); ++i)
      if (addWith(w, tets[i], v, at) && (worst = w.value()) <= floor) {
        std::swap(tets[i], tets[0]);
        return worst;
      }
    return worst;
  };
  double best = worstAt(start, -1e9);
  const Constraint c = classify(v, s);
  if (c.dof == 0) return best;
  double len = 0;
  for (const Tet& q : s.tets)
    for (int32_t u : q) len = std::max(len, norm(m_.points[u] - start));
  // Per-label volume change of moving v to `at`, and whether every label stays within budget.
  std::vector<double> trialDelta(labels_.size());
  auto withinBudget = [&](const Vec3& at) {
    std::fill(trialDelta.begin(), trialDelta.end(), 0.0);
    for (size_t i = 0; i < s.tets.size(); ++i) {
      const Tet& q = s.tets[i];
      Vec3 p[4], p0[4];
      for (int k = 0; k < 4; ++k) p[k] = p0[k] = m_.points[q[k]];
      for (int k = 0; k < 4; ++k)
        if (q[k] == v) p[k] = at;
      trialDelta[labelIndex(s.mats[i])] += signedTetVolume(p[0], p[1], p[2], p[3]) - signedTetVolume(p0[0], p0[1], p0[2], p0[3]);
    }
    for (size_t l = 0; l < labels_.size(); ++l)
      if (trialDelta[l] != 0.0 && std::abs(change_[l] + trialDelta[l]) > budget_[l]) return false;
    return true;
  };
  PatternSearch search;
  search.dof = c.dof;
  search.dir = c.dir;
  search.initialStep = 0.15 * len;
  search.finalStep = 0.002 * len;
  search.maxMove = c.dof == 3 && !c.constrainedReach ? 0.3 * len : 0.1 * len;
  // A trial counts only within the volume budget; its per-label change is kept when accepted.
  bestPos = search.run(
      start, best,
      [&](const Vec3& at, double floor) {
        const double w = worstAt(at, floor);
        return w > floor && !withinBudget(at) ? floor : w;
      },
      [&](Vec3& trial) {
        for (int a = 0; a < 3; ++a)
          if (c.keepAxes >> a & 1) trial[a] = start[a];
      },
      [&] { delta = trialDelta; });
  return best;
}

void Improver::commitVolumeChange(const std::vector<double>& delta) {
  for (size_t l = 0; l < change_.size(); ++l) change_[l] += delta[l];
}

bool Improver::smoothVertex(int32_t v, std::vector<int32_t>& touched) {
  std::vector<int32_t> ts;
  starOf(v, ts);
  const LocalStar s = localStar(ts);
  const double before = worstOf(ts);
  Vec3 pos;
  std::vector<double> delta;
  const double after = optimizePosition(v, s, pos, delta);
  if (!(after > before + 1e-9) || pos == m_.points[v]) return false;
  m_.points[v] = pos;
  commitVolumeChange(delta);
  touched.insert(touched.end(), ts.begin(), ts.end());
  ++st_.smoothed;
  return true;
}

} // namespace tetflow::improve_detail
