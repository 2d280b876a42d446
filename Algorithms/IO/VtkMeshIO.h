#pragma once
// Tetrahedral meshes in VTK's files (the contracts are MeshIO.h's; MeshIO.cpp dispatches here):
//   .vtu  XML unstructured grid: our own writer (VtuWriter.h), read through VTK after
//         VtkXmlPrecheck has checked its block headers against the file;
//   .vtk  legacy unstructured grid through VTK (binary 4.2 layout written), its counts checked
//         against the file before VTK reads it.
// Material is the int32 cell array "material"; other point and cell arrays are fields.
#include <string>

#include "../Core/TetMesh.h"

namespace tetflow {

void writeVtu(const std::string& path, const TetMesh& m);
void writeVtkLegacy(const std::string& path, const TetMesh& m);
TetMesh readVtu(const std::string& path);
TetMesh readVtkLegacy(const std::string& path);

} // namespace tetflow
