// ReadLabelVolume: a segmentation from NRRD, NIfTI, MetaImage, INRIA or VTK image files, with
// spacing and origin kept, and the tissue names of its label table (given, or found beside it).
#include <filesystem>

#include "Algorithms/IO/LabelTable.h"
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
    if (!raw.labelNames.empty()) { // a 3D Slicer segmentation names its segments; a table overrides
      v.labelNames = raw.labelNames;
      ctx.report().set("label_names_from", "file header");
    }
    raw = RawVolume{}; // release the file's copy before reporting
    std::string tablePath;
    if (!ctx.getString("label_table").empty()) tablePath = ctx.getPath("label_table");
    else if (ctx.getBool("find_label_table")) tablePath = labelTableBeside(path);
    if (!tablePath.empty()) {
      LabelTable t = readLabelTable(tablePath);
      v.labelNames = std::move(t.names);
      v.labelConductivities = std::move(t.conductivities);
      ctx.report().set("label_names_from", "label table");
      ctx.report().set("label_table", tablePath);
      ctx.report().set("label_table_format", t.format);
    }
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
                  "origin kept in mm, tissue names from a label table. Formats: " + exts + ".";
  m.outputs = {{"volume", {PortType::LabelVolume}, "the labels"}};
  ParamSpec f;
  f.name = "filename";
  f.type = ParamType::String;
  f.defaultValue = std::string();
  f.description = "volume file; relative names resolve against the network file's folder";
  f.isInputPath = true;
  ParamSpec table = makeParam("label_table", ParamType::String, std::string(), "",
                              "the tissue names (and optionally conductivities) of the labels: an "
                              "ITK-SNAP label description, a FreeSurfer colour table (*LUT.txt, "
                              ".ctbl) or CSV/TSV rows 'label, name[, conductivity S/m]'; empty = "
                              "look beside the volume (find_label_table)");
  table.isInputPath = true;
  ParamSpec find = makeParam("find_label_table", ParamType::Bool, true, "",
                             "with label_table empty, use the table that comes with the volume by "
                             "convention, if there is one: NAME_LUT.txt (SimNIBS charm), NAME.lut, "
                             "NAME.ctbl, NAME.label, NAME.txt, NAME.csv or NAME.tsv beside NAME.EXT");
  m.params = {f, table, find};
  m.summaryKeys = {"dims", "labels"};
  m.factory = [] { return std::make_unique<ReadLabelVolume>(); };
  // The table found beside the volume is read too: which one (or none) and its time belong to the
  // result, so a table added, edited or removed beside a cached volume reads it again.
  m.sideFiles = [](const std::map<std::string, ParamValue>& params, const std::string& baseDir) {
    std::vector<std::string> files;
    auto text = [&](const char* name) {
      auto it = params.find(name);
      const std::string* v = it == params.end() ? nullptr : std::get_if<std::string>(&it->second);
      return v ? *v : std::string();
    };
    auto find = params.find("find_label_table");
    const bool* on = find == params.end() ? nullptr : std::get_if<bool>(&find->second);
    std::filesystem::path volume(text("filename"));
    if (volume.empty() || !text("label_table").empty() || !on || !*on) return files;
    if (volume.is_relative() && !baseDir.empty()) volume = std::filesystem::path(baseDir) / volume;
    const std::string table = labelTableBeside(volume.string());
    files.push_back(table.empty() ? "(no label table beside the volume)" : table);
    return files;
  };
  r.add(std::move(m));
}

} // namespace tetflow
