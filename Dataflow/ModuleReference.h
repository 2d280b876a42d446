#pragma once
// The module reference as Markdown (docs/modules.md), generated from the registry so that it
// cannot drift from the code: every module with its package, category and description, its ports
// (index, name, types, optional) and its parameters (name, type, default, allowed values, unit,
// description). `tetflow describe --markdown [FILE]` writes it; a test (ModuleReference.*)
// fails when the committed docs/modules.md differs from what the code generates.
#include <string>

#include "ModuleRegistry.h"

namespace tetflow {

// The whole page. Deterministic: modules in the registry's order (category, then name).
std::string moduleReferenceMarkdown(const ModuleRegistry& reg);

// GitHub's anchor for a heading text ("CleaveMesh" -> "cleavemesh"): lower case, spaces to '-',
// everything but letters, digits, '-' and '_' dropped.
std::string markdownAnchor(const std::string& heading);

} // namespace tetflow
