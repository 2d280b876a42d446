// EvaluateQuality: element quality, validity and per-material volumes of a tetrahedral mesh, and,
// with the label volume connected, the mesh certificate (Algorithms/Quality/Certificate.h).
// Inputs: 0 mesh (TetMesh), 1 reference (LabelVolume, optional: reference volume per label =
// voxel count x voxel volume, and the image the certificate compares with). Outputs: 0 mesh with
// the quality cell fields (and certificate_flags) added, 1 Report.
#include "Algorithms/Quality/Certificate.h"
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
    for (const auto& [label, mq] : result.materials)
      if (auto n = in.materialNames.find(label); n != in.materialNames.end())
        report.set("material_" + std::to_string(label) + "_name", n->second);
    if (!result.valid) ctx.log("the mesh is not valid (see inverted, zero_volume, duplicate_tets, "
                               "nonmanifold_faces)");

    TetMesh out = in;
    for (auto& [name, field] : result.cellFields) out.cellFields[name] = std::move(field);

    CertificateThresholds th;
    th.maxVolumeError = ctx.getDouble("max_volume_error") / 100.0;
    th.smallComponentAllowance = ctx.getDouble("small_component_allowance");
    th.requireComponents = ctx.getBool("require_components");
    th.forbidSpuriousContacts = ctx.getBool("forbid_spurious_contacts");
    const bool wantCertificate = ctx.getBool("certificate");
    const bool thresholds = th.maxVolumeError > 0 || th.requireComponents || th.forbidSpuriousContacts;
    std::vector<std::string> failures;
    if (ctx.hasInput(1) && wantCertificate) {
      const LabelVolume& ref = ctx.inputAs<LabelVolumeData>(1).value;
      CertificateResult cert = certifyMesh(in, ref, ctx.progress());
      writeCertificateReport(cert, report);
      failures = certificateFailures(cert, th);
      report.set("cert_passed", ReportValue(failures.empty()));
      Field flags;
      flags.values.assign(cert.flags.begin(), cert.flags.end());
      out.cellFields["certificate_flags"] = std::move(flags);
      for (const auto& is : cert.componentIssues)
        if (is.kind == ComponentIssueKind::LostSmall) {
          ctx.log(std::to_string(cert.lostSmall) + " image component(s) without a core voxel have no "
                  "mesh counterpart (listed as lost_small in the report)");
          break;
        }
    } else if (thresholds) {
      throw InputError(std::string("the certificate thresholds (max_volume_error, require_components, "
                                   "forbid_spurious_contacts) need ") +
                       (wantCertificate ? "the label volume on input port 1 (reference)"
                                        : "parameter certificate = true"));
    }
    // Angle bounds (independent of the certificate): the worst tet against them.
    const double minBound = ctx.getDouble("require_min_dihedral"), maxBound = ctx.getDouble("require_max_dihedral");
    std::vector<std::string> angleFailures;
    // Tets outside a bound: how many, and the worst with its index and centroid.
    auto outside = [&](const char* field, bool below, double bound) {
      const auto it = out.cellFields.find(field);
      if (it == out.cellFields.end()) return std::string();
      int64_t count = 0, worst = -1;
      for (size_t t = 0; t < it->second.values.size(); ++t) {
        const double a = it->second.values[t];
        if (below ? a < bound : a > bound) {
          ++count;
          if (worst < 0 || (below ? a < it->second.values[size_t(worst)] : a > it->second.values[size_t(worst)]))
            worst = int64_t(t);
        }
      }
      if (worst < 0) return std::string();
      const auto& q = in.tets[size_t(worst)];
      Vec3 c{0, 0, 0};
      for (int32_t v : q) c = c + 0.25 * in.points[size_t(v)];
      return ": " + std::to_string(count) + " tet(s), the worst tet " + std::to_string(worst) + " (material " +
             std::to_string(in.materials[size_t(worst)]) + ") at (" + formatDouble(c[0]) + ", " + formatDouble(c[1]) +
             ", " + formatDouble(c[2]) + ") mm";
    };
    if (minBound > 0 && result.minDihedral < minBound)
      angleFailures.push_back("smallest dihedral angle " + formatDouble(result.minDihedral) + " deg < require_min_dihedral " +
                              formatDouble(minBound) + " deg" + outside("min_dihedral", true, minBound) +
                              " (CleaveMesh improve / ImproveMesh raise it)");
    if (maxBound < 180 && result.maxDihedral > maxBound)
      angleFailures.push_back("largest dihedral angle " + formatDouble(result.maxDihedral) + " deg > require_max_dihedral " +
                              formatDouble(maxBound) + " deg" + outside("max_dihedral", false, maxBound) +
                              " (CleaveMesh improve / ImproveMesh lower it)");
    for (const auto& [key, value] : report.entries()) ctx.report().set(key, value);
    std::string msg;
    if (!failures.empty()) {
      msg = "the mesh fails its certificate: ";
      for (size_t i = 0; i < failures.size(); ++i) msg += (i ? "; " : "") + failures[i];
    }
    if (!angleFailures.empty()) {
      msg += std::string(msg.empty() ? "" : "; ") + "the mesh fails its angle bounds: ";
      for (size_t i = 0; i < angleFailures.size(); ++i) msg += (i ? "; " : "") + angleFailures[i];
    }
    const bool passOn = ctx.getString("gate") == "pass_on";
    if (!msg.empty() && !passOn) throw ProcessingError(msg);
    ctx.setOutput(0, makeData<TetMeshData>(std::move(out)));
    ctx.setOutput(1, makeData<ReportData>(std::move(report)));
    // The mesh goes on (with its certificate_flags) to be written and looked at; the module and the
    // run still fail.
    if (!msg.empty()) throw GateFailure(msg + " (the mesh is passed on: gate = pass_on)");
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
      "each material's volume is compared with its voxel count x voxel volume, and the mesh "
      "certificate compares the mesh with the image label by label: volume error, connected "
      "components (lost, split, merged, spurious), label contacts (spurious, missing) and "
      "non-manifold interfaces; thresholds make the module fail. The output mesh carries the cell "
      "fields min_dihedral, max_dihedral, aspect_ratio, radius_ratio, volume and, with the "
      "certificate, certificate_flags (bits: 1 spurious, 2 split piece, 4 merging, 8 in a lost "
      "component, 16 spurious contact, 32 non-manifold interface).";
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
  ParamSpec gate = makeParam("gate", ParamType::Enum, std::string("pass_on"), "",
                             "when a threshold fails: pass_on = the mesh (with its certificate_flags) still "
                             "goes downstream to be written and shown, the module and the run fail; stop = "
                             "nothing downstream runs");
  gate.choices = {"pass_on", "stop"};
  m.params = {
      bin,
      makeParam("certificate", ParamType::Bool, true, "",
                "compare the mesh with the label volume on port 1 (reference): volumes, components, "
                "contacts, interfaces"),
      doubleParam("max_volume_error", 0.0, 0.0, 1000.0, "%",
                  "fail when a label's |volume error| against its voxels exceeds this (0 = no check) "
                  "and its small-component allowance"),
      doubleParam("small_component_allowance", 1.0, 0.0, 1000.0, "h^3",
                  "volume a label may miss by, whatever max_volume_error, for each of its components "
                  "smaller than an element: this x h^3, h the mean longest edge of the tets over the "
                  "component (0 = percentages only)"),
      makeParam("require_components", ParamType::Bool, false, "",
                "fail when a robust image component is lost, split or merged, or a spurious mesh "
                "component exists"),
      makeParam("forbid_spurious_contacts", ParamType::Bool, false, "",
                "fail when two labels touch in the mesh but not in the image"),
      doubleParam("require_min_dihedral", 0.0, 0.0, 90.0, "deg",
                  "fail when any tet's smallest dihedral angle is below this (0 = no check)"),
      doubleParam("require_max_dihedral", 180.0, 60.0, 180.0, "deg",
                  "fail when any tet's largest dihedral angle is above this (180 = no check)"),
      gate};
  m.summaryKeys = {"tets", "min_dihedral_deg", "max_dihedral_deg", "valid", "cert_passed"};
  m.factory = [] { return std::make_unique<EvaluateQuality>(); };
  r.add(std::move(m));
}

} // namespace tetflow
