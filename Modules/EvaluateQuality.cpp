// EvaluateQuality: element quality, validity and per-material volumes of a tetrahedral mesh.
// Inputs: 0 mesh (TetMesh), 1 reference (LabelVolume, optional: reference volume per label =
// voxel count x voxel volume). Outputs: 0 mesh with the quality cell fields added, 1 Report.
#include "Algorithms/Quality/MeshQuality.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
class EvaluateQuality : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const TetMesh& in = ctx.inputAs<TetMeshData>(0).value;
    QualityParams params;
    params.bin_width_deg = ctx.getDouble("bin_width");
    if (ctx.hasInput(1)) {
      const LabelVolume& ref = ctx.inputAs<LabelVolumeData>(1).value;
      const double voxel = ref.grid.voxelVolume();
      for (const auto& [label, count] : labelCounts(ref))
        params.referenceVolumes[label] = double(count) * voxel;
    }
    QualityResult result = evaluateQuality(in, params, ctx.progress());

    Report report;
    writeQualityReport(result, report);
    for (const auto& [key, value] : report.entries()) ctx.report().set(key, value);
    if (!result.valid) ctx.log("the mesh is not valid (see inverted, zero_volume, duplicate_tets, "
                               "nonmanifold_faces)");

    TetMesh out = in;
    for (auto& [name, field] : result.cellFields) out.cellFields[name] = std::move(field);
    ctx.setOutput(0, makeData<TetMeshData>(std::move(out)));
    ctx.setOutput(1, makeData<ReportData>(std::move(report)));
  }
};
} // namespace

void registerEvaluateQuality(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "EvaluateQuality";
  m.category = "Quality";
  m.description =
      "Evaluates a tetrahedral mesh: dihedral angles (min/max, histogram of the per-tet minimum), "
      "aspect ratio (shortest altitude / longest edge) and radius ratio (3 r_in / R_circ), "
      "validity (inverted, zero-volume and duplicate tets, faces shared by more than two tets, "
      "closed boundary), total and per-material volume. With a reference label volume connected, "
      "each material's volume is compared with its voxel count x voxel volume. The output mesh "
      "carries the cell fields min_dihedral, max_dihedral, aspect_ratio, radius_ratio, volume.";
  PortSpec reference{"reference", {PortType::LabelVolume},
                     "optional label volume giving reference volumes per label", true};
  m.inputs = {{"mesh", {PortType::TetMesh}, "mesh to evaluate"}, reference};
  m.outputs = {{"mesh", {PortType::TetMesh}, "the mesh with quality cell fields"},
               {"report", {PortType::Report}, "quality figures (same as the module report)"}};
  ParamSpec bin;
  bin.name = "bin_width";
  bin.type = ParamType::Double;
  bin.defaultValue = 5.0;
  bin.min = kMinBinWidthDeg; // (0, 90], with a floor that bounds the number of bins
  bin.max = 90.0;
  bin.unit = "deg";
  bin.description = "bin width of the histogram of per-tet minimum dihedral angles (0..180 deg)";
  m.params = {bin};
  m.summaryKeys = {"tets", "min_dihedral_deg", "max_dihedral_deg", "valid"};
  m.factory = [] { return std::make_unique<EvaluateQuality>(); };
  r.add(std::move(m));
}

} // namespace tetflow
