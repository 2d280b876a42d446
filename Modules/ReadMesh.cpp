// ReadMesh: a tetrahedral mesh from .vtu, .vtk, Gmsh .msh (2.x, 4.1) or TetGen .node/.ele.
#include "Algorithms/IO/MeshIO.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
class ReadMesh : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const std::string path = ctx.getPath("filename");
    ctx.progress().beginStage("read");
    TetMesh mesh = readMesh(path);
    ctx.progress().endStage();
    ctx.report().set("file", path);
    ctx.report().set("vertices", ReportValue(int64_t(mesh.numPoints())));
    ctx.report().set("tets", ReportValue(int64_t(mesh.numTets())));
    if (!mesh.materialNames.empty()) {
      std::string names;
      for (const auto& [label, name] : mesh.materialNames) {
        if (!names.empty()) names += "; ";
        names += std::to_string(label) + " " + name;
      }
      ctx.report().set("material_names", names);
    }
    ctx.setOutput(0, makeData<TetMeshData>(std::move(mesh)));
  }
};
} // namespace

void registerReadMesh(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "ReadMesh";
  m.category = "DataIO";
  m.description = "Reads a tetrahedral mesh (.vtu, .vtk, Gmsh .msh 2.x / 4.1 ASCII or binary, "
                  "TetGen .node/.ele) with its material labels, names (.msh physical names) and "
                  "fields (.vtu, .vtk). From .msh only 4-node tetrahedra are kept; boundary "
                  "triangles, lines and points are skipped.";
  m.outputs = {{"mesh", {PortType::TetMesh}, "the mesh"}};
  ParamSpec f;
  f.name = "filename";
  f.type = ParamType::String;
  f.defaultValue = std::string();
  f.description = "mesh file; relative names resolve against the network file's folder";
  f.isInputPath = true;
  m.params = {f};
  m.summaryKeys = {"vertices", "tets"};
  m.factory = [] { return std::make_unique<ReadMesh>(); };
  r.add(std::move(m));
}

} // namespace tetflow
