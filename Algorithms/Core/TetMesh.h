#pragma once
// Tetrahedral mesh in physical units (mm).
//
// points[v]    : vertex position (double xyz)
// tets[t]      : 4 vertex indices, 0-based, positively oriented:
//                signedTetVolume(p[a], p[b], p[c], p[d]) > 0 (d on the side (b-a)x(c-a) points to)
// materials[t] : material label of tet t (the label value of the input, not a dense index)
// pointFields / cellFields : named fields, `components` values per point / per tet, interleaved.
// materialNames : optional tissue names by material label (e.g. 3 -> "CSF"); a label without an
//                entry has no name. Formats that carry names read and write them (MeshIO.h).
// materialConductivities : optional conductivities [S/m] by label, from a label table; used by
//                AssembleFEMPoisson for labels its `conductivities` parameter does not list.
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "Geometry.h"

namespace tetflow {

struct Field {
  int components = 1;
  std::vector<double> values; // size = components * (number of points or tets)
  bool operator==(const Field&) const = default;
};

struct TetMesh {
  using Tet = std::array<int32_t, 4>;
  std::vector<Vec3> points;
  std::vector<Tet> tets;
  std::vector<int32_t> materials;
  std::map<std::string, Field> pointFields;
  std::map<std::string, Field> cellFields;
  std::map<int32_t, std::string> materialNames;
  std::map<int32_t, double> materialConductivities;

  size_t numPoints() const { return points.size(); }
  size_t numTets() const { return tets.size(); }
  double tetVolume(size_t t) const {
    const Tet& q = tets[t];
    return signedTetVolume(points[q[0]], points[q[1]], points[q[2]], points[q[3]]);
  }
  // Throws InputError (prefixed by `what`) when array sizes disagree, an index is out of range,
  // a field has the wrong length, or a coordinate is not finite. Orientation is not checked here.
  void validateStructure(const std::string& what) const;
};

// The distinct material labels of the mesh's tets, ascending.
std::vector<int32_t> presentMaterials(const TetMesh& mesh);

// The labels whose tissue name is `name`, ignoring case, and with spaces, '-' and '_' alike
// ("Grey matter" is "grey_matter"); ascending, empty when none.
std::vector<int32_t> labelsNamed(const std::map<int32_t, std::string>& names, const std::string& name);

} // namespace tetflow
