#pragma once
// Tetrahedral mesh files. Format by extension (or given explicitly):
//   .vtu        VTK XML unstructured grid (own writer, VtuWriter.h; read through VTK): material
//               as int32 cell data "material", point/cell fields as point/cell data arrays
//               (components kept)
//   .vtk        legacy VTK unstructured grid (through VTK), same arrays
//   .msh        Gmsh MSH (GmshIO.h): written as 4.1 ASCII by default, or 2.2 ASCII / binary
//               (MeshFormat::Gmsh22, Gmsh22Binary); read in 2.x and 4.1, ASCII or binary. One
//               physical volume group per material (physical tag = material label; label <= 0
//               mapped to a fresh tag), named after TetMesh::materialNames or "material_<label>"
//   .node/.ele  TetGen: both files written for either name; 1-based indices; the material is the
//               single region attribute of each tet
// Every format is read as well as written. Each has its own file: VtkMeshIO, GmshIO, TetGenIO.
// All writers are atomic (temp file + rename; for TetGen both files or none).
//
// Contracts (details in MeshIO.cpp):
//  - writeMesh refuses (InputError naming `path`, nothing written) a mesh failing
//    validateStructure, an unknown extension (message lists the supported ones) and a missing
//    or unwritable folder. For .vtu/.vtk a cell field may not be called "material" and field
//    names may not be empty. Tets are written in their stored vertex order.
//  - .vtu: appended raw binary, zlib-compressed; .vtk: binary, legacy 4.2 layout. Points are
//    double, material is vtkIntArray "material", fields are vtkDoubleArray with their
//    components. Fields round-trip exactly through .vtu and .vtk.
//  - .msh and TetGen store geometry and materials only: fields are NOT written (.msh also stores
//    material names). MSH 4.1 groups the tets by material (ascending label; stored order within a
//    material), element tags 1..n in that order; MSH 2.2 keeps the stored order (element tag =
//    tet index + 1); node tags = vertex index + 1.
//  - TetGen: "<stem>.node" + "<stem>.ele" for a path ending in .node or .ele (any case), or
//    path + ".node"/".ele" when the format is given explicitly for another name. Coordinates with
//    17 significant digits. TetGen's corner order (orient3d(a,b,c,d) < 0, d above the
//    counter-clockwise a,b,c) is TetFlow's positive orientation, so corners are written as stored.
//  - readMesh: InputError naming the file (and line for TetGen) for a missing, damaged,
//    truncated or unsupported file (e.g. a non-tetrahedral VTK cell, 10-node TetGen tets, a
//    Gmsh hexahedron; GmshIO.h lists what .msh reading keeps, skips and refuses). VTK: a
//    missing "material" array gives material 0, other
//    numeric point/cell arrays become fields (as double; non-numeric arrays are skipped).
//    TetGen: node numbering may start at 0 or 1; comments, node attributes and boundary markers
//    are skipped; the first tet attribute (region) is the material, else 0.
//  - Every reader returns positively oriented tets: a tet stored with negative volume gets its
//    first two vertices swapped (as TetGen does when it reads a mesh); degenerate tets are kept.
#include <string>

#include "../Core/TetMesh.h"

namespace tetflow {

enum class MeshFormat : int {
  Auto = 0,
  Vtu = 1,
  VtkLegacy = 2,
  Gmsh41 = 3, // .msh: MSH 4.1 ASCII written; any MSH 2.x / 4.1 read
  TetGen = 4,
  Gmsh22 = 5,       // MSH 2.2 ASCII written (SimNIBS, DUNEuro); read as Gmsh41
  Gmsh22Binary = 6, // MSH 2.2 binary written; read as Gmsh41
};

MeshFormat meshFormatFromPath(const std::string& path); // InputError on unknown extension; .msh -> Gmsh41
// "vtu", "vtk", "msh", "tetgen", "msh22", "msh22_binary"
const char* meshFormatName(MeshFormat f);

void writeMesh(const std::string& path, const TetMesh& mesh, MeshFormat format = MeshFormat::Auto);
TetMesh readMesh(const std::string& path, MeshFormat format = MeshFormat::Auto);

} // namespace tetflow
