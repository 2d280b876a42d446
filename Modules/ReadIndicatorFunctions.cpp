// ReadIndicatorFunctions: one scalar volume per material (seed §4.3), e.g. Cleaver's
// spheres1..4.nrrd. Material = argmax of the functions.
#include "Algorithms/IO/VolumeIO.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
class ReadIndicatorFunctions : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const auto& files = ctx.getList("filenames");
    if (files.empty())
      throw InputError("parameter 'filenames' is empty; list one volume file per material, separated by ';'");
    std::vector<int32_t> labels;
    for (const auto& s : ctx.getList("labels")) {
      size_t used = 0;
      long v = 0;
      try {
        v = std::stol(s, &used);
      } catch (...) {
        used = 0;
      }
      if (used != s.size() || v < INT32_MIN || v > INT32_MAX)
        throw InputError("parameter 'labels': '" + s + "' is not an integer label");
      labels.push_back(static_cast<int32_t>(v));
    }
    if (!labels.empty() && labels.size() != files.size())
      throw InputError("parameter 'labels' has " + std::to_string(labels.size()) + " entries for " +
                       std::to_string(files.size()) + " files; give one label per file or none");
    std::vector<ScalarVolume> vols;
    ctx.progress().beginStage("read");
    for (size_t i = 0; i < files.size(); ++i) {
      vols.push_back(readScalarVolume(ctx.resolvePath(files[i])));
      ctx.progress().report(double(i + 1) / double(files.size()));
      ctx.progress().checkCancel();
    }
    ctx.progress().endStage();
    auto mats = std::make_shared<const IndicatorMaterials>(std::move(vols), labels);
    const auto& g = mats->grid();
    ctx.report().set("materials", ReportValue(int64_t(mats->numMaterials())));
    ctx.report().set("dims", std::to_string(g.dims[0]) + " x " + std::to_string(g.dims[1]) + " x " +
                                 std::to_string(g.dims[2]));
    for (int m = 0; m < mats->numMaterials(); ++m)
      ctx.report().set("material_" + std::to_string(mats->labels()[m]) + "_input_mm3",
                       ReportValue(mats->inputVolumes()[m]));
    ctx.setOutput(0, makeData<MaterialsData>(std::shared_ptr<const MaterialSet>(mats)));
  }
};
} // namespace

void registerReadIndicatorFunctions(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "ReadIndicatorFunctions";
  m.category = "DataIO";
  m.description = "Reads one scalar volume per material (indicator functions on a common grid); "
                  "a point belongs to the material whose function is largest there.";
  m.outputs = {{"materials", {PortType::Materials}, "the indicator functions"}};
  ParamSpec f;
  f.name = "filenames";
  f.type = ParamType::List;
  f.defaultValue = std::vector<std::string>{};
  f.description = "volume files separated by ';', one per material; relative names resolve against the network file's folder";
  f.isInputPath = true;
  ParamSpec l;
  l.name = "labels";
  l.type = ParamType::List;
  l.defaultValue = std::vector<std::string>{};
  l.description = "label value of each material, separated by ';' (default 0, 1, 2, ...)";
  m.params = {f, l};
  m.summaryKeys = {"materials", "dims"};
  m.factory = [] { return std::make_unique<ReadIndicatorFunctions>(); };
  r.add(std::move(m));
}

} // namespace tetflow
