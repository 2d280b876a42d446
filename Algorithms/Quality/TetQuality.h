#pragma once
// Per-element quality metrics of a tetrahedron (DESIGN §6, §7: stateless functions, each with its
// formula). Inputs are the four corner positions p0..p3 in physical units (mm); angles are in
// degrees, volumes in mm^3, ratios are dimensionless.
//
// Notation: e_ij = p_j - p_i; L_max = longest of the 6 edges; A_k = area of the face opposite p_k;
// S = A_0 + A_1 + A_2 + A_3; V = signedTetVolume(p0,p1,p2,p3) = e01 . (e02 x e03) / 6.
//
// Orientation: only tetVolume() is signed. The angle and ratio metrics describe the shape and are
// independent of the corner order (an inverted tet has the same angles and ratios as its mirror
// image); inversion is reported by the sign of the volume (and counted by evaluateQuality).
//
// Degenerate tets: a tet is "zero-volume" when |V| <= kZeroVolumeRelTol * L_max^3 (this includes
// coincident corners and L_max = 0). For such a tet
//   - minDihedral() is 0 and maxDihedral() is 180,
//   - aspectRatio() and radiusRatio() are 0,
//   - dihedralAngles() still returns the 6 geometric angles computed with atan2, which for a flat
//     tet are each 0 or 180 (up to rounding), and 0 at an edge whose two faces have zero area.
// No metric ever returns NaN or divides by zero for finite corner coordinates.
//
// Reference values (closed forms; checked by Testing/Algorithms/Quality/TetQualityTest.cpp):
//   regular tet            : all 6 dihedral angles acos(1/3) = 70.528779°,
//                            aspect ratio sqrt(2/3) = 0.816497, radius ratio 1
//   BCC lattice tet        : (two adjacent cube centres + the two ends of an edge of their shared
//                            face) 60° at the 4 short edges, 90° at the 2 long edges,
//                            aspect ratio 1/sqrt(2) = 0.707107, radius ratio 3/sqrt(10) = 0.948683
//                            (the seed's §4.10 quotes 0.866025 for this tet's aspect ratio; the
//                            definition it states, h_min / L_max, gives 1/sqrt(2))
//   right-corner tet (0,0,0),(1,0,0),(0,1,0),(0,0,1):
//                            90° at the 3 edges through the origin, acos(1/sqrt(3)) = 54.735610°
//                            at the 3 others, aspect ratio 1/sqrt(6) = 0.408248,
//                            radius ratio sqrt(3) - 1 = 0.732051
#include <array>

#include "Algorithms/Core/Geometry.h"

namespace tetflow {

// Relative tolerance of the zero-volume test |V| <= kZeroVolumeRelTol * L_max^3.
inline constexpr double kZeroVolumeRelTol = 1e-12;

// The 6 edges of a tet as corner index pairs, in the order used by dihedralAngles():
// (0,1) (0,2) (0,3) (1,2) (1,3) (2,3).
inline constexpr std::array<std::array<int, 2>, 6> kTetEdges{
    {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}}};

// Signed volume V = (p1-p0) . ((p2-p0) x (p3-p0)) / 6  [mm^3]; > 0 for TetFlow's orientation.
double tetVolume(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3);

// Longest edge length L_max [mm].
double longestEdge(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3);

// True when |V| <= kZeroVolumeRelTol * L_max^3.
bool isZeroVolume(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3);

// The 6 interior dihedral angles [deg], one per edge in kTetEdges order. At edge (i,j) with the
// other two corners k,l: with e = p_j - p_i, m_k = e x (p_k - p_i), m_l = e x (p_l - p_i) (normals
// of the two faces meeting at the edge, both perpendicular to e),
//     angle_ij = atan2(|m_k x m_l|, m_k . m_l)    in [0, 180].
// atan2 keeps full accuracy near 0 and 180 (acos does not). Sum over a valid tet lies in (360, 720).
std::array<double, 6> dihedralAngles(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3);

// Extreme cosines of the 6 interior dihedral angles of a positive tet, from its outward face
// normals n_k (the angle at the edge between faces k and l has cos = -n_k.n_l / |n_k||n_l|):
// lo = cos(largest angle), hi = cos(smallest). No trigonometry: for scans over every tet and for
// checks against fixed bounds. False when the tet is inverted or flat (isZeroVolume).
bool dihedralCosineRange(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, double& lo, double& hi);

// min(smallest dihedral angle, 180 - largest) [deg] from dihedralCosineRange (one acos); -1 when
// the tet is inverted or flat.
double dihedralScore(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3);

// min / max of dihedralAngles() [deg]; 0 / 180 for a zero-volume tet.
double minDihedral(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3);
double maxDihedral(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3);

// Aspect ratio (seed §4.10, definition 3): shortest altitude / longest edge,
//     ar = h_min / L_max,  h_min = 3|V| / max_k A_k.
// In [0, sqrt(2/3)]: sqrt(2/3) = 0.816497 for the regular tet (the maximum); 0 when zero-volume.
double aspectRatio(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3);

// Radius ratio 3 r_in / R_circ, in [0, 1], 1 exactly for the regular tet, 0 when zero-volume.
//   r_in   = 3|V| / S
//   R_circ = |N| / (12|V|),  N = |a|^2 (b x c) + |b|^2 (c x a) + |c|^2 (a x b),
//            a = p1-p0, b = p2-p0, c = p3-p0  (the circumcentre is p0 + N / (12 V))
// so 3 r_in / R_circ = 108 V^2 / (S |N|), evaluated in that form (no division by V).
double radiusRatio(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3);

// All of the above in one pass (what evaluateQuality uses per tet).
struct TetMetrics {
  double volume = 0.0;               // signed V [mm^3]
  std::array<double, 6> dihedral{};  // [deg], kTetEdges order
  double minDihedral = 0.0;          // [deg]
  double maxDihedral = 0.0;          // [deg]
  double aspectRatio = 0.0;
  double radiusRatio = 0.0;
  bool zeroVolume = false;           // |V| <= kZeroVolumeRelTol * L_max^3
};
TetMetrics tetMetrics(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3);

} // namespace tetflow
