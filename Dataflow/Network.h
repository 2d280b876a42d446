#pragma once
// The network model: modules (with parameters, position, note), typed connections, and plain
// change notifications. The GUI observes and edits it through this API, the same one the .srn
// loader and the headless runner use; nothing here knows about Qt or about concrete modules.
//
// Rules enforced on every edit (InputError with the reason, network unchanged on failure):
//  - connections go from an output port to an input port of another module,
//  - the output's type must be one the input accepts,
//  - an input port takes one wire,
//  - no cycles (the message names the cycle).
#include <functional>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include "Module.h"
#include "ModuleRegistry.h"

namespace tetflow {

struct ModuleNode {
  std::string id; // "m1", "m2", ...
  const ModuleInfo* info = nullptr;
  ParamValues params; // every parameter of the module (defaults merged)
  double x = 0, y = 0; // canvas position
  std::string note;
};

struct Connection {
  std::string id; // "c1", ...
  std::string from;
  int fromPort = 0;
  std::string to;
  int toPort = 0;
  bool operator==(const Connection&) const = default;
};

struct NetworkEvent {
  enum class Kind {
    ModuleAdded, ModuleRemoved, Connected, Disconnected, ParameterChanged, PositionChanged,
    NoteChanged, Cleared
  };
  Kind kind;
  std::string id;    // module id, or connection id for (Dis)Connected
  std::string param; // ParameterChanged only
};

class Network {
public:
  explicit Network(const ModuleRegistry& registry) : registry_(&registry) {}
  const ModuleRegistry& registry() const { return *registry_; }

  // --- edits ---
  // Adds a module of type `name`; `id` empty = next free "mN". InputError for an unknown name
  // (listing the known ones) or a duplicate id.
  std::string addModule(const std::string& name, const std::string& id = "", double x = 0,
                        double y = 0);
  void removeModule(const std::string& id); // also removes its connections
  void setParameter(const std::string& id, const std::string& param, const ParamValue& value);
  // Parse `text` as the parameter's type (what --set and the .srn loader use).
  void setParameterText(const std::string& id, const std::string& param, const std::string& text);
  void setPosition(const std::string& id, double x, double y);
  void setNote(const std::string& id, const std::string& note);
  std::string connect(const std::string& from, int fromPort, const std::string& to, int toPort,
                      const std::string& id = "");
  void disconnect(const std::string& connectionId);
  void clear();

  // Why connecting would be refused, or "" when allowed (used by the GUI while dragging).
  std::string checkConnection(const std::string& from, int fromPort, const std::string& to,
                              int toPort) const;

  // --- queries ---
  const std::vector<ModuleNode>& modules() const { return modules_; } // insertion order
  const std::vector<Connection>& connections() const { return connections_; }
  const ModuleNode* module(const std::string& id) const;
  const ModuleNode& requireModule(const std::string& id) const; // InputError if absent
  const Connection* connection(const std::string& id) const;
  // The connection feeding input port `port` of module `id`, or nullptr.
  const Connection* inputConnection(const std::string& id, int port) const;
  std::vector<std::string> upstream(const std::string& id) const;   // direct
  std::vector<std::string> downstream(const std::string& id) const; // direct
  // `ids` and everything downstream of them.
  std::vector<std::string> downstreamClosure(const std::vector<std::string>& ids) const;
  // Topological order of all modules (ties in insertion order).
  std::vector<std::string> topologicalOrder() const;

  // --- observation ---
  using Listener = std::function<void(const NetworkEvent&)>;
  int subscribe(Listener l);
  void unsubscribe(int token);

  // Free text about the whole network (the .srn root <note>).
  const std::string& note() const { return note_; }
  void setNetworkNote(const std::string& n) { note_ = n; }

  // Folder that relative file names resolve against (the .srn file's folder).
  const std::string& baseDir() const { return baseDir_; }
  void setBaseDir(const std::string& d) { baseDir_ = d; }
  // When set, relative *output* file names resolve against this folder instead (headless
  // `--output-dir`); input files still resolve against baseDir.
  const std::string& outputDir() const { return outputDir_; }
  void setOutputDir(const std::string& d) { outputDir_ = d; }
  // Output files that would destroy data: an output parameter naming a file that some module
  // reads (e.g. WriteVolume over the net's own ReadLabelVolume input), or two output parameters
  // naming one file. One message per conflict, naming both modules and parameters and the file;
  // empty when there is none. Paths resolve as the modules resolve them (baseDir, outputDir).
  std::vector<std::string> fileConflicts() const;
  // Every file a parameter names: module, parameter, the name as written, the path it resolves to
  // (weakly canonical), and whether the module writes it.
  struct FileUse {
    std::string module, param, shown, resolved;
    bool output = false;
  };
  std::vector<FileUse> fileUses() const;

private:
  ModuleNode* findModule(const std::string& id);
  void notify(NetworkEvent::Kind k, const std::string& id, const std::string& param = "");
  std::vector<std::string> pathBetween(const std::string& a, const std::string& b) const;

  const ModuleRegistry* registry_;
  void reindex();

  std::vector<ModuleNode> modules_;
  std::unordered_map<std::string, size_t> index_; // module id -> position in modules_
  std::vector<Connection> connections_;
  std::map<int, Listener> listeners_;
  int nextListener_ = 1;
  std::string baseDir_;
  std::string outputDir_;
  std::string note_;
};

} // namespace tetflow
