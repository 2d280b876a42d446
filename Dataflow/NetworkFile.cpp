#include "NetworkFile.h"

#include <filesystem>
#include <sstream>

#include "Algorithms/IO/FileUtil.h"
#include "Xml.h"

namespace tetflow {

namespace {

std::string formatProblems(const std::string& file, const std::vector<LoadProblem>& ps) {
  std::ostringstream m;
  m << file << ": cannot load the network (" << ps.size() << (ps.size() == 1 ? " problem" : " problems")
    << ")";
  for (const auto& p : ps) {
    m << "\n  " << file;
    if (p.line > 0) m << ":" << p.line;
    m << ": ";
    if (!p.moduleId.empty()) m << "module " << p.moduleId << ": ";
    m << p.message;
  }
  for (const auto& p : ps)
    if (p.message.rfind("unknown module", 0) == 0) {
      m << "\n  (`tetflow list-modules` lists the modules TetFlow has)";
      break;
    }
  return m.str();
}

std::string stripBraces(const std::string& s) {
  if (s.size() >= 2 && s.front() == '{' && s.back() == '}') return s.substr(1, s.size() - 2);
  return s;
}

bool parseNumber(const std::string& s, double& out) {
  try {
    size_t used = 0;
    out = std::stod(s, &used);
    return used == s.size() && std::isfinite(out);
  } catch (...) {
    return false;
  }
}

} // namespace

NetworkLoadError::NetworkLoadError(const std::string& file, std::vector<LoadProblem> problems)
    : InputError(formatProblems(file, problems)), file_(file), problems_(std::move(problems)) {}

Network loadNetworkFromString(const std::string& xml, const std::string& name,
                              const std::string& baseDir, const ModuleRegistry& registry) {
  Network net(registry);
  net.setBaseDir(baseDir);
  std::vector<LoadProblem> problems;
  auto problem = [&](int line, const std::string& id, const std::string& msg) {
    problems.push_back({line, id, msg});
  };

  std::unique_ptr<XmlElement> root;
  try {
    root = parseXml(xml);
  } catch (const XmlError& e) {
    throw NetworkLoadError(name, {{e.line, "", std::string("malformed XML: ") + e.what()}});
  }
  if (root->name != "network")
    throw NetworkLoadError(name, {{root->line, "", "the root element is <" + root->name +
                                                       ">, expected <network>; not a .srn network file"}});
  for (const XmlElement* n : root->childrenNamed("note")) net.setNetworkNote(stripBraces(n->text));

  // Module ids that exist in the file (loaded or not), so connections to an unknown module are
  // reported once, as such.
  std::map<std::string, bool> declared; // id -> loaded
  for (const XmlElement* mods : root->childrenNamed("modules")) {
    for (const auto& child : mods->children) {
      const XmlElement& el = *child;
      if (el.name != "module") {
        problem(el.line, "", "unexpected element <" + el.name + "> inside <modules>");
        continue;
      }
      const XmlAttribute* idA = el.attribute("id");
      const XmlAttribute* nameA = el.attribute("name");
      if (!idA || idA->value.empty()) {
        problem(el.line, "", "a <module> has no id attribute");
        continue;
      }
      const std::string id = idA->value;
      if (declared.count(id)) {
        problem(el.line, id, "module id '" + id + "' is used twice; ids must be unique");
        continue;
      }
      declared[id] = false;
      if (!nameA || nameA->value.empty()) {
        problem(el.line, id, "<module> has no name attribute (the module type)");
        continue;
      }
      const ModuleInfo* info = registry.find(nameA->value);
      if (!info) {
        const XmlAttribute* pkg = el.attribute("package");
        problem(el.line, id, "unknown module '" + nameA->value + "'" +
                                 (pkg ? " (package " + pkg->value + ")" : std::string()));
        continue;
      }
      double x = 0, y = 0;
      for (const XmlElement* pos : el.childrenNamed("position")) {
        const XmlAttribute* xa = pos->attribute("x");
        const XmlAttribute* ya = pos->attribute("y");
        if ((xa && !parseNumber(xa->value, x)) || (ya && !parseNumber(ya->value, y)))
          problem(pos->line, id, "position x/y must be numbers");
      }
      net.addModule(info->name, id, x, y);
      declared[id] = true;
      for (const XmlElement* note : el.childrenNamed("note")) net.setNote(id, stripBraces(note->text));
      for (const XmlElement* var : el.childrenNamed("var")) {
        const XmlAttribute* vn = var->attribute("name");
        const XmlAttribute* vv = var->attribute("val");
        if (!vn || !vv) {
          problem(var->line, id, "<var> needs name and val attributes");
          continue;
        }
        if (!info->param(vn->value)) {
          std::string known;
          for (const auto& p : info->params) known += (known.empty() ? "" : ", ") + p.name;
          problem(var->line, id, info->name + " has no parameter '" + vn->value + "' (parameters: " +
                                     (known.empty() ? "none" : known) + ")");
          continue;
        }
        try {
          net.setParameterText(id, vn->value, stripBraces(vv->value));
        } catch (const InputError& e) {
          std::string msg = e.what();
          const std::string prefix = id + " (" + info->name + "): ";
          if (msg.rfind(prefix, 0) == 0) msg = msg.substr(prefix.size());
          problem(vv->line, id, msg);
        }
      }
      for (const auto& c : el.children)
        if (c->name != "position" && c->name != "note" && c->name != "var" && c->name != "gui_callback")
          problem(c->line, id, "unexpected element <" + c->name + "> inside <module>");
    }
  }

  for (const XmlElement* conns : root->childrenNamed("connections")) {
    for (const auto& child : conns->children) {
      const XmlElement& el = *child;
      if (el.name != "connection") {
        problem(el.line, "", "unexpected element <" + el.name + "> inside <connections>");
        continue;
      }
      const XmlAttribute* cid = el.attribute("id");
      const XmlAttribute* from = el.attribute("from");
      const XmlAttribute* to = el.attribute("to");
      const XmlAttribute* fp = el.attribute("fromport");
      const XmlAttribute* tp = el.attribute("toport");
      const std::string label = "connection " + (cid ? cid->value : std::string("(no id)")) + ": ";
      if (!from || !to || !fp || !tp) {
        problem(el.line, "", label + "needs from, fromport, to and toport attributes");
        continue;
      }
      auto known = [&](const std::string& mid) {
        auto it = declared.find(mid);
        if (it == declared.end()) {
          problem(el.line, "", label + "no module with id '" + mid + "' in this file");
          return false;
        }
        return it->second; // declared but not loaded: already reported
      };
      const bool okFrom = known(from->value);
      const bool okTo = known(to->value);
      if (!okFrom || !okTo) continue;
      const ModuleNode& a = net.requireModule(from->value);
      const ModuleNode& b = net.requireModule(to->value);
      const int fpi = a.info->outputIndex(fp->value);
      const int tpi = b.info->inputIndex(tp->value);
      if (fpi < 0) {
        std::string names;
        for (const auto& p : a.info->outputs) names += (names.empty() ? "" : ", ") + p.name;
        problem(el.line, from->value, label + a.info->name + " has no output port '" + fp->value +
                                          "' (outputs: " + (names.empty() ? "none" : names) + ")");
        continue;
      }
      if (tpi < 0) {
        std::string names;
        for (const auto& p : b.info->inputs) names += (names.empty() ? "" : ", ") + p.name;
        problem(el.line, to->value, label + b.info->name + " has no input port '" + tp->value +
                                        "' (inputs: " + (names.empty() ? "none" : names) + ")");
        continue;
      }
      const std::string why = net.checkConnection(from->value, fpi, to->value, tpi);
      if (!why.empty()) {
        problem(el.line, "", label + why);
        continue;
      }
      const std::string id = cid && !cid->value.empty() && !net.connection(cid->value) ? cid->value : "";
      if (cid && !cid->value.empty() && id.empty())
        problem(el.line, "", label + "connection id is used twice");
      else
        net.connect(from->value, fpi, to->value, tpi, id);
    }
  }
  for (const auto& c : root->children)
    if (c->name != "note" && c->name != "modules" && c->name != "connections")
      problem(c->line, "", "unexpected element <" + c->name + "> inside <network>");

  if (!problems.empty()) throw NetworkLoadError(name, std::move(problems));
  return net;
}

Network loadNetwork(const std::string& path, const ModuleRegistry& registry) {
  const std::vector<char> bytes = readFileBytes(path);
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  const std::string base = dir.empty() ? std::string(".") : dir.string();
  return loadNetworkFromString(std::string(bytes.begin(), bytes.end()), path, base, registry);
}

std::string saveNetworkToString(const Network& net) {
  std::ostringstream o;
  o << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  o << "<!DOCTYPE network PUBLIC \"-//SCIRun/Network DTD\" \"network.dtd\">\n";
  o << "<network version=\"tetflow-1\" name=\"{Main}\">\n";
  o << "  <note>{" << xmlEscape(net.note()) << "}</note>\n";
  o << "  <modules>\n";
  for (const auto& m : net.modules()) {
    o << "    <module id=\"" << xmlEscape(m.id) << "\" package=\"" << xmlEscape(m.info->package)
      << "\" category=\"" << xmlEscape(m.info->category) << "\" name=\"" << xmlEscape(m.info->name)
      << "\" version=\"1.0\">\n";
    o << "      <position x=\"" << formatDouble(m.x) << "\" y=\"" << formatDouble(m.y) << "\"/>\n";
    if (!m.note.empty())
      o << "      <note position=\"{def}\" color=\"{white}\">{" << xmlEscape(m.note) << "}</note>\n";
    for (const auto& spec : m.info->params) {
      auto it = m.params.find(spec.name);
      const ParamValue& v = it != m.params.end() ? it->second : spec.defaultValue;
      o << "      <var name=\"" << xmlEscape(spec.name) << "\" val=\"{"
        << xmlEscape(formatParam(spec, v)) << "}\" substitute=\"no\"/>\n";
    }
    o << "    </module>\n";
  }
  o << "  </modules>\n";
  o << "  <connections>\n";
  for (const auto& c : net.connections())
    o << "    <connection id=\"" << xmlEscape(c.id) << "\" from=\"" << xmlEscape(c.from)
      << "\" fromport=\"" << c.fromPort << "\" to=\"" << xmlEscape(c.to) << "\" toport=\""
      << c.toPort << "\"/>\n";
  o << "  </connections>\n";
  o << "</network>\n";
  return o.str();
}

void saveNetwork(const std::string& path, const Network& net) {
  AtomicOutputFile out(path);
  out.stream() << saveNetworkToString(net);
  out.commit();
}

} // namespace tetflow
