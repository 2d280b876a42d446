#pragma once
// Background edges that miss a material (seed §6.2, "topological aliasing"): cleaving gives every
// background vertex the material that dominates there and puts at most one interface point on an
// edge, so a layer that an edge crosses without a vertex inside it - a one-voxel CSF between skull
// and brain on 4 mm cells, a sulcus between two banks of grey matter - is not in the mesh there.
// The label repair can only patch such a layer afterwards, with whole tets.
//
// EdgeTopology answers, for a segment, whether it crosses such a layer, from the voxels the
// segment passes through (the labels the indicator functions are built from). The segment is
// widened by kTieWidth voxels, so a segment that runs along a voxel face or through a voxel corner
// (any lattice whose cells are a whole number of voxels) sees the voxels on both sides. It misses a
// material when, counting only the stretches of the segment where a label's voxels cover at least
// kMinStretch voxels of it (a corner grazed does not count),
//   - it crosses three or more labels, or
//   - a label comes back after a stretch of another (A, B, A).
// In Mode::Separating a segment misses a material when its ends carry labels that do not touch near it (below).
// A background whose every edge passes this test shows every layer the voxels have to the cleaver.
// The octree (OctreeBcc.h) splits the cells that hold such edges, the seed's "routine subdivision".
#include <cstdint>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/Core/Volume.h"

namespace tetflow {

class EdgeTopology {
public:
  static constexpr double kTieWidth = 1e-3;   // voxels
  static constexpr double kMinStretch = 0.25; // voxels: a label over less of the segment does not count
  // Which misses count:
  //   Separating  only where the segment's ends carry two labels that do not touch (a face-adjacent
  //               voxel pair) near the segment - in the box of the voxels it passes, widened by
  //               one voxel: the layer between them (the CSF between skull and brain, a sheet
  //               between two tissues that meet elsewhere) would be missing there and the two
  //               would touch. Decided by the ends' voxels and that box; for a long edge (a box of
  //               more than kNearVoxels voxels) by the whole image (labels that never touch).
  //               Likewise where the ends lie in two components of one label (two ventricles,
  //               whatever keeps them apart would be missing and they would merge).
  //               And every miss (as All) of a layer of a component without a core voxel (a
  //               voxel whose six neighbours carry its label): a one- or two-voxel sheet, rod or
  //               speck that would be lost whole, whatever labels it lies between.
  //   All         every miss above (three labels, or A B A): every thin layer and sheet.
  enum class Mode { Separating, All };
  // Keeps a reference to `labels`, which must outlive it.
  explicit EdgeTopology(const LabelVolume& labels, Mode mode = Mode::All);
  // a, b physical (mm). Outside the grid the boundary voxels continue (as the materials do).
  // With a split ratio r > 1 (setSplitRatio), a miss counts only when the segment is longer than
  // r times the missed layer's extent along it: the part of the segment between the stretch of
  // the label at a that starts at a and the stretch of the label at b that ends at b (the layer
  // of a separating miss, the B of A B A, the middle of A B C). Splitting the segment's cell into
  // halves then stops once its edges are no longer than r x that extent, so a cell is refined
  // as far as the layer it misses is thin, not down to the voxels wherever a layer is missed:
  // halves of at most the extent sample the layer along the segment's line (r = 1), longer ones
  // may leave it to the label repair. r <= 1 (the default, 1): every miss counts.
  bool missesMaterial(const Vec3& a, const Vec3& b) const;
  void setSplitRatio(double r) { splitRatio_ = r; }
  double splitRatio() const { return splitRatio_; }
  // Whether the voxels around the points (physical, mm; their bounding box in the grid) are known
  // to carry one label: then no segment between two of them misses a material (in either mode),
  // and a caller with many such segments (the edges of a cell or a tet) need not test them one by
  // one. (Not known, and false, when nothingMisses.)
  bool uniformOver(const Vec3* points, int n) const;
  // Whether no segment can miss a material: Separating on an image of at most two labels, each
  // in one piece, and no component without a core (a segment between the two labels passes a face between them in
  // the box it crosses, and nothing coreless is there to lose). A smooth organ in its background.
  bool nothingMisses() const { return nothingMisses_; }
  // Largest voxel spacing (mm).
  double voxelSize() const { return voxelSize_; }
  const GridGeometry& grid() const { return labels_.grid; }

private:
  static constexpr int kBlock = 4; // voxels per block edge
  const LabelVolume& labels_;
  Mode mode_;
  double splitRatio_ = 1.0;
  std::vector<std::pair<int32_t, int32_t>> contacts_; // label pairs (a < b) on face-adjacent voxels, sorted
  static constexpr int64_t kNearVoxels = 4096;
  bool touch(int32_t a, int32_t b) const;
  // The voxels (clamped to the grid) over the index-space box [mn, mx] widened by kTieWidth.
  void voxelBox(const double mn[3], const double mx[3], int64_t lo[3], int64_t hi[3]) const;
  // Whether a block over the voxel box [lo, hi] has flags[block] == value.
  bool anyBlock(const std::vector<uint8_t>& flags, const int64_t lo[3], const int64_t hi[3], uint8_t value) const;
  // Whether A and B are face-adjacent somewhere in the voxel box [lo, hi] widened by one voxel.
  bool touchNear(int32_t A, int32_t B, const int64_t lo[3], const int64_t hi[3]) const;
  Mat3 toIndex_;        // physical offset -> continuous index
  double voxelSize_ = 0;
  std::array<int64_t, 3> blocks_{0, 0, 0};
  // Per block: 1 when the block and its one-voxel halo carry one label.
  std::vector<uint8_t> uniform_;
  // Separating: per voxel, 1 in a component without a core voxel (empty when there is none); per
  // block (with its halo), 1 when it holds such a voxel.
  std::vector<uint8_t> coreless_, corelessBlock_;
  // Separating: per voxel, its 26-connected component, when some label has several (else empty).
  std::vector<int32_t> comp_;
  Vec3 index(const Vec3& p) const;
  bool nothingMisses_ = false;
};

// Per tet of `mesh`: 1 when one of its six edges misses a material. Both cores; the result does
// not depend on the thread count.
// Only the tets with only[t] != 0 when `only` is given.
std::vector<uint8_t> tetsMissingMaterials(const TetMesh& mesh, const EdgeTopology& topology, Progress& progress,
                                          const std::vector<uint8_t>* only = nullptr);

} // namespace tetflow
