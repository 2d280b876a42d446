#include "Network.h"

#include <algorithm>
#include <deque>
#include <filesystem>
#include <queue>
#include <set>

namespace tetflow {

namespace {
int nextNumber(const std::string& prefix, const std::vector<std::string>& ids) {
  int n = 0;
  for (const auto& id : ids) {
    if (id.size() > prefix.size() && id.compare(0, prefix.size(), prefix) == 0) {
      const std::string rest = id.substr(prefix.size());
      if (std::all_of(rest.begin(), rest.end(), [](unsigned char c) { return std::isdigit(c); }) &&
          rest.size() < 9)
        n = std::max(n, std::stoi(rest));
    }
  }
  return n + 1;
}
} // namespace

ModuleNode* Network::findModule(const std::string& id) {
  const auto it = index_.find(id);
  return it == index_.end() ? nullptr : &modules_[it->second];
}

const ModuleNode* Network::module(const std::string& id) const {
  const auto it = index_.find(id);
  return it == index_.end() ? nullptr : &modules_[it->second];
}

void Network::reindex() {
  index_.clear();
  for (size_t i = 0; i < modules_.size(); ++i) index_[modules_[i].id] = i;
}

const ModuleNode& Network::requireModule(const std::string& id) const {
  const ModuleNode* m = module(id);
  if (!m) throw InputError("no module with id '" + id + "' in the network");
  return *m;
}

const Connection* Network::connection(const std::string& id) const {
  for (const auto& c : connections_)
    if (c.id == id) return &c;
  return nullptr;
}

const Connection* Network::inputConnection(const std::string& id, int port) const {
  for (const auto& c : connections_)
    if (c.to == id && c.toPort == port) return &c;
  return nullptr;
}

void Network::notify(NetworkEvent::Kind k, const std::string& id, const std::string& param) {
  const NetworkEvent e{k, id, param};
  // Copy: a listener may unsubscribe while being notified.
  auto ls = listeners_;
  for (auto& [token, l] : ls) l(e);
}

int Network::subscribe(Listener l) {
  const int t = nextListener_++;
  listeners_[t] = std::move(l);
  return t;
}

void Network::unsubscribe(int token) { listeners_.erase(token); }

std::string Network::addModule(const std::string& name, const std::string& idIn, double x, double y) {
  const ModuleInfo* info = registry_->find(name);
  if (!info) {
    std::string known;
    for (const auto* m : registry_->all()) known += (known.empty() ? "" : ", ") + m->name;
    throw InputError("unknown module '" + name + "'; known modules: " + known);
  }
  std::string id = idIn;
  if (id.empty()) {
    std::vector<std::string> ids;
    for (const auto& m : modules_) ids.push_back(m.id);
    id = "m" + std::to_string(nextNumber("m", ids));
  } else if (module(id)) {
    throw InputError("module id '" + id + "' is used twice; ids must be unique");
  }
  ModuleNode n;
  n.id = id;
  n.info = info;
  n.params = ModuleRegistry::defaults(*info);
  n.x = x;
  n.y = y;
  modules_.push_back(std::move(n));
  index_[modules_.back().id] = modules_.size() - 1;
  notify(NetworkEvent::Kind::ModuleAdded, id);
  return id;
}

void Network::removeModule(const std::string& id) {
  requireModule(id);
  std::vector<std::string> gone;
  for (const auto& c : connections_)
    if (c.from == id || c.to == id) gone.push_back(c.id);
  for (const auto& c : gone) disconnect(c);
  modules_.erase(std::remove_if(modules_.begin(), modules_.end(),
                                [&](const ModuleNode& m) { return m.id == id; }),
                 modules_.end());
  reindex();
  notify(NetworkEvent::Kind::ModuleRemoved, id);
}

void Network::setParameter(const std::string& id, const std::string& param, const ParamValue& value) {
  ModuleNode* m = findModule(id);
  if (!m) throw InputError("no module with id '" + id + "' in the network");
  const ParamSpec* spec = m->info->param(param);
  if (!spec) {
    std::string known;
    for (const auto& p : m->info->params) known += (known.empty() ? "" : ", ") + p.name;
    throw InputError(id + " (" + m->info->name + "): unknown parameter '" + param +
                     "'; parameters: " + (known.empty() ? "none" : known));
  }
  std::string err;
  if (!checkParam(*spec, value, err))
    throw InputError(id + " (" + m->info->name + "): parameter '" + param + "': " + err);
  if (m->params[param] == value) return;
  m->params[param] = value;
  notify(NetworkEvent::Kind::ParameterChanged, id, param);
}

void Network::setParameterText(const std::string& id, const std::string& param, const std::string& text) {
  const ModuleNode& m = requireModule(id);
  const ParamSpec* spec = m.info->param(param);
  if (!spec) {
    setParameter(id, param, ParamValue{}); // throws the unknown-parameter message
    return;
  }
  std::string err;
  auto v = parseParam(*spec, text, err);
  if (!v) throw InputError(id + " (" + m.info->name + "): parameter '" + param + "': " + err);
  setParameter(id, param, *v);
}

void Network::setPosition(const std::string& id, double x, double y) {
  ModuleNode* m = findModule(id);
  if (!m) throw InputError("no module with id '" + id + "' in the network");
  if (m->x == x && m->y == y) return;
  m->x = x;
  m->y = y;
  notify(NetworkEvent::Kind::PositionChanged, id);
}

void Network::setNote(const std::string& id, const std::string& note) {
  ModuleNode* m = findModule(id);
  if (!m) throw InputError("no module with id '" + id + "' in the network");
  if (m->note == note) return;
  m->note = note;
  notify(NetworkEvent::Kind::NoteChanged, id);
}

std::vector<std::string> Network::pathBetween(const std::string& a, const std::string& b) const {
  // BFS from a along connections; returns a..b or empty.
  std::map<std::string, std::string> parent;
  std::deque<std::string> q{a};
  parent[a] = "";
  while (!q.empty()) {
    const std::string cur = q.front();
    q.pop_front();
    if (cur == b) {
      std::vector<std::string> path;
      for (std::string s = b; !s.empty(); s = parent[s]) path.push_back(s);
      std::reverse(path.begin(), path.end());
      return path;
    }
    for (const auto& c : connections_)
      if (c.from == cur && !parent.count(c.to)) {
        parent[c.to] = cur;
        q.push_back(c.to);
      }
  }
  return {};
}

std::string Network::checkConnection(const std::string& from, int fromPort, const std::string& to,
                                     int toPort) const {
  const ModuleNode* a = module(from);
  const ModuleNode* b = module(to);
  if (!a) return "no module with id '" + from + "'";
  if (!b) return "no module with id '" + to + "'";
  if (from == to) return "a module cannot feed itself (" + from + ")";
  if (fromPort < 0 || fromPort >= static_cast<int>(a->info->outputs.size()))
    return from + " (" + a->info->name + ") has no output port " + std::to_string(fromPort) +
           " (it has " + std::to_string(a->info->outputs.size()) + ")";
  if (toPort < 0 || toPort >= static_cast<int>(b->info->inputs.size()))
    return to + " (" + b->info->name + ") has no input port " + std::to_string(toPort) +
           " (it has " + std::to_string(b->info->inputs.size()) + ")";
  const PortSpec& out = a->info->outputs[fromPort];
  const PortSpec& in = b->info->inputs[toPort];
  if (!in.accepts_(out.type())) {
    std::string acc;
    for (PortType t : in.accepts) acc += (acc.empty() ? "" : " or ") + std::string(portTypeName(t));
    return "type mismatch: " + from + " output '" + out.name + "' is " + portTypeName(out.type()) +
           " but " + to + " input '" + in.name + "' takes " + acc;
  }
  if (const Connection* c = inputConnection(to, toPort))
    return to + " input '" + in.name + "' already has a wire (" + c->id + " from " + c->from +
           "); an input takes one wire";
  const auto path = pathBetween(to, from);
  if (!path.empty()) {
    std::string cyc;
    for (const auto& s : path) cyc += s + " -> ";
    cyc += to;
    return "would create a cycle: " + cyc;
  }
  return "";
}

std::string Network::connect(const std::string& from, int fromPort, const std::string& to, int toPort,
                             const std::string& idIn) {
  const std::string why = checkConnection(from, fromPort, to, toPort);
  if (!why.empty()) throw InputError("cannot connect " + from + ":" + std::to_string(fromPort) +
                                     " -> " + to + ":" + std::to_string(toPort) + ": " + why);
  std::string id = idIn;
  if (id.empty()) {
    std::vector<std::string> ids;
    for (const auto& c : connections_) ids.push_back(c.id);
    id = "c" + std::to_string(nextNumber("c", ids));
  } else if (connection(id)) {
    throw InputError("connection id '" + id + "' is used twice; ids must be unique");
  }
  connections_.push_back({id, from, fromPort, to, toPort});
  notify(NetworkEvent::Kind::Connected, id);
  return id;
}

void Network::disconnect(const std::string& connectionId) {
  auto it = std::find_if(connections_.begin(), connections_.end(),
                         [&](const Connection& c) { return c.id == connectionId; });
  if (it == connections_.end()) throw InputError("no connection with id '" + connectionId + "'");
  connections_.erase(it);
  notify(NetworkEvent::Kind::Disconnected, connectionId);
}

void Network::clear() {
  modules_.clear();
  index_.clear();
  connections_.clear();
  notify(NetworkEvent::Kind::Cleared, "");
}

std::vector<std::string> Network::upstream(const std::string& id) const {
  std::vector<std::string> v;
  for (const auto& c : connections_)
    if (c.to == id && std::find(v.begin(), v.end(), c.from) == v.end()) v.push_back(c.from);
  return v;
}

std::vector<std::string> Network::downstream(const std::string& id) const {
  std::vector<std::string> v;
  for (const auto& c : connections_)
    if (c.from == id && std::find(v.begin(), v.end(), c.to) == v.end()) v.push_back(c.to);
  return v;
}

std::vector<std::string> Network::downstreamClosure(const std::vector<std::string>& ids) const {
  std::set<std::string> seen(ids.begin(), ids.end());
  std::deque<std::string> q(ids.begin(), ids.end());
  while (!q.empty()) {
    const std::string cur = q.front();
    q.pop_front();
    for (const auto& d : downstream(cur))
      if (seen.insert(d).second) q.push_back(d);
  }
  std::vector<std::string> out;
  for (const auto& id : topologicalOrder())
    if (seen.count(id)) out.push_back(id);
  return out;
}

std::vector<std::string> Network::topologicalOrder() const {
  // Kahn's algorithm, picking the earliest-inserted ready module each time (a min-heap of
  // positions): O((modules + connections) log modules).
  const size_t n = modules_.size();
  std::vector<int> indeg(n, 0);
  std::vector<std::vector<size_t>> next(n);
  for (const auto& c : connections_) {
    const auto f = index_.find(c.from), t = index_.find(c.to);
    if (f == index_.end() || t == index_.end()) continue;
    next[f->second].push_back(t->second);
    ++indeg[t->second];
  }
  std::priority_queue<size_t, std::vector<size_t>, std::greater<size_t>> ready;
  for (size_t i = 0; i < n; ++i)
    if (indeg[i] == 0) ready.push(i);
  std::vector<std::string> order;
  order.reserve(n);
  while (!ready.empty()) { // fewer than n only with a cycle, which connect() refuses
    const size_t i = ready.top();
    ready.pop();
    order.push_back(modules_[i].id);
    for (size_t j : next[i])
      if (--indeg[j] == 0) ready.push(j);
  }
  return order;
}

std::vector<Network::FileUse> Network::fileUses() const {
  namespace fs = std::filesystem;
  auto resolve = [&](const std::string& p, bool output) {
    fs::path q(p);
    const std::string& base = output && !outputDir_.empty() ? outputDir_ : baseDir_;
    if (q.is_relative() && !base.empty()) q = fs::path(base) / q;
    std::error_code ec;
    const fs::path c = fs::weakly_canonical(q, ec);
    return (ec ? q.lexically_normal() : c).string();
  };
  std::vector<FileUse> uses;
  for (const auto& m : modules_)
    for (const auto& spec : m.info->params) {
      if (!spec.isInputPath && !spec.isOutputPath) continue;
      const auto it = m.params.find(spec.name);
      if (it == m.params.end()) continue;
      std::vector<std::string> names;
      if (const auto* s = std::get_if<std::string>(&it->second)) names.push_back(*s);
      else if (const auto* l = std::get_if<std::vector<std::string>>(&it->second)) names = *l;
      for (const auto& n : names)
        if (!n.empty()) uses.push_back({m.id, spec.name, n, resolve(n, spec.isOutputPath), spec.isOutputPath});
    }
  return uses;
}

std::vector<std::string> Network::fileConflicts() const {
  struct Use {
    std::string module, param, shown;
  };
  std::map<std::string, std::vector<Use>> reads, writes;
  for (const FileUse& u : fileUses()) (u.output ? writes : reads)[u.resolved].push_back({u.module, u.param, u.shown});
  std::vector<std::string> out;
  for (const auto& [file, ws] : writes) {
    if (const auto r = reads.find(file); r != reads.end())
      for (const Use& w : ws)
        for (const Use& u : r->second)
          out.push_back("module " + w.module + " parameter " + w.param + " writes '" + w.shown + "' (" + file +
                        "), which module " + u.module + " reads through " + u.param +
                        "; the run would overwrite its own input: choose another output file name");
    for (size_t i = 1; i < ws.size(); ++i)
      out.push_back("modules " + ws[0].module + " (" + ws[0].param + ") and " + ws[i].module + " (" + ws[i].param +
                    ") both write '" + file + "'; one output would be lost: give each writer its own file");
  }
  return out;
}

} // namespace tetflow
