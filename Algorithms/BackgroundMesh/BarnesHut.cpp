#include "BarnesHut.h"

#include <algorithm>
#include <cmath>

#include "Algorithms/Core/Errors.h"

namespace tetflow {

BarnesHutTree::BarnesHutTree(const std::vector<Vec3>& points, const std::vector<double>& charges) {
  if (points.size() != charges.size()) throw ProcessingError("Barnes-Hut tree: points and charges differ in number");
  if (points.size() >= size_t(INT32_MAX)) throw ProcessingError("Barnes-Hut tree: too many charges");
  pos_ = points;
  q_ = charges;
  index_.resize(points.size());
  for (size_t i = 0; i < points.size(); ++i) index_[i] = int64_t(i);
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const Vec3& p : points)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  // A cube around the points, so cells stay cubes and `size` is their edge.
  double edge = 0;
  for (int a = 0; a < 3; ++a) edge = std::max(edge, hi[a] - lo[a]);
  edge = std::max(edge, 1e-9) * (1 + 1e-9);
  for (int a = 0; a < 3; ++a) hi[a] = lo[a] + edge;
  nodes_.reserve(points.size() / 2 + 16);
  nodes_.emplace_back();
  if (!points.empty()) build(0, 0, int32_t(points.size()), lo, hi, 0);
}

void BarnesHutTree::build(int32_t node, int32_t begin, int32_t end, const Vec3& lo, const Vec3& hi, int depth) {
  {
    Node& n = nodes_[size_t(node)];
    n.begin = begin;
    n.end = end;
    n.size = hi[0] - lo[0];
    double q = 0;
    Vec3 c{0, 0, 0};
    for (int32_t i = begin; i < end; ++i) {
      q += q_[size_t(i)];
      c = c + q_[size_t(i)] * pos_[size_t(i)];
    }
    n.charge = q;
    if (q > 0) {
      n.centre = (1.0 / q) * c;
    } else { // no charge: the cell's centre (never used for a field, only for distances)
      n.centre = 0.5 * (lo + hi);
    }
  }
  if (end - begin <= kLeafSize || depth >= 48) return;
  const Vec3 mid = 0.5 * (lo + hi);
  // Counting sort of [begin, end) by octant.
  std::array<int32_t, 9> start{};
  std::vector<uint8_t> oct(size_t(end - begin));
  for (int32_t i = begin; i < end; ++i) {
    const Vec3& p = pos_[size_t(i)];
    const uint8_t o = uint8_t((p[0] >= mid[0]) | (p[1] >= mid[1]) << 1 | (p[2] >= mid[2]) << 2);
    oct[size_t(i - begin)] = o;
    ++start[size_t(o) + 1];
  }
  for (int o = 0; o < 8; ++o) start[size_t(o) + 1] += start[size_t(o)];
  {
    std::vector<Vec3> p2(size_t(end - begin));
    std::vector<double> q2(size_t(end - begin));
    std::vector<int64_t> i2(size_t(end - begin));
    std::array<int32_t, 8> at;
    for (int o = 0; o < 8; ++o) at[size_t(o)] = start[size_t(o)];
    for (int32_t i = begin; i < end; ++i) {
      const int32_t k = at[oct[size_t(i - begin)]]++;
      p2[size_t(k)] = pos_[size_t(i)];
      q2[size_t(k)] = q_[size_t(i)];
      i2[size_t(k)] = index_[size_t(i)];
    }
    std::copy(p2.begin(), p2.end(), pos_.begin() + begin);
    std::copy(q2.begin(), q2.end(), q_.begin() + begin);
    std::copy(i2.begin(), i2.end(), index_.begin() + begin);
  }
  int children = 0;
  for (int o = 0; o < 8; ++o) children += start[size_t(o) + 1] > start[size_t(o)];
  const int32_t first = int32_t(nodes_.size());
  nodes_.resize(nodes_.size() + size_t(children));
  nodes_[size_t(node)].firstChild = first;
  nodes_[size_t(node)].children = children;
  int c = 0;
  for (int o = 0; o < 8; ++o) {
    if (start[size_t(o) + 1] == start[size_t(o)]) continue;
    Vec3 clo, chi;
    for (int a = 0; a < 3; ++a) {
      const bool upper = (o >> a) & 1;
      clo[a] = upper ? mid[a] : lo[a];
      chi[a] = upper ? hi[a] : mid[a];
    }
    build(first + c, begin + start[size_t(o)], begin + start[size_t(o) + 1], clo, chi, depth + 1);
    ++c;
  }
}

BarnesHutTree::Sample BarnesHutTree::evaluate(const Vec3& x, int64_t self, double theta, double softening) const {
  Sample s;
  if (pos_.empty()) return s;
  const double soft2 = softening * softening;
  auto add = [&](const Vec3& y, double q) {
    const Vec3 d = x - y;
    const double r2 = std::max(dot(d, d), soft2);
    const double r = std::sqrt(r2);
    s.potential += q / r;
    s.field = s.field + (q / (r2 * r)) * d;
  };
  auto direct = [&](const Node& n) {
    for (int32_t i = n.begin; i < n.end; ++i)
      if (index_[size_t(i)] != self) add(pos_[size_t(i)], q_[size_t(i)]);
  };
  const double theta2 = theta * theta;
  // A cell far enough (edge < theta * distance to its centre of charge) counts as one charge there;
  // a nearer leaf is summed directly; a nearer inner cell is opened. Each cell is judged when its
  // parent is opened, so only cells to open go on the stack.
  auto far = [&](const Node& n) {
    const Vec3 d = x - n.centre;
    return n.size * n.size < theta2 * dot(d, d);
  };
  const Node& root = nodes_[0];
  if (root.charge <= 0) return s;
  if (far(root)) {
    add(root.centre, root.charge);
    return s;
  }
  if (root.firstChild < 0) {
    direct(root);
    return s;
  }
  int32_t stack[512];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[size_t(stack[--top])];
    for (int32_t c = n.firstChild; c < n.firstChild + n.children; ++c) {
      const Node& k = nodes_[size_t(c)];
      if (k.charge <= 0) continue;
      if (far(k)) add(k.centre, k.charge);
      else if (k.firstChild < 0) direct(k);
      else stack[top++] = c;
    }
  }
  return s;
}

} // namespace tetflow
