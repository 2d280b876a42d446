#include "TetMesh.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

#include "Errors.h"

namespace tetflow {

std::vector<int32_t> presentMaterials(const TetMesh& mesh) {
  std::vector<int32_t> labels;
  for (size_t t = 0; t < mesh.materials.size(); ++t)
    if (t == 0 || mesh.materials[t] != mesh.materials[t - 1]) labels.push_back(mesh.materials[t]);
  std::sort(labels.begin(), labels.end());
  labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
  return labels;
}

std::vector<int32_t> labelsNamed(const std::map<int32_t, std::string>& names, const std::string& name) {
  auto key = [](const std::string& s) {
    std::string k;
    for (unsigned char c : s) k += c == ' ' || c == '-' ? '_' : char(std::tolower(c));
    return k;
  };
  const std::string want = key(name);
  std::vector<int32_t> out;
  for (const auto& [label, n] : names)
    if (key(n) == want) out.push_back(label);
  return out;
}

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
