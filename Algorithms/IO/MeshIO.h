#pragma once
// Tetrahedral mesh files. Format by extension (or given explicitly):
//   .vtu        VTK XML unstructured grid (through VTK): material as int32 cell data "material",
//               point/cell fields as point/cell data arrays (components kept)
//   .vtk        legacy VTK unstructured grid (through VTK), same arrays
//   .msh        Gmsh MSH 4.1 ASCII: one volume entity + physical group per material
//               (physical tag = material label; label <= 0 mapped and named "material_<label>")
//   .node/.ele  TetGen: both files written for either name; 1-based indices; the material is the
//               single region attribute of each tet
// Readers exist for .vtu, .vtk and TetGen (.node/.ele), so meshes can be read back.
// All writers are atomic (temp file + rename; for TetGen both files or none).
#include <string>

#include "../Core/TetMesh.h"

namespace tetflow {

enum class MeshFormat : int { Auto = 0, Vtu = 1, VtkLegacy = 2, Gmsh41 = 3, TetGen = 4 };

MeshFormat meshFormatFromPath(const std::string& path); // InputError on unknown extension
const char* meshFormatName(MeshFormat f);                // "vtu", "vtk", "msh", "tetgen"

void writeMesh(const std::string& path, const TetMesh& mesh, MeshFormat format = MeshFormat::Auto);
TetMesh readMesh(const std::string& path, MeshFormat format = MeshFormat::Auto);

} // namespace tetflow
