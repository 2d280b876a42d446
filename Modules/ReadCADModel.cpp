// ReadCADModel: a B-rep CAD model (STEP, IGES, BREP) through OpenCASCADE (Algorithms/CAD).
#include "Algorithms/CAD/CadModel.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
class ReadCADModel : public Module {
public:
  void execute(ExecutionContext& ctx) override {
#ifdef TETFLOW_HAVE_OCCT
    const std::string path = ctx.getPath("filename");
    ctx.progress().beginStage("read");
    auto model = CadModel::read(path);
    ctx.progress().endStage();
    Report& r = ctx.report();
    r.set("file", path);
    r.set("solids", model->solids().size());
    r.set("solids_in_file", model->solidsInFile());
    r.set("patches", model->patches().size());
    r.set("curves", model->curves().size());
    r.set("corners", model->corners().size());
    r.set("euler_characteristic", model->eulerCharacteristic());
    double area = 0;
    for (const auto& p : model->patches()) area += p.area;
    r.set("surface_area_mm2", area);
    for (size_t s = 0; s < model->solids().size(); ++s)
      r.set("solid_" + std::to_string(s + 1) + "_volume_mm3", model->solids()[s].volume);
    const auto b = model->bounds();
    r.set("bounds_mm", formatDouble(b[0][0]) + " " + formatDouble(b[0][1]) + " " + formatDouble(b[0][2]) + " " +
                           formatDouble(b[1][0]) + " " + formatDouble(b[1][1]) + " " + formatDouble(b[1][2]));
    ctx.setOutput(0, makeData<CadModelData>(model));
#else
    (void)ctx;
    throwBuiltWithoutOpenCascade("ReadCADModel");
#endif
  }
};
} // namespace

void registerReadCADModel(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "ReadCADModel";
  m.category = "DataIO";
  m.description = "Reads a B-rep CAD model (STEP .step/.stp, IGES .iges/.igs, OpenCASCADE .brep) through "
                  "OpenCASCADE: its corners, curves, surface patches with their parameterisations, and "
                  "solids. Refuses models without a solid, open or non-manifold solids, and invalid B-reps.";
  m.outputs = {{"model", {PortType::CADModel}, "the CAD model"}};
  ParamSpec f = makeParam("filename", ParamType::String, std::string(), "",
                          "CAD file; relative names resolve against the network file's folder");
  f.isInputPath = true;
  m.params = {f};
  m.summaryKeys = {"solids", "patches", "curves", "euler_characteristic"};
  m.factory = [] { return std::make_unique<ReadCADModel>(); };
  r.add(std::move(m));
}

} // namespace tetflow
