#pragma once
// The smallest meshing net, as a user builds it in the node editor: CreatePhantom ("p") ->
// GenerateBackgroundMesh ("bg") -> CleaveMesh ("cl") -> EvaluateQuality ("q", with the phantom as
// its reference), every parameter at its default.
#include "Dataflow/Network.h"

namespace tetflow::test {

inline void addPhantomPipeline(Network& net) {
  net.addModule("CreatePhantom", "p");
  net.addModule("GenerateBackgroundMesh", "bg");
  net.addModule("CleaveMesh", "cl");
  net.addModule("EvaluateQuality", "q");
  net.connect("p", 0, "bg", 0);
  net.connect("p", 0, "cl", 0);
  net.connect("bg", 0, "cl", 1);
  net.connect("cl", 0, "q", 0);
  net.connect("p", 0, "q", 1);
}

} // namespace tetflow::test
