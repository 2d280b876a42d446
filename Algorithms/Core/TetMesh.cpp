#include "TetMesh.h"

#include <cmath>
#include <sstream>

#include "Errors.h"

namespace tetflow {

void TetMesh::validateStructure(const std::string& what) const {
  if (materials.size() != tets.size()) {
    std::ostringstream m;
    m << what << ": " << tets.size() << " tets but " << materials.size() << " material labels";
    throw InputError(m.str());
  }
  const int64_t np = static_cast<int64_t>(points.size());
  for (size_t v = 0; v < points.size(); ++v)
    for (double c : points[v])
      if (!std::isfinite(c)) {
        std::ostringstream m;
        m << what << ": vertex " << v << " has a non-finite coordinate";
        throw InputError(m.str());
      }
  for (size_t t = 0; t < tets.size(); ++t)
    for (int32_t i : tets[t])
      if (i < 0 || i >= np) {
        std::ostringstream m;
        m << what << ": tet " << t << " refers to vertex " << i << " but the mesh has " << np
          << " vertices";
        throw InputError(m.str());
      }
  auto checkFields = [&](const std::map<std::string, Field>& fields, size_t n, const char* kind) {
    for (const auto& [name, f] : fields) {
      if (f.components < 1 || f.values.size() != n * static_cast<size_t>(f.components)) {
        std::ostringstream m;
        m << what << ": " << kind << " field '" << name << "' has " << f.values.size()
          << " values; expected " << n << " x " << f.components;
        throw InputError(m.str());
      }
    }
  };
  checkFields(pointFields, points.size(), "point");
  checkFields(cellFields, tets.size(), "cell");
}

} // namespace tetflow
