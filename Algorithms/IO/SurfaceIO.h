#pragma once
// Triangle surfaces (the BEM surfaces of ExtractSurfaces) to files, by extension, atomically:
//   .off  Object File Format, ASCII (read by OpenMEEG, MeshLab, CGAL, meshio);
//   .stl  binary STL, float coordinates, each facet's normal from its corners;
//   .vtp  VTK XML PolyData, ASCII (ParaView, VTK);
//   .surf FreeSurfer triangle surface, binary big-endian, float coordinates (what MNE's BEM
//         surfaces are: mne.read_surface, mne.make_bem_model; nibabel reads it too).
// Coordinates in mm, 17 significant digits in the text formats. InputError naming the file for
// an unknown extension or an unwritable folder.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "../Core/Geometry.h"

namespace tetflow {

void writeTriangleSurface(const std::string& path, const std::vector<Vec3>& points,
                          const std::vector<std::array<int32_t, 3>>& triangles);

} // namespace tetflow
