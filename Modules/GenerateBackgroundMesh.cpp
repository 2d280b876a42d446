// GenerateBackgroundMesh: the background tet mesh that cleaving deforms (seed §4.4).
#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
class GenerateBackgroundMesh : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const DataPtr& in = ctx.input(0);
    const GridGeometry grid = in->type() == PortType::LabelVolume
                                  ? ctx.inputAs<LabelVolumeData>(0).value.grid
                                  : ctx.inputAs<MaterialsData>(0).value->grid();
    BccParams p;
    p.cell_size = ctx.getDouble("cell_size");
    p.padding = ctx.getDouble("padding");
    BackgroundMesh bg = generateRegularBcc(grid, p, ctx.progress());
    // The lattice kind travels with the mesh so CleaveMesh can apply alpha_short / alpha_long.
    Field kind;
    kind.values.reserve(bg.kind.size());
    for (auto k : bg.kind) kind.values.push_back(double(static_cast<int>(k)));
    bg.mesh.pointFields["lattice_kind"] = std::move(kind);
    Report& r = ctx.report();
    r.set("kind", "regular_bcc");
    r.set("cells", std::to_string(bg.cells[0]) + " x " + std::to_string(bg.cells[1]) + " x " +
                       std::to_string(bg.cells[2]));
    r.set("cell_size_mm", std::to_string(bg.cellSize[0]) + " x " + std::to_string(bg.cellSize[1]) +
                              " x " + std::to_string(bg.cellSize[2]));
    r.set("vertices", ReportValue(int64_t(bg.mesh.numPoints())));
    r.set("tets", ReportValue(int64_t(bg.mesh.numTets())));
    r.set("box_volume_mm3", ReportValue(bg.boxVolume));
    ctx.setOutput(0, makeData<TetMeshData>(std::move(bg.mesh)));
  }
};
} // namespace

void registerGenerateBackgroundMesh(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "GenerateBackgroundMesh";
  m.category = "Meshing";
  m.description = "Builds the background mesh for cleaving: a regular body-centred cubic lattice "
                  "covering exactly the volume's box (plus padding), with tets bisected at the box "
                  "faces so the mesh ends on the box.";
  m.inputs = {{"volume", {PortType::LabelVolume, PortType::Materials}, "gives the box to cover"}};
  m.outputs = {{"mesh", {PortType::TetMesh}, "background tet mesh"}};
  ParamSpec kind;
  kind.name = "kind";
  kind.type = ParamType::Enum;
  kind.defaultValue = std::string("regular_bcc");
  kind.choices = {"regular_bcc"};
  kind.description = "lattice type";
  ParamSpec cs;
  cs.name = "cell_size";
  cs.type = ParamType::Double;
  cs.defaultValue = 4.0;
  cs.min = 1e-6;
  cs.unit = "mm";
  cs.description = "edge of a lattice cell (rounded per axis so cells tile the box exactly)";
  ParamSpec pad;
  pad.name = "padding";
  pad.type = ParamType::Double;
  pad.defaultValue = 0.0;
  pad.min = 0.0;
  pad.unit = "mm";
  pad.description = "margin added around the volume's box on every side";
  m.params = {kind, cs, pad};
  m.summaryKeys = {"cells", "tets"};
  m.factory = [] { return std::make_unique<GenerateBackgroundMesh>(); };
  r.add(std::move(m));
}

} // namespace tetflow
