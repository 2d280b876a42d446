#pragma once
// The network that meshes a label volume file (issue 30), built in one place for everyone who
// needs it: `tetflow mesh` builds and runs it, the node editor builds it for a volume file it
// opens, and Nets/mesh_labels.srn and Nets/mesh_labels_adaptive.srn are it for the bundled head
// (a test compares them). The shape of the shipped phantom nets, starting from a file:
//
//   regular:           ReadLabelVolume m1 -> GenerateBackgroundMesh m2 (regular_bcc) -> CleaveMesh m3
//                        -> EvaluateQuality m4 (certificate against m1) -> WriteMesh m5
//   octree, particles: the same, with ComputeSizingField m6 (m1 -> m6 -> m2's sizing port) and
//                        m2 of kind octree_bcc or particles
//
// Every module keeps its defaults except what the sizes and files set (and, with `certify`, the
// shipped nets' thresholds). The sizes left at 0 are chosen from the voxels (chooseMeshSizes):
// the shipped phantom nets' sizes for their 2 mm voxels, scaled with the voxel.
#include <optional>
#include <string>
#include <vector>

#include "Algorithms/Core/Volume.h"
#include "Dataflow/Network.h"

namespace tetflow {

enum class MeshBackground { Regular, Octree, Particles };
const char* meshBackgroundName(MeshBackground b); // regular, octree, particles
std::optional<MeshBackground> meshBackgroundFromName(const std::string& name);

struct MeshLabelsOptions {
  std::string labels;       // the label volume file, as the network names it
  std::string labelTable;   // ReadLabelVolume's label_table ("" = found beside the volume)
  std::string output;       // the mesh file, as the network names it
  std::string format = "auto"; // WriteMesh's format
  MeshBackground background = MeshBackground::Regular;
  double cellSize = 0;      // regular: the lattice's cell edge (mm); 0 = chosen
  double minSize = 0;       // octree, particles: the sizing field's smallest size (mm); 0 = chosen
  double maxSize = 0;       // octree, particles: its largest size (mm); 0 = chosen
  // The shipped nets' certificate thresholds (every label within 1.5 %, every component, no
  // spurious contact, every tet in [10, 160] deg): the run fails when the mesh misses one (the
  // mesh is still written). Off: the certificate is computed and reported, nothing fails on it.
  bool certify = false;
  // CleaveMesh's strip_exterior: the label whose exterior (its voxels connected to the box) is
  // removed, e.g. the air around a head (exteriorLabelOf chooses it); none keeps everything.
  std::optional<int32_t> exterior;
  // GenerateBackgroundMesh's max_tets (0 = no budget): every size is scaled up until the mesh
  // cleaving makes is predicted to fit.
  int64_t maxTets = 0;
};

// The label tetflow mesh strips by default: 0 when some voxel on the box's faces carries it (the
// background around a segmented body), else none.
std::optional<int32_t> exteriorLabelOf(const LabelVolume& labels);

// The voxel size the defaults scale with: the longest side of a voxel (mm).
double meshVoxelSize(const GridGeometry& grid);
// Fills the sizes options leaves at 0 for the background it asks for, from the voxels: cell size
// 4 x the voxel (regular); sizing field from 4 x (octree; particles 2 x) to 16 x the voxel. Returns
// one line per size saying what it is and whether it was chosen or given.
std::vector<std::string> chooseMeshSizes(MeshLabelsOptions& options, const GridGeometry& grid);

// The mesh file name tetflow mesh and the node editor give a volume by default: the volume's file
// name without its volume extension (".nii.gz" and all), plus ".vtu" (or the format's extension).
std::string defaultMeshFileName(const std::string& labelsPath, const std::string& format = "auto");

// The network; sizes must be set (chooseMeshSizes). Throws InputError for a value a module
// refuses (naming the module and parameter).
Network buildMeshLabelsNetwork(const ModuleRegistry& registry, const MeshLabelsOptions& options);

} // namespace tetflow
