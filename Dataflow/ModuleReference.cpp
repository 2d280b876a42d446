#include "ModuleReference.h"

#include <cctype>
#include <sstream>

#include "Parameter.h"
#include "PortTypes.h"

namespace tetflow {

std::string markdownAnchor(const std::string& heading) {
  std::string a;
  for (unsigned char c : heading) {
    if (std::isalnum(c)) a.push_back(char(std::tolower(c)));
    else if (c == ' ' || c == '-') a.push_back('-');
    else if (c == '_') a.push_back('_');
  }
  return a;
}

namespace {

// A table cell: no line breaks, '|' escaped.
std::string cell(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '|') o += "\\|";
    else if (c == '\n') o += ' ';
    else o.push_back(c);
  }
  return o;
}

// Inline code that survives any backticks in the text.
std::string code(const std::string& s) {
  if (s.empty()) return "(empty)";
  const std::string fence = s.find('`') == std::string::npos ? "`" : "`` ";
  const std::string close = fence == "`" ? "`" : " ``";
  return fence + cell(s) + close;
}

std::string allowed(const ParamSpec& p) {
  std::ostringstream m;
  if (p.type == ParamType::Enum) {
    for (size_t i = 0; i < p.choices.size(); ++i) m << (i ? ", " : "") << code(p.choices[i]);
    return m.str();
  }
  if (p.min && p.max) m << "[" << formatDouble(*p.min) << ", " << formatDouble(*p.max) << "]";
  else if (p.min) m << "≥ " << formatDouble(*p.min);
  else if (p.max) m << "≤ " << formatDouble(*p.max);
  if (p.isInputPath) m << (m.str().empty() ? "" : "; ") << "input file";
  if (p.isOutputPath) m << (m.str().empty() ? "" : "; ") << "output file";
  return m.str();
}

void ports(std::ostream& o, const char* title, const std::vector<PortSpec>& ps) {
  o << "**" << title << "**";
  if (ps.empty()) {
    o << ": none\n\n";
    return;
  }
  o << "\n\n| # | port | type | description |\n|---|---|---|---|\n";
  for (size_t i = 0; i < ps.size(); ++i) {
    std::string types;
    for (PortType t : ps[i].accepts) types.append(types.empty() ? "" : " or ").append(portTypeName(t));
    o << "| " << i << " | " << code(ps[i].name) << " | " << types << " | " << cell(ps[i].description)
      << (ps[i].optional ? " (optional)" : "") << " |\n";
  }
  o << "\n";
}

} // namespace

std::string moduleReferenceMarkdown(const ModuleRegistry& reg) {
  const std::vector<const ModuleInfo*> all = reg.all();
  std::ostringstream o;
  o << "# Module reference\n\n"
    << "Generated from the module registry by `tetflow describe --markdown docs/modules.md`; do not edit by "
       "hand (the test `ModuleReference.CommittedPageMatchesTheCode` fails when this page and the code "
       "differ). Port numbers are the indices a `.srn` connection uses; ports and parameters can also be "
       "named. `tetflow describe MODULE` prints the same in a terminal.\n\n";
  size_t categories = 0;
  std::string cat;
  for (const ModuleInfo* m : all)
    if (m->category != cat) {
      cat = m->category;
      ++categories;
    }
  o << all.size() << " modules in " << categories << " categories.\n\n";
  cat.clear();
  for (const ModuleInfo* m : all) {
    if (m->category != cat) {
      if (!cat.empty()) o << "\n";
      cat = m->category;
      o << "- **" << cat << "**: ";
    } else {
      o << ", ";
    }
    o << "[" << m->name << "](#" << markdownAnchor(m->name) << ")";
  }
  o << "\n";
  cat.clear();
  for (const ModuleInfo* m : all) {
    if (m->category != cat) {
      cat = m->category;
      o << "\n## " << cat << "\n";
    }
    o << "\n### " << m->name << "\n\n";
    o << "Package " << m->package << ", category " << m->category << ".\n\n" << m->description << "\n\n";
    ports(o, "Inputs", m->inputs);
    ports(o, "Outputs", m->outputs);
    o << "**Parameters**";
    if (m->params.empty()) {
      o << ": none\n";
      continue;
    }
    o << "\n\n| name | type | default | allowed | unit | description |\n|---|---|---|---|---|---|\n";
    for (const auto& p : m->params)
      o << "| " << code(p.name) << " | " << paramTypeName(p.type) << " | " << code(formatParam(p, p.defaultValue))
        << " | " << allowed(p) << " | " << cell(p.unit) << " | " << cell(p.description) << " |\n";
  }
  return o.str();
}

} // namespace tetflow
