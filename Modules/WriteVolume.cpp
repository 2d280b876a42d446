// WriteVolume: a label or scalar volume to any supported volume format (by extension).
#include <filesystem>

#include "Algorithms/IO/VolumeIO.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
class WriteVolume : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const std::string path = ctx.getPath("filename");
    const DataPtr& in = ctx.input(0);
    ctx.progress().beginStage("write");
    if (in->type() == PortType::LabelVolume)
      writeVolume(path, fromLabelVolume(ctx.inputAs<LabelVolumeData>(0).value));
    else
      writeVolume(path, fromScalarVolume(ctx.inputAs<ScalarVolumeData>(0).value));
    ctx.progress().endStage();
    ctx.report().set("file", path);
    std::error_code ec;
    ctx.report().set("bytes", ReportValue(int64_t(std::filesystem::file_size(path, ec))));
  }
};
} // namespace

void registerWriteVolume(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "WriteVolume";
  m.category = "DataIO";
  std::string exts;
  for (const auto& e : volumeExtensions()) exts += (exts.empty() ? "" : " ") + e;
  m.description = "Writes a label or scalar volume; the format follows the extension (" + exts +
                  "). Written atomically: a failed write leaves no partial file.";
  m.inputs = {{"volume", {PortType::LabelVolume, PortType::ScalarVolume}, "volume to write"}};
  ParamSpec f;
  f.name = "filename";
  f.type = ParamType::String;
  f.defaultValue = std::string();
  f.description = "output file; relative names resolve against the network file's folder";
  f.isOutputPath = true;
  m.params = {f};
  m.summaryKeys = {"file", "bytes"};
  m.factory = [] { return std::make_unique<WriteVolume>(); };
  r.add(std::move(m));
}

} // namespace tetflow
