#include "StandardModules.h"

#include <sstream>

#include "Algorithms/Core/Errors.h"

namespace tetflow {

void registerStandardModules(ModuleRegistry& r) {
  registerCreatePhantom(r);
  registerReadLabelVolume(r);
  registerWriteVolume(r);
  registerReadMesh(r);
  registerWriteMesh(r);
  registerExtractSurfaces(r);
  registerEvaluateQuality(r);
  registerReadIndicatorFunctions(r);
  registerComputeSizingField(r);
  registerGenerateBackgroundMesh(r);
  registerCleaveMesh(r);
  registerImproveMesh(r);
  registerAssembleFEMPoisson(r);
  registerComputeLeadField(r);
  registerAnalyticSphereEEG(r);
  registerComputeMEG(r);
  registerComputeMegLeadField(r);
  registerReadCADModel(r);
  registerMeshCADSurface(r);
}

std::optional<int32_t> labelOrNoneParam(ExecutionContext& ctx, const std::string& name, const std::string& hint) {
  const std::string text = ctx.getString(name);
  if (text == "none" || text.empty()) return std::nullopt;
  size_t used = 0;
  long v = 0;
  try {
    v = std::stol(text, &used);
  } catch (...) {
    used = 0;
  }
  if (used != text.size()) throw InputError("parameter '" + name + "' = '" + text + "': use 'none' or " + hint);
  return static_cast<int32_t>(v);
}

std::shared_ptr<const MaterialSet> materialsFromInput(const DataPtr& data, double blendSigma) {
  if (data->type() == PortType::Materials)
    return static_cast<const MaterialsData&>(*data).value;
  const auto& lv = dynamic_cast<const LabelVolumeData&>(*data);
  // Share the volume with the data object that owns it (no copy).
  std::shared_ptr<const LabelVolume> vol(data, &lv.value);
  return std::make_shared<const LabelMaterials>(vol, blendSigma);
}

void carryLabelNames(const DataPtr& labels, TetMesh& mesh) {
  if (!labels || labels->type() != PortType::LabelVolume) return;
  const LabelVolume& v = static_cast<const LabelVolumeData&>(*labels).value;
  mesh.materialNames.clear();
  mesh.materialConductivities.clear();
  for (int32_t L : presentMaterials(mesh)) {
    if (auto it = v.labelNames.find(L); it != v.labelNames.end()) mesh.materialNames[L] = it->second;
    if (auto it = v.labelConductivities.find(L); it != v.labelConductivities.end()) mesh.materialConductivities[L] = it->second;
  }
}

void reportLabelVolume(Report& report, const LabelVolume& v) {
  const auto& g = v.grid;
  auto triple = [](double a, double b, double c) {
    std::ostringstream s;
    s << a << " x " << b << " x " << c;
    return s.str();
  };
  report.set("dims", std::to_string(g.dims[0]) + " x " + std::to_string(g.dims[1]) + " x " +
                         std::to_string(g.dims[2]));
  report.set("voxels", ReportValue(int64_t(g.voxelCount())));
  report.set("spacing_mm", triple(g.spacing[0], g.spacing[1], g.spacing[2]));
  std::ostringstream o;
  o << g.origin[0] << " " << g.origin[1] << " " << g.origin[2];
  report.set("origin_mm", o.str());
  report.set("axis_aligned", ReportValue(g.isAxisAligned()));
  const auto counts = labelCounts(v);
  report.set("labels", ReportValue(int64_t(counts.size())));
  std::string list;
  for (const auto& [label, n] : counts) {
    if (!list.empty()) list += ' ';
    list += std::to_string(label);
  }
  report.set("label_values", list);
  if (!v.labelNames.empty()) {
    std::string names;
    for (const auto& [label, n] : counts)
      if (auto it = v.labelNames.find(label); it != v.labelNames.end())
        names += (names.empty() ? "" : "; ") + std::to_string(label) + " " + it->second;
    report.set("label_names", names);
  }
  for (const auto& [label, n] : counts) {
    const std::string key = "label_" + std::to_string(label);
    report.set(key + "_voxels", ReportValue(int64_t(n)));
    report.set(key + "_volume_mm3", ReportValue(double(n) * g.voxelVolume()));
  }
}

void throwBuiltWithoutOpenCascade(const std::string& module) {
  throw InputError(module + ": this TetFlow was built without OpenCASCADE (-DTETFLOW_WITH_OCCT=OFF); install "
                   "libocct-data-exchange-dev (scripts/setup.sh does) and build again");
}

} // namespace tetflow
