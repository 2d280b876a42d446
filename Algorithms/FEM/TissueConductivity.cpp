// Conductivities by tissue name (see TissueConductivity.h).
#include "Algorithms/FEM/TissueConductivity.h"

#include <cctype>
#include <charconv>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/IO/HeaderText.h"

namespace tetflow {

namespace {

std::string trimmed(const std::string& s) { return std::string(headertext::trim(s)); }

struct Tissue {
  const char* name;
  double sigma; // S/m
  std::vector<const char*> aliases; // normalised (see key())
};

// SimNIBS's standard conductivities (see the header) and air.
const std::vector<Tissue>& tissues() {
  static const std::vector<Tissue> t = {
      {"white matter", 0.126, {"whitematter", "wm", "white", "cerebralwhitematter", "cerebellumwhitematter"}},
      {"grey matter", 0.275, {"greymatter", "graymatter", "gm", "grey", "gray", "cortex", "cerebralcortex", "cerebellumcortex"}},
      {"CSF", 1.654, {"csf", "cerebrospinalfluid", "lateralventricle", "3rdventricle", "4thventricle", "ventricles"}},
      {"bone", 0.010, {"bone", "skull"}},
      {"compact bone", 0.008, {"compactbone", "corticalbone"}},
      {"spongy bone", 0.025, {"spongybone", "cancellousbone"}},
      {"scalp", 0.465, {"scalp", "skin"}},
      {"eyes", 0.5, {"eyes", "eye", "eyeballs", "eyeball"}},
      {"blood", 0.6, {"blood", "bloodvessels", "vessels"}},
      {"muscle", 0.16, {"muscle", "muscles"}},
      {"air", 2.5e-14, {"air", "airway", "airways", "aircavities"}},
  };
  return t;
}

// Lower case without spaces, '-' and '_', and without a hemisphere prefix ("Left-", "rh_").
std::string key(const std::string& name) {
  std::string k;
  for (unsigned char c : name)
    if (c != ' ' && c != '-' && c != '_') k += char(std::tolower(c));
  for (const char* prefix : {"left", "right", "lh", "rh"}) {
    const std::string p = prefix;
    if (k.size() > p.size() && k.compare(0, p.size(), p) == 0) {
      const std::string rest = k.substr(p.size());
      for (const Tissue& t : tissues())
        for (const char* a : t.aliases)
          if (rest == a) return rest;
    }
  }
  return k;
}

} // namespace

std::optional<double> literatureConductivity(const std::string& name, std::string* matched) {
  const std::string k = key(name);
  for (const Tissue& t : tissues())
    for (const char* a : t.aliases)
      if (k == a) {
        if (matched) *matched = t.name;
        return t.sigma;
      }
  return std::nullopt;
}

std::vector<std::string> conductivityItemsByLabel(const std::vector<std::string>& items,
                                                  const std::map<int32_t, std::string>& names) {
  std::vector<std::string> out;
  for (const std::string& item : items) {
    const size_t colon = item.find(':');
    const std::string head = trimmed(item.substr(0, colon == std::string::npos ? item.size() : colon));
    // A label (or a malformed item, which the parser names) starts like a number; a name does not.
    double number = 0;
    const bool numeric = std::from_chars(head.data(), head.data() + head.size(), number).ptr != head.data();
    if (colon == std::string::npos || head.empty() || numeric || head[0] == '+' || head[0] == '-') {
      out.push_back(item);
      continue;
    }
    const std::vector<int32_t> labels = labelsNamed(names, head);
    if (labels.empty()) {
      std::string known;
      for (const auto& [L, n] : names) known += (known.empty() ? "" : ", ") + n + " (" + std::to_string(L) + ")";
      throw InputError("conductivities: entry '" + trimmed(item) + "': the mesh has no tissue called '" + head + "'" +
                       (known.empty() ? std::string("; its materials have no names: give labels instead")
                                      : "; its tissues are " + known));
    }
    for (int32_t L : labels) out.push_back(std::to_string(L) + item.substr(colon));
  }
  return out;
}

std::map<int32_t, std::string> completeConductivities(ConductivityTable& table, const TetMesh& mesh, bool byName) {
  std::map<int32_t, std::string> source;
  for (int32_t L : presentMaterials(mesh)) {
    if (table.byLabel.count(L)) {
      source[L] = "parameter";
    } else if (auto it = mesh.materialConductivities.find(L); it != mesh.materialConductivities.end()) {
      table.set(L, it->second);
      source[L] = "label table";
    } else if (auto n = mesh.materialNames.find(L); byName && n != mesh.materialNames.end()) {
      if (const auto sigma = literatureConductivity(n->second)) {
        table.set(L, *sigma);
        source[L] = "literature";
      } else {
        source[L] = "default";
      }
    } else {
      source[L] = "default";
    }
  }
  return source;
}

} // namespace tetflow
