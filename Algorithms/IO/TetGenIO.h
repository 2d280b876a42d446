#pragma once
// Tetrahedral meshes as TetGen's .node / .ele pair (the contracts are MeshIO.h's; MeshIO.cpp
// dispatches here). TetGen's corner order is TetFlow's positive orientation (MeshIO.cpp's
// file comment gives the evidence), so corners are written and read as stored.
#include <string>

#include "../Core/TetMesh.h"

namespace tetflow {

// "<stem>.node" + "<stem>.ele" for a path ending in .node or .ele, else path + ".node"/".ele".
TetMesh readTetGen(const std::string& path);
void writeTetGen(const std::string& path, const TetMesh& m);

} // namespace tetflow
