#pragma once
// Gmsh MSH meshes (the contracts are MeshIO.h's; MeshIO.cpp dispatches here).
//
// Writing: MSH 4.1 ASCII, MSH 2.2 ASCII and MSH 2.2 binary. Geometry, materials and material
// names only (fields are not written). Each material is a physical volume group whose tag is the
// label (labels <= 0 get fresh tags above the largest label) and whose name is the material's
// name in TetMesh::materialNames, else "material_<label>". Node tags are vertex index + 1.
//   4.1: one volume entity per material; elements grouped by material (ascending label, stored
//        order within one), element tags 1..n in that order.
//   2.2: elements in stored order (element tag = tet index + 1), tags: physical, elementary (the
//        elementary tag is the material's entity number, 1.. in ascending label order).
//
// Reading: MSH 2.0-2.2 and 4.1, ASCII or binary, either byte order. Only 4-node tetrahedra
// (Gmsh type 4) become tets; points, lines, triangles and quadrangles (boundary elements that
// Gmsh writes beside the volume) are skipped; other volume elements (hexahedra, prisms,
// pyramids, second- and higher-order tetrahedra) are refused, naming the element and its type.
// A tet's material is its physical volume tag (2.x: the first tag, or the elementary tag when the
// physical one is 0; 4.1: the first physical tag of its volume entity, or the entity's tag when it
// has none); a physical name "material_<n>" gives label n back (the writer's own names, so unnamed
// labels <= 0 round-trip; a named label <= 0 comes back under its fresh tag), any other name of a
// physical volume becomes the label's material name. In 2.x
// an element listed again under the same element tag (an element in two physical groups) is kept
// once, with its first group. All nodes are kept, in file order. $NodeData and other sections are
// skipped. Refused with InputError naming the file, the line (ASCII) or byte offset (binary) and
// the problem: MSH 1, 3 and 4.0, partitioned 4.1 files, a data size other than 8, an element
// referring to a node the file does not hold, counts larger than the file can hold, a file that
// ends inside a section.
#include <string>

#include "../Core/TetMesh.h"

namespace tetflow {

enum class GmshVariant { V41Ascii, V22Ascii, V22Binary };

void writeGmsh(const std::string& path, const TetMesh& m, GmshVariant variant);
TetMesh readGmsh(const std::string& path);

} // namespace tetflow
