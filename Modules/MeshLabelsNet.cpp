#include "MeshLabelsNet.h"

#include <algorithm>

#include "Algorithms/IO/VolumeIO.h"
#include "Dataflow/Parameter.h"

namespace tetflow {

const char* meshBackgroundName(MeshBackground b) {
  switch (b) {
    case MeshBackground::Regular: return "regular";
    case MeshBackground::Octree: return "octree";
    case MeshBackground::Particles: return "particles";
  }
  return "?";
}

std::optional<MeshBackground> meshBackgroundFromName(const std::string& name) {
  for (auto b : {MeshBackground::Regular, MeshBackground::Octree, MeshBackground::Particles})
    if (name == meshBackgroundName(b)) return b;
  return std::nullopt;
}

std::string defaultMeshFileName(const std::string& labelsPath, const std::string& format) {
  std::string stem = labelsPath.substr(labelsPath.find_last_of('/') + 1);
  for (const auto& ext : volumeExtensions())
    if (stem.size() > ext.size() && stem.compare(stem.size() - ext.size(), ext.size(), ext) == 0) {
      stem.resize(stem.size() - ext.size());
      break;
    }
  const std::string ext = format == "vtk"                ? ".vtk"
                          : format == "tetgen"           ? ".node"
                          : format.rfind("msh", 0) == 0 ? ".msh"
                                                          : ".vtu";
  return stem + ext;
}

std::optional<int32_t> exteriorLabelOf(const LabelVolume& v) {
  const auto& d = v.grid.dims;
  for (int64_t k = 0; k < d[2]; ++k)
    for (int64_t j = 0; j < d[1]; ++j) {
      const bool face = k == 0 || k == d[2] - 1 || j == 0 || j == d[1] - 1;
      for (int64_t i = 0; i < d[0]; i += face ? 1 : std::max<int64_t>(1, d[0] - 1))
        if (v.at(i, j, k) == 0) return 0;
    }
  return std::nullopt;
}

double meshVoxelSize(const GridGeometry& grid) {
  return std::max({grid.spacing[0], grid.spacing[1], grid.spacing[2]});
}

std::vector<std::string> chooseMeshSizes(MeshLabelsOptions& o, const GridGeometry& grid) {
  const double voxel = meshVoxelSize(grid);
  std::vector<std::string> lines;
  auto pick = [&](double& value, double times, const std::string& what, const std::string& option) {
    const bool chosen = value <= 0;
    if (chosen) value = times * voxel;
    lines.push_back(what + " " + formatDouble(value) + " mm" +
                    (chosen ? " (" + formatDouble(times) + " x the " + formatDouble(voxel) + " mm voxels; " + option +
                                  " to change)"
                            : " (" + option + ")"));
  };
  // The lattices' layers thinner than their cells are refined where they are missed (the thin-
  // layer refinement, to their own thickness), so their sizes need not follow the thinnest layer:
  // 4 x the voxel. The particles have no such refinement: their smallest size is 2 x the voxel.
  if (o.background == MeshBackground::Regular) {
    pick(o.cellSize, 4, "cell size", "--cell-size");
  } else {
    pick(o.minSize, o.background == MeshBackground::Octree ? 4 : 2, "smallest element size", "--min-size");
    pick(o.maxSize, 16, "largest element size", "--max-size");
  }
  return lines;
}

Network buildMeshLabelsNetwork(const ModuleRegistry& registry, const MeshLabelsOptions& o) {
  const bool adaptive = o.background != MeshBackground::Regular;
  Network net(registry);
  const std::string backgroundText =
      o.background == MeshBackground::Regular
          ? "a regular BCC lattice of " + formatDouble(o.cellSize) + " mm cells, refined where a layer is thinner than the cells"
          : std::string(o.background == MeshBackground::Octree ? "a BCC lattice graded on an octree"
                                                                : "an electrostatic particle mesh") +
                " by the sizing field from the local feature size (ComputeSizingField, sizes " + formatDouble(o.minSize) +
                " to " + formatDouble(o.maxSize) + " mm, growth 0.5 mm/mm as in the adaptive phantom nets)";
  const std::string stripText = o.exterior ? "label " + std::to_string(*o.exterior) + " outside the body stripped"
                                            : "nothing stripped";
  const std::string budgetText =
      o.maxTets > 0 ? ", every size scaled up until the mesh is predicted to fit " + std::to_string(o.maxTets) + " tets" : "";
  net.setNetworkNote("A label volume meshed as `tetflow mesh` meshes it: read with its tissue names, " + backgroundText +
                     budgetText + ", lattice cleaving with the modules' defaults (label repair, volume correction, "
                     "improvement; " + stripText + "), quality and certificate against the voxels" +
                     (o.certify ? " (failing the run unless every label is within 1.5 %, every component is kept, no "
                                  "spurious contact appears and every dihedral angle is in [10, 160] deg)"
                                : " (reported; nothing fails on it)") +
                     ", written to a mesh file. Sizes scale with the voxels: 4 x the voxel for the lattice's cells, "
                     "4 x to 16 x for the octree's sizing field (2 x to 16 x for the particles').");
  net.addModule("ReadLabelVolume", "m1", 40, 40);
  net.setParameterText("m1", "filename", o.labels);
  if (!o.labelTable.empty()) net.setParameterText("m1", "label_table", o.labelTable);
  // One column, top to bottom; the sizing field (adaptive) between the volume and the background.
  const double y0 = adaptive ? 240 : 140;
  net.addModule("GenerateBackgroundMesh", "m2", 40, y0);
  net.addModule("CleaveMesh", "m3", 40, y0 + 100);
  net.addModule("EvaluateQuality", "m4", 40, y0 + 200);
  net.addModule("WriteMesh", "m5", 40, y0 + 300);
  if (adaptive) {
    net.addModule("ComputeSizingField", "m6", 40, 140);
    net.setParameterText("m2", "kind", o.background == MeshBackground::Octree ? "octree_bcc" : "particles");
    net.setParameterText("m6", "lipschitz", "0.5");
    net.setParameterText("m6", "min_size", formatDouble(o.minSize));
    net.setParameterText("m6", "max_size", formatDouble(o.maxSize));
  } else {
    net.setParameterText("m2", "cell_size", formatDouble(o.cellSize));
  }
  if (o.exterior) {
    net.setParameterText("m3", "strip_exterior", std::to_string(*o.exterior));
    net.setParameterText("m2", "max_tets_exterior", std::to_string(*o.exterior));
  }
  if (o.maxTets > 0) net.setParameterText("m2", "max_tets", std::to_string(o.maxTets));
  if (o.certify) {
    net.setParameterText("m4", "max_volume_error", "1.5");
    net.setParameterText("m4", "require_components", "true");
    net.setParameterText("m4", "forbid_spurious_contacts", "true");
    net.setParameterText("m4", "require_min_dihedral", "10");
    net.setParameterText("m4", "require_max_dihedral", "160");
  }
  net.setParameterText("m5", "filename", o.output);
  net.setParameterText("m5", "format", o.format);
  net.connect("m1", 0, "m2", 0, "c1");
  net.connect("m1", 0, "m3", 0, "c2");
  net.connect("m2", 0, "m3", 1, "c3");
  net.connect("m3", 0, "m4", 0, "c4");
  net.connect("m1", 0, "m4", 1, "c5");
  net.connect("m4", 0, "m5", 0, "c6");
  if (adaptive) {
    net.connect("m1", 0, "m6", 0, "c7");
    net.connect("m6", 0, "m2", 1, "c8");
  }
  return net;
}

} // namespace tetflow
