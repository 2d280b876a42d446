#pragma once
// The one registry of module types: drives .srn loading, `tetflow describe`, and the GUI palette.
#include <map>
#include <string>
#include <vector>

#include "Module.h"

namespace tetflow {

class ModuleRegistry {
public:
  // Throws std::logic_error on a duplicate name or an inconsistent declaration (a programming
  // error, caught by the registry test).
  void add(ModuleInfo info);
  const ModuleInfo* find(const std::string& name) const;
  // All modules sorted by category then name.
  std::vector<const ModuleInfo*> all() const;
  // Defaults for every parameter of a module.
  static ParamValues defaults(const ModuleInfo& info);

private:
  std::map<std::string, ModuleInfo> modules_;
};

} // namespace tetflow
