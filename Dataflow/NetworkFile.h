#pragma once
// .srn network files in SCIRun 4's XML layout (DESIGN §4):
//
//   <network version="tetflow-1" name="{Main}">
//     <note>{...}</note>
//     <modules>
//       <module id="m1" package="TetFlow" category="DataIO" name="ReadLabelVolume" version="1.0">
//         <position x="10" y="20"/>
//         <note position="{def}" color="{white}">{text}</note>
//         <var name="filename" val="{head.nrrd}" substitute="no"/>
//       </module>
//     </modules>
//     <connections>
//       <connection id="c1" from="m1" fromport="0" to="m2" toport="volume"/>
//     </connections>
//   </network>
//
// Values may be wrapped in one pair of Tcl braces (SCIRun writes them; we do too). The module
// `name` is the key; `package` and `category` are written but optional on load. Ports are given by
// index or by name. Relative file names resolve against the file's folder at run time.
//
// Loading checks everything and reports *every* problem (unknown module, parameter or port, bad
// value, duplicate id, type-mismatched, doubly-fed or cyclic connection, malformed XML) with its
// line number and module id, in one NetworkLoadError; nothing is dropped silently. Saving writes
// every parameter, so save -> load -> save gives the same bytes.
#include <string>
#include <vector>

#include "Network.h"

namespace tetflow {

struct LoadProblem {
  int line = 0;
  std::string moduleId; // may be empty (e.g. XML syntax errors, connections)
  std::string message;
};

class NetworkLoadError : public InputError {
public:
  NetworkLoadError(const std::string& file, std::vector<LoadProblem> problems);
  const std::string& file() const { return file_; }
  const std::vector<LoadProblem>& problems() const { return problems_; }

private:
  std::string file_;
  std::vector<LoadProblem> problems_;
};

// Load a network file. `displayName` names the file in messages; relative paths in the network
// resolve against `baseDir`.
Network loadNetworkFromString(const std::string& xml, const std::string& displayName,
                              const std::string& baseDir, const ModuleRegistry& registry);
Network loadNetwork(const std::string& path, const ModuleRegistry& registry);

std::string saveNetworkToString(const Network& net);
void saveNetwork(const std::string& path, const Network& net); // atomic (temp file + rename)

} // namespace tetflow
