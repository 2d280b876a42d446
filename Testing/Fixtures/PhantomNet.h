#pragma once
// Phantom pipelines for the dataflow tests. addPhantomPipeline: the smallest meshing net, as a user
// builds it in the node editor: CreatePhantom ("p") -> GenerateBackgroundMesh ("bg") -> CleaveMesh
// ("cl") -> EvaluateQuality ("q", with the phantom as its reference), every parameter at its default.
#include <sstream>
#include <string>

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

// The head phantom of the FEM tests (scalp 1, skull 2, CSF 3, brain 4; radii "scalp skull csf
// brain" in mm, voxel size in mm) -> regular BCC lattice of `cell` mm -> CleaveMesh ("cl", air kept),
// with the thin layers not refined: the lattices the tests' figures were measured on (refining the
// thin CSF and skull would change, and slow, every solve there; the forward-accuracy benchmarks
// measure that).
inline void addHeadPipeline(Network& net, const std::string& radii, double voxel, double cell) {
  std::istringstream s(radii);
  std::string r[4];
  s >> r[0] >> r[1] >> r[2] >> r[3];
  net.addModule("CreatePhantom", "p");
  net.setParameterText("p", "kind", "head");
  net.setParameterText("p", "voxel_size", std::to_string(voxel));
  net.setParameterText("p", "radius", r[0]);
  net.setParameterText("p", "skull_radius", r[1]);
  net.setParameterText("p", "csf_radius", r[2]);
  net.setParameterText("p", "brain_radius", r[3]);
  net.addModule("GenerateBackgroundMesh", "bg");
  net.setParameterText("bg", "cell_size", std::to_string(cell));
  net.setParameterText("bg", "refine_thin_layers", "none");
  net.addModule("CleaveMesh", "cl");
  net.setParameterText("cl", "strip_exterior", "0");
  net.connect("p", 0, "bg", 0);
  net.connect("p", 0, "cl", 0);
  net.connect("bg", 0, "cl", 1);
}

} // namespace tetflow::test
