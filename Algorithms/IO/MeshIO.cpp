// Tetrahedral mesh files: the format from the extension, and the call to its own file
// (VtkMeshIO.cpp: .vtu, .vtk; GmshIO.cpp: .msh; TetGenIO.cpp: .node/.ele; what they share is in
// MeshFileText.h). See MeshIO.h for the contracts.
//
// Vertex order conventions (all the same for 4-node tets, so no reordering is needed):
//   TetFlow : signedTetVolume(p0, p1, p2, p3) > 0, i.e. p3 lies on the side of triangle (p0,p1,p2)
//             that (p1-p0)x(p2-p0) points to.
//   VTK     : VTK_TETRA, (0,1,2) is a base triangle whose right-hand normal points to vertex 3.
//   Gmsh    : 4-node tetrahedron (type 4), reference nodes (0,0,0) (1,0,0) (0,1,0) (0,0,1).
//   TetGen  : TetGen 1.5 keeps every tet (a,b,c,d) with Shewchuk's orient3d(a,b,c,d) < 0, i.e. d
//             above the counter-clockwise triangle (a,b,c) -- the TetFlow orientation -- and
//             writes .ele corners in that stored order. Evidence: tetgenmesh::reconstructmesh()
//             (tetgen.cxx, 1.5) swaps the first two corners of any input tet with
//             orient3d(...) > 0; and the Debian libtet 1.5 library, run on random points
//             (Delaunay) and on a box PLC (-pq), emits only tets with positive TetFlow volume.
//             So the mapping is the identity.
// Every reader finally re-orients tets stored with negative volume by swapping their first two
// corners (what TetGen's own reader does), so files from tools with the opposite habit still give
// a valid TetMesh.
#include "MeshIO.h"

#include <string>

#include "../Core/Errors.h"
#include "FileUtil.h"
#include "GmshIO.h"
#include "TetGenIO.h"
#include "VtkMeshIO.h"

namespace tetflow {

namespace {
constexpr const char* kSupported = ".vtu, .vtk, .msh, .node/.ele (TetGen)";
} // namespace


MeshFormat meshFormatFromPath(const std::string& path) {
  const std::string ext = fileExtension(path);
  if (ext == ".vtu") return MeshFormat::Vtu;
  if (ext == ".vtk") return MeshFormat::VtkLegacy;
  if (ext == ".msh") return MeshFormat::Gmsh41;
  if (ext == ".node" || ext == ".ele") return MeshFormat::TetGen;
  if (ext.empty())
    throw InputError(path + ": the mesh file name has no extension; supported: " +
                     std::string(kSupported));
  throw InputError(path + ": unknown mesh file extension '" + ext + "'; supported: " +
                   std::string(kSupported));
}

const char* meshFormatName(MeshFormat f) {
  switch (f) {
  case MeshFormat::Auto: return "auto";
  case MeshFormat::Vtu: return "vtu";
  case MeshFormat::VtkLegacy: return "vtk";
  case MeshFormat::Gmsh41: return "msh";
  case MeshFormat::TetGen: return "tetgen";
  case MeshFormat::Gmsh22: return "msh22";
  case MeshFormat::Gmsh22Binary: return "msh22_binary";
  }
  return "unknown";
}

void writeMesh(const std::string& path, const TetMesh& mesh, MeshFormat format) {
  if (format == MeshFormat::Auto) format = meshFormatFromPath(path);
  mesh.validateStructure(path);
  switch (format) {
  case MeshFormat::Vtu: writeVtu(path, mesh); return;
  case MeshFormat::VtkLegacy: writeVtkLegacy(path, mesh); return;
  case MeshFormat::Gmsh41: writeGmsh(path, mesh, GmshVariant::V41Ascii); return;
  case MeshFormat::Gmsh22: writeGmsh(path, mesh, GmshVariant::V22Ascii); return;
  case MeshFormat::Gmsh22Binary: writeGmsh(path, mesh, GmshVariant::V22Binary); return;
  case MeshFormat::TetGen: writeTetGen(path, mesh); return;
  case MeshFormat::Auto: break;
  }
  throw InputError(path + ": invalid mesh format value " +
                   std::to_string(static_cast<int>(format)));
}

TetMesh readMesh(const std::string& path, MeshFormat format) {
  if (format == MeshFormat::Auto) format = meshFormatFromPath(path);
  switch (format) {
  case MeshFormat::Vtu: return readVtu(path);
  case MeshFormat::VtkLegacy: return readVtkLegacy(path);
  case MeshFormat::TetGen: return readTetGen(path);
  case MeshFormat::Gmsh41:
  case MeshFormat::Gmsh22:
  case MeshFormat::Gmsh22Binary: return readGmsh(path); // the version is the file's
  case MeshFormat::Auto: break;
  }
  throw InputError(path + ": invalid mesh format value " +
                   std::to_string(static_cast<int>(format)));
}

} // namespace tetflow
