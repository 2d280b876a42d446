#pragma once
// Barnes-Hut octree for the Coulomb field of positive point charges (seed §5.4.3, after Barnes &
// Hut 1986), used by the electrostatic particle system.
//
// Units are Gaussian: a charge q at y gives the potential q / |x - y| and the field
// q (x - y) / |x - y|^3 at x. The tree holds the charges in cells of at most kLeafSize; every
// cell keeps its total charge and its centre of charge. A cell, leaves included, is replaced by a
// point charge at its centre of charge when its edge / distance < theta (the seed's opening
// criterion); otherwise an inner cell's children are visited and a leaf's charges are summed
// directly. theta = 0 sums everything directly. The charge at the query's own index is skipped,
// and pairs closer than `softening` are counted at that distance (so coincident charges give a
// finite push, not a division by zero).
#include <array>
#include <cstdint>
#include <vector>

#include "Algorithms/Core/Geometry.h"

namespace tetflow {

class BarnesHutTree {
public:
  static constexpr int kLeafSize = 8;
  // Charges must be >= 0; the tree keeps copies of the positions (reordered internally).
  BarnesHutTree(const std::vector<Vec3>& points, const std::vector<double>& charges);

  struct Sample {
    Vec3 field{0, 0, 0};
    double potential = 0.0;
  };
  // Field and potential at x of every charge except the one with index `self` (-1: none).
  Sample evaluate(const Vec3& x, int64_t self, double theta, double softening) const;

private:
  struct Node {
    Vec3 centre{0, 0, 0}; // centre of charge
    double charge = 0.0;
    double size = 0.0;    // longest edge of the cell
    int32_t firstChild = -1; // index of the first of `children` consecutive nodes, -1 for a leaf
    int32_t children = 0;
    int32_t begin = 0, end = 0; // the cell's charges in order_[begin, end)
  };
  void build(int32_t node, int32_t begin, int32_t end, const Vec3& lo, const Vec3& hi, int depth);
  std::vector<Vec3> pos_;         // positions in tree order
  std::vector<double> q_;         // charges in tree order
  std::vector<int64_t> index_;    // original index of each position in tree order
  std::vector<Node> nodes_;       // nodes_[0] is the root
};

} // namespace tetflow
