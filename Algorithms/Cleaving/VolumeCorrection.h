#pragma once
// Volume correction of a labelled mesh (CleaveMesh `correct_volumes`): the vertices on material
// interfaces are moved along the interfaces' normals, by a fraction of a millimetre, so that every
// material's volume equals its target (the voxels of its label) - the geometric counterpart of
// raising or lowering a material's indicator function, done once on the final mesh instead of by
// cleaving again.
//
// Why: cleaving puts interfaces where the indicator functions cross, but a piecewise-linear surface
// through those points shaves the corners of a voxel staircase, and the label repair adds or removes
// whole tets where it reconnects a layer. A layer one voxel thick loses or gains a few percent that
// way; its position is right, its volume is not.
//
// How, per round (at most `rounds`):
//  - volumes per material; the relative error e_L = (V_L - T_L) / T_L. When every |e_L| is within
//    `tolerance`, the round does nothing more (one pass over the tets);
//  - the interfaces: faces between tets of two materials, and the faces of the mesh's boundary
//    that are not on the domain box (where a stripped exterior was: the material against nothing),
//    with their areas A_LM;
//  - a displacement d_LM = phi_L - phi_M of each interface (toward M, L grows), with the
//    potentials phi solving sum_M A_LM (phi_L - phi_M) = -(V_L - T_L) for every material with a
//    target (materials without one, and "nothing", keep phi = 0; when none is without, the largest
//    material is held): the smallest moves (in the A-weighted least-squares sense) that remove
//    every error to first order;
//  - every interface vertex moves by the u that best gives each of its interfaces its
//    displacement along that interface's normal at the vertex (least squares over its
//    interfaces; a vertex on the domain box stays on its box faces);
//  - a move that would invert a tet, take a dihedral angle outside [min_angle, max_angle], or
//    further outside when it already was, is undone (its vertex stays).
// Geometry changes, connectivity and labels do not. Sums run in a fixed order: the result does not
// depend on the thread count.
#include <cstdint>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Report.h"
#include "Algorithms/Core/TetMesh.h"

namespace tetflow {

// The box the mesh fills (its faces do not move): in the frame's coordinates
// local = frame^T (p - origin), the box is [lo, hi].
struct DomainBox {
  Mat3 frame = identity3();
  Vec3 origin{0, 0, 0};
  Vec3 lo{0, 0, 0}, hi{0, 0, 0};
  bool empty() const { return !(hi[0] > lo[0]); }
  // Bit a set: vertex p lies on a box face normal to local axis a.
  uint8_t fixedAxes(const Vec3& p) const;
};
// The box of a background mesh's vertices, in the frame of `frame` (columns: axes).
DomainBox domainBoxOf(const TetMesh& background, const Mat3& frame, const Vec3& origin);

struct VolumeCorrectionParams {
  double tolerance = 1e-3; // relative volume error left as it is
  int rounds = 4;          // in [0, 20]
  double min_angle = 10.0, max_angle = 160.0; // deg
};

struct VolumeCorrectionStats {
  int rounds = 0;               // rounds that moved vertices
  int64_t movedVertices = 0;    // in the last round that moved
  int64_t undoneMoves = 0;      // all rounds
  std::vector<int32_t> labels;  // materials with a target
  std::vector<double> errorBefore, errorAfter; // relative, per label
  std::vector<double> shift;    // mm: area-weighted mean displacement of each label's interfaces (outward > 0)
};

// labels/targets: the materials to correct and their volumes (mm^3); a target <= 0 means none.
// `faceNeighbours`, when given and not empty, is tetFaceNeighbours(mesh) computed before (the
// correction moves vertices only). Throws InputError for sizes that differ or parameters out of range.
VolumeCorrectionStats correctVolumes(TetMesh& mesh, const std::vector<int32_t>& labels,
                                     const std::vector<double>& targets, const DomainBox& box,
                                     const VolumeCorrectionParams& params, Progress& progress,
                                     const std::vector<int32_t>* faceNeighbours = nullptr);

// volume_correction_* keys.
void writeVolumeCorrectionReport(const VolumeCorrectionStats& s, Report& report);

} // namespace tetflow
