#pragma once
// What the 3D view draws for a tet mesh, in plain C++ (no Qt, no VTK; unit-testable):
// the boundary faces of a *selected* set of tets (visible materials, on the kept side of the
// clipping plane). A face is drawn when the tet across it is missing or not selected, so the
// interior material interfaces appear where the clip plane cuts into the mesh ("crinkle" clip:
// whole tets, element edges stay visible).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "Algorithms/Core/TetMesh.h"

namespace tetflow::gui {

struct MeshTopology {
  // neighbor[4*t + f] = tet across face f of tet t (face f is opposite vertex f), or -1.
  std::vector<int32_t> neighbor;
  std::vector<Vec3> centroid;
  Vec3 lo{0, 0, 0}, hi{0, 0, 0}; // bounding box of the points
  std::vector<int32_t> labels;   // distinct material labels, ascending
  static MeshTopology build(const TetMesh& mesh);
};

struct SurfaceFaces {
  std::vector<std::array<int32_t, 3>> faces; // outward (counter-clockwise seen from outside)
  std::vector<int32_t> tet;                  // owning tet of each face
};

struct ClipPlane {
  bool enabled = false;
  int axis = 0;          // 0 x, 1 y, 2 z
  double position = 0;   // mm
  bool keepAbove = false; // keep tets with centroid >= position (else <=)
};

// labelVisible(label) decides material visibility.
template <class Visible>
SurfaceFaces extractSurface(const TetMesh& mesh, const MeshTopology& topo, Visible&& labelVisible,
                            const ClipPlane& clip) {
  const size_t n = mesh.numTets();
  std::vector<uint8_t> sel(n, 0);
  for (size_t t = 0; t < n; ++t) {
    bool keep = labelVisible(mesh.materials.empty() ? 0 : mesh.materials[t]);
    if (keep && clip.enabled) {
      const double c = topo.centroid[t][clip.axis];
      keep = clip.keepAbove ? c >= clip.position : c <= clip.position;
    }
    sel[t] = keep;
  }
  // Outward faces of a positively oriented tet (a,b,c,d), face f opposite vertex f.
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  SurfaceFaces out;
  for (size_t t = 0; t < n; ++t) {
    if (!sel[t]) continue;
    for (int f = 0; f < 4; ++f) {
      const int32_t nb = topo.neighbor[4 * t + f];
      if (nb >= 0 && sel[nb]) continue;
      const auto& q = mesh.tets[t];
      out.faces.push_back({q[kFace[f][0]], q[kFace[f][1]], q[kFace[f][2]]});
      out.tet.push_back(int32_t(t));
    }
  }
  return out;
}

// Per-tet minimum dihedral angle (deg), when the mesh has no "min_dihedral" field yet.
std::vector<double> computeMinDihedral(const TetMesh& mesh);
// Per-tet |grad u| of a P1 point field u (1 component).
std::vector<double> computeGradientMagnitude(const TetMesh& mesh, const std::vector<double>& u);

} // namespace tetflow::gui
