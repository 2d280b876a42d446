// ReadLabelVolume: a segmentation from NRRD, NIfTI, MetaImage, INRIA or VTK image files, with
// spacing and origin kept.
#include "Algorithms/IO/VolumeIO.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
class ReadLabelVolume : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const std::string path = ctx.getPath("filename");
    ctx.progress().beginStage("read");
    RawVolume raw = readVolume(path);
    ctx.progress().endStage();
    LabelVolume v = toLabelVolume(raw, path);
    raw = RawVolume{}; // release the file's copy before reporting
    ctx.report().set("file", path);
    reportLabelVolume(ctx.report(), v);
    ctx.setOutput(0, makeData<LabelVolumeData>(std::move(v)));
  }
};
} // namespace

void registerReadLabelVolume(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "ReadLabelVolume";
  m.category = "DataIO";
  std::string exts;
  for (const auto& e : volumeExtensions()) exts += (exts.empty() ? "" : " ") + e;
  m.description = "Reads a labelled (segmented) volume: any integer label values, spacing and "
                  "origin kept in mm. Formats: " + exts + ".";
  m.outputs = {{"volume", {PortType::LabelVolume}, "the labels"}};
  ParamSpec f;
  f.name = "filename";
  f.type = ParamType::String;
  f.defaultValue = std::string();
  f.description = "volume file; relative names resolve against the network file's folder";
  f.isInputPath = true;
  m.params = {f};
  m.summaryKeys = {"dims", "labels"};
  m.factory = [] { return std::make_unique<ReadLabelVolume>(); };
  r.add(std::move(m));
}

} // namespace tetflow
