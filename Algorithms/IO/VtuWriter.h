#pragma once
// .vtu writer: the VTK XML UnstructuredGrid layout of vtkXMLUnstructuredGridWriter in appended raw
// mode with UInt64 headers and zlib (level 1, 32 KiB blocks), written without VTK. VTK's writer
// compresses on one thread and first copies the connectivity into its own arrays; this one
// compresses blocks in parallel straight from the mesh's memory, a few MiB at a time, so the
// write is faster and needs no copy of the mesh (docs/file-formats.md).
//
// Arrays, in file order: PointData (every point field), CellData ("material" Int32, then every
// cell field), Points (Float64 x3), Cells (connectivity and offsets Int32, or Int64 once 4 * tets
// exceeds the int32 range; types UInt8 = VTK_TETRA). Fields are Float64 with their components, in
// name order. Single-component arrays carry RangeMin/RangeMax (NaN ignored; left out when no
// value is finite). Before the piece, FieldData holds the materials' names and conductivities
// (materialFieldArrays), in ASCII.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "../Core/TetMesh.h"

namespace tetflow {

struct VtuWriteOptions {
  // 64-bit connectivity and offsets even where 32-bit ones fit (for tests of the huge-mesh path).
  bool int64Cells = false;
  // Blocks compressed together between two writes and cancellation checks (4 MiB of input).
  int blocksPerChunk = 128;
  // Blocks that zlib barely shrinks (judged by the first block of each group of 8) go out as
  // stored zlib blocks; off: every block at level 1, byte for byte what VTK's writer makes.
  bool storeIncompressible = true;
};

// The materials' names and conductivities as VTK field data, shared by the .vtu and .vtk writers:
// one Int32 array per named material, called by its name and holding (label, 3) -- the
// convention meshio uses for Gmsh's physical groups (tag, dimension), so meshio and ParaView
// users see the names (a name given to two labels gets " (label N)" after it); and one Float64
// array kMaterialConductivitiesArray of (label, S/m) pairs. Strings are avoided: meshio cannot
// read a String array.
inline constexpr const char* kMaterialConductivitiesArray = "material_conductivities";
struct MaterialFieldArrays {
  std::vector<std::pair<std::string, int32_t>> names; // (array name, label)
  std::vector<std::pair<int32_t, double>> conductivities;
};
MaterialFieldArrays materialFieldArrays(const TetMesh& m);

// Writes `m` to `path` atomically (temp file + rename). The caller has validated the mesh and
// its field names (writeMesh). Throws InputError naming `path` when the file cannot be written
// (nothing is left behind), Cancelled once the running module (currentProgress()) is cancelled.
void writeVtuFile(const std::string& path, const TetMesh& m, const VtuWriteOptions& options = {});

} // namespace tetflow
