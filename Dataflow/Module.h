#pragma once
// Module contract (DESIGN §3): a module declares its ports and parameters (ModuleInfo), maps the
// parameters onto an algorithm's Params struct, calls the algorithm once and sends the result.
// Validation lives in the algorithm; a module throws tetflow::InputError / ProcessingError and the
// executor records it against the module id. Modules never include Qt.
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Report.h"
#include "Parameter.h"
#include "PortTypes.h"

namespace tetflow {

struct PortSpec {
  std::string name;              // e.g. "volume", "mesh"; usable in .srn instead of the index
  std::vector<PortType> accepts; // inputs: accepted types (first = main); outputs: exactly one
  std::string description;
  bool optional = false;         // inputs only: may stay unconnected
  PortType type() const { return accepts.front(); }
  bool accepts_(PortType t) const;
};

class ExecutionContext;

class Module {
public:
  virtual ~Module() = default;
  virtual void execute(ExecutionContext& ctx) = 0;
};

struct ModuleInfo {
  std::string name;        // registry key, e.g. "CleaveMesh"
  std::string package = "TetFlow";
  std::string category;    // e.g. "DataIO", "Meshing", "FEM"
  std::string description; // one paragraph
  std::vector<PortSpec> inputs;
  std::vector<PortSpec> outputs;
  std::vector<ParamSpec> params;
  std::vector<std::string> summaryKeys; // Report keys shown on the runner's one-line summary
  std::function<std::unique_ptr<Module>()> factory;
  // Files the module reads besides those its path parameters name (e.g. the label table found
  // beside a volume), given its parameters and the network's folder: their size and time join
  // the result's cache signature, so that editing, adding or removing one runs it again.
  std::function<std::vector<std::string>(const std::map<std::string, ParamValue>&, const std::string& baseDir)>
      sideFiles;

  const ParamSpec* param(const std::string& n) const;
  // Port index by name or by decimal index text; -1 when unknown.
  int inputIndex(const std::string& nameOrIndex) const;
  int outputIndex(const std::string& nameOrIndex) const;
};

using ParamValues = std::map<std::string, ParamValue>;

// What a module sees while it runs.
class ExecutionContext {
public:
  ExecutionContext(const ModuleInfo& info, std::string moduleId, ParamValues params,
                   std::vector<DataPtr> inputs, std::string baseDir, Progress& progress,
                   std::string outputDir = "");

  const std::string& moduleId() const { return moduleId_; }
  Progress& progress() { return progress_; }
  Report& report() { return report_; }
  const Report& report() const { return report_; }

  bool getBool(const std::string& name) const;
  int64_t getInt(const std::string& name) const;
  double getDouble(const std::string& name) const;
  const std::string& getString(const std::string& name) const; // String and Enum
  const std::vector<std::string>& getList(const std::string& name) const;
  // A path parameter resolved against the network file's folder (absolute paths unchanged);
  // output-path parameters resolve against the output folder when one is set.
  std::string getPath(const std::string& name) const;
  std::string resolvePath(const std::string& path, bool output = false) const;

  bool hasInput(size_t port) const { return port < inputs_.size() && inputs_[port] != nullptr; }
  const DataPtr& input(size_t port) const;
  // Typed access; throws ProcessingError when the port is empty or of another type.
  template <class D>
  const D& inputAs(size_t port) const {
    const D* d = dynamic_cast<const D*>(input(port).get());
    if (!d) throw ProcessingError(moduleId_ + ": input port " + std::to_string(port) +
                                  " does not hold a " + portTypeName(D::kType));
    return *d;
  }
  void setOutput(size_t port, DataPtr data);
  const std::vector<DataPtr>& outputs() const { return outputs_; }

  void log(const std::string& message);
  const std::vector<std::string>& messages() const { return messages_; }

private:
  const ParamValue& value(const std::string& name) const;
  const ModuleInfo& info_;
  std::string moduleId_;
  ParamValues params_;
  std::vector<DataPtr> inputs_;
  std::vector<DataPtr> outputs_;
  std::string baseDir_;
  std::string outputDir_;
  Progress& progress_;
  Report report_;
  std::vector<std::string> messages_;
};

} // namespace tetflow
