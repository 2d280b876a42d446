// WriteMesh: a tetrahedral mesh to .vtu, .vtk, Gmsh .msh (4.1, or 2.2 ASCII / binary) or TetGen
// .node/.ele.
#include <filesystem>

#include "Algorithms/IO/MeshIO.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
MeshFormat formatFromName(const std::string& s) {
  if (s == "vtu") return MeshFormat::Vtu;
  if (s == "vtk") return MeshFormat::VtkLegacy;
  if (s == "msh") return MeshFormat::Gmsh41;
  if (s == "tetgen") return MeshFormat::TetGen;
  if (s == "msh22") return MeshFormat::Gmsh22;
  if (s == "msh22_binary") return MeshFormat::Gmsh22Binary;
  return MeshFormat::Auto;
}

class WriteMesh : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const std::string path = ctx.getPath("filename");
    const TetMesh& mesh = ctx.inputAs<TetMeshData>(0).value;
    ctx.progress().beginStage("write");
    writeMesh(path, mesh, formatFromName(ctx.getString("format")));
    ctx.progress().endStage();
    ctx.report().set("file", path);
    ctx.report().set("vertices", ReportValue(int64_t(mesh.numPoints())));
    ctx.report().set("tets", ReportValue(int64_t(mesh.numTets())));
  }
};
} // namespace

void registerWriteMesh(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "WriteMesh";
  m.category = "DataIO";
  m.description = "Writes a tetrahedral mesh: .vtu / .vtk (material and fields as cell/point "
                  "data), .msh (Gmsh 4.1, or 2.2 with format msh22 / msh22_binary as SimNIBS and "
                  "DUNEuro read it; material as named physical group), .node/.ele (TetGen, "
                  "material as region attribute). Written atomically.";
  m.inputs = {{"mesh", {PortType::TetMesh}, "mesh to write"}};
  ParamSpec f;
  f.name = "filename";
  f.type = ParamType::String;
  f.defaultValue = std::string();
  f.description = "output file; relative names resolve against the network file's folder";
  f.isOutputPath = true;
  ParamSpec fmt;
  fmt.name = "format";
  fmt.type = ParamType::Enum;
  fmt.defaultValue = std::string("auto");
  fmt.choices = {"auto", "vtu", "vtk", "msh", "tetgen", "msh22", "msh22_binary"};
  fmt.description = "file format; auto = from the file extension (.msh: MSH 4.1); msh22 and "
                    "msh22_binary: Gmsh MSH 2.2 ASCII / binary";
  m.params = {f, fmt};
  m.summaryKeys = {"tets", "file"};
  m.factory = [] { return std::make_unique<WriteMesh>(); };
  r.add(std::move(m));
}

} // namespace tetflow
