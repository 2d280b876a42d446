#include "Module.h"

#include <algorithm>
#include <filesystem>
#include <mutex>

#include "ModuleRegistry.h"

namespace tetflow {

bool PortSpec::accepts_(PortType t) const {
  return std::find(accepts.begin(), accepts.end(), t) != accepts.end();
}

const ParamSpec* ModuleInfo::param(const std::string& n) const {
  for (const auto& p : params)
    if (p.name == n) return &p;
  return nullptr;
}

namespace {
int portIndex(const std::vector<PortSpec>& ports, const std::string& s) {
  for (size_t i = 0; i < ports.size(); ++i)
    if (ports[i].name == s) return static_cast<int>(i);
  if (!s.empty() && std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); }) &&
      s.size() < 6) {
    const int i = std::stoi(s);
    if (i >= 0 && i < static_cast<int>(ports.size())) return i;
  }
  return -1;
}
} // namespace

int ModuleInfo::inputIndex(const std::string& s) const { return portIndex(inputs, s); }
int ModuleInfo::outputIndex(const std::string& s) const { return portIndex(outputs, s); }

ExecutionContext::ExecutionContext(const ModuleInfo& info, std::string moduleId, ParamValues params,
                                   std::vector<DataPtr> inputs, std::string baseDir,
                                   Progress& progress, std::string outputDir)
    : info_(info), moduleId_(std::move(moduleId)), params_(std::move(params)),
      inputs_(std::move(inputs)), outputs_(info.outputs.size()), baseDir_(std::move(baseDir)),
      outputDir_(std::move(outputDir)), progress_(progress) {}

const ParamValue& ExecutionContext::value(const std::string& name) const {
  auto it = params_.find(name);
  if (it == params_.end())
    throw ProcessingError(moduleId_ + ": module " + info_.name + " has no parameter '" + name + "'");
  return it->second;
}

bool ExecutionContext::getBool(const std::string& n) const { return std::get<bool>(value(n)); }
int64_t ExecutionContext::getInt(const std::string& n) const { return std::get<int64_t>(value(n)); }
double ExecutionContext::getDouble(const std::string& n) const { return std::get<double>(value(n)); }
const std::string& ExecutionContext::getString(const std::string& n) const {
  return std::get<std::string>(value(n));
}
const std::vector<std::string>& ExecutionContext::getList(const std::string& n) const {
  return std::get<std::vector<std::string>>(value(n));
}

std::string ExecutionContext::resolvePath(const std::string& path, bool output) const {
  if (path.empty()) return path;
  std::filesystem::path p(path);
  const std::string& base = output && !outputDir_.empty() ? outputDir_ : baseDir_;
  if (p.is_absolute() || base.empty()) return path;
  return (std::filesystem::path(base) / p).lexically_normal().string();
}

std::string ExecutionContext::getPath(const std::string& n) const {
  const std::string& p = getString(n);
  if (p.empty())
    throw InputError(moduleId_ + ": parameter '" + n + "' is empty; give a file name");
  const ParamSpec* spec = info_.param(n);
  return resolvePath(p, spec && spec->isOutputPath);
}

const DataPtr& ExecutionContext::input(size_t port) const {
  if (port >= inputs_.size() || !inputs_[port]) {
    const std::string name = port < info_.inputs.size() ? info_.inputs[port].name : "?";
    throw InputError(moduleId_ + ": input port " + std::to_string(port) + " (" + name +
                     ") is not connected");
  }
  return inputs_[port];
}

void ExecutionContext::setOutput(size_t port, DataPtr data) {
  if (port >= outputs_.size())
    throw ProcessingError(moduleId_ + ": no output port " + std::to_string(port));
  if (data && data->type() != info_.outputs[port].type())
    throw ProcessingError(moduleId_ + ": output port " + std::to_string(port) + " expects " +
                          portTypeName(info_.outputs[port].type()) + ", got " +
                          portTypeName(data->type()));
  outputs_[port] = std::move(data);
}

void ExecutionContext::log(const std::string& message) { messages_.push_back(message); }

// ---- registry ---------------------------------------------------------------------------

void ModuleRegistry::add(ModuleInfo info) {
  if (info.name.empty() || !info.factory)
    throw std::logic_error("module registration needs a name and a factory");
  if (modules_.count(info.name)) throw std::logic_error("module " + info.name + " registered twice");
  for (const auto& p : info.params) {
    std::string err;
    if (!checkParam(p, p.defaultValue, err))
      throw std::logic_error(info.name + "." + p.name + ": default " + err);
  }
  for (const auto& o : info.outputs)
    if (o.accepts.size() != 1) throw std::logic_error(info.name + ": output " + o.name + " needs one type");
  for (const auto& i : info.inputs)
    if (i.accepts.empty()) throw std::logic_error(info.name + ": input " + i.name + " needs a type");
  const std::string name = info.name;
  modules_.emplace(name, std::move(info));
}

const ModuleInfo* ModuleRegistry::find(const std::string& name) const {
  auto it = modules_.find(name);
  return it == modules_.end() ? nullptr : &it->second;
}

std::vector<const ModuleInfo*> ModuleRegistry::all() const {
  std::vector<const ModuleInfo*> v;
  for (const auto& [n, m] : modules_) v.push_back(&m);
  std::stable_sort(v.begin(), v.end(), [](const ModuleInfo* a, const ModuleInfo* b) {
    return a->category < b->category || (a->category == b->category && a->name < b->name);
  });
  return v;
}

ParamValues ModuleRegistry::defaults(const ModuleInfo& info) {
  ParamValues v;
  for (const auto& p : info.params) v[p.name] = p.defaultValue;
  return v;
}

} // namespace tetflow
