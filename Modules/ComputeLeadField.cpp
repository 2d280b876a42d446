// ComputeLeadField: the EEG lead field by reciprocity (Algorithms/FEM/LeadField.h).
// Inputs: 0 mesh (TetMesh). Outputs: 0 lead field (DenseMatrix, electrodes x 3 sources, V per
// mA mm), 1 report. Electrodes come from a file (.csv/.tsv/.txt, .elc, .sfp; Algorithms/IO/
// ElectrodeIO.h), sources from labels (tet centroids) or a point file; the matrix is written to
// `filename` (.npy or .csv) with the .electrodes.csv / .sources.csv sidecars, when one is given.
#include <algorithm>
#include <sstream>

#include "Algorithms/FEM/LeadField.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
class ComputeLeadField : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const TetMesh& mesh = ctx.inputAs<TetMeshData>(0).value;
    LeadFieldParams p;
    p.conductivities = conductivitiesFrom(ctx, mesh, ctx.report());
    if (ctx.getString("electrodes_file").empty())
      throw InputError("electrodes_file: give the electrode positions (.csv/.tsv/.txt name,x,y,z in mm, .elc or .sfp)");
    p.electrodes = readElectrodes(ctx.getPath("electrodes_file"), ctx.getDouble("electrode_unit_scale"));
    p.reference = ctx.getString("reference");
    leadFieldSourcesFrom(ctx, p.sourceLabels, p.sourcePoints);
    p.solver = solverParamsFrom(ctx);
    p.sourceModel = sourceModelFrom(ctx);

    LeadFieldResult r = computeLeadField(mesh, p, ctx.progress());
    Report& rep = ctx.report();
    const auto i64 = [](auto v) { return ReportValue(int64_t(v)); };
    rep.set("electrodes", i64(r.names.size()));
    rep.set("sources", i64(r.sources.size()));
    rep.set("reference", r.reference);
    rep.set("ground_electrode", r.names[size_t(r.ground)]);
    double maxSnap = 0, meanSnap = 0;
    size_t worst = 0;
    for (size_t e = 0; e < r.snapDistance.size(); ++e) {
      meanSnap += r.snapDistance[e] / double(r.snapDistance.size());
      if (r.snapDistance[e] > maxSnap) maxSnap = r.snapDistance[e], worst = e;
    }
    rep.set("snap_distance_max", ReportValue(maxSnap));
    rep.set("snap_distance_mean", ReportValue(meanSnap));
    rep.set("snap_worst_electrode", r.names[worst]);
    rep.set("dofs", i64(r.dofs));
    rep.set("nnz", i64(r.nnz));
    rep.set("source_model", sourceModelName(p.sourceModel));
    rep.set("solver", r.solverUsed);
    if (p.solver.kind == SolverKind::Auto) rep.set("solver_requested", std::string("auto"));
    rep.set("preconditioner", preconditionerKindName(p.solver.preconditioner));
    rep.set("solver_backend", solverBackendName(p.solver.backend));
    rep.set("ranks", i64(r.ranks));
    rep.set("tolerance", ReportValue(p.solver.tolerance));
    rep.set("solves", i64(r.solves));
    rep.set("iterations_total", i64(r.iterationsTotal));
    rep.set("iterations_max", i64(r.iterationsMax));
    rep.set("converged", ReportValue(r.converged));
    rep.set("assemble_seconds", ReportValue(r.assembleSeconds));
    rep.set("setup_seconds", ReportValue(r.setupSeconds));
    rep.set("solve_seconds", ReportValue(r.solveSeconds));
    rep.set("matrix_seconds", ReportValue(r.matrixSeconds));
    {
      std::ostringstream m;
      m << r.names.size() << " electrodes snapped to the scalp surface: mean " << meanSnap << " mm, largest "
        << maxSnap << " mm (" << r.names[worst] << ")";
      ctx.log(m.str());
    }
    for (const auto& note : r.notes) ctx.log(note);
    if (!ctx.getString("filename").empty()) {
      const std::string path = ctx.getPath("filename");
      ctx.progress().beginStage("write");
      writeLeadField(r, mesh, path);
      ctx.progress().endStage();
      rep.set("file", path);
    }
    ctx.setOutput(0, makeData<DenseMatrixData>(std::make_shared<const Eigen::MatrixXd>(std::move(r.matrix))));
    ctx.setOutput(1, makeData<ReportData>(Report(rep)));
  }
};
} // namespace

void registerComputeLeadField(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "ComputeLeadField";
  m.category = "FEM";
  m.description =
      "EEG lead field by reciprocity: electrodes (from a file) are snapped to the nearest scalp "
      "surface vertex; one FEM solve per electrode (1 mA in at it, out at the ground electrode) on "
      "one stiffness matrix gives the potential at every electrode of a unit dipole along x, y, z "
      "at every source (the centroids of the tets of source_labels, or the points of "
      "sources_file), the same numbers as direct dipole solves with AssembleFEMPoisson. Rows are "
      "average-referenced or referenced to a named electrode. Output: the matrix (electrodes x 3 "
      "sources, V per mA mm), written to filename as .npy (shape electrodes x sources x 3) or "
      ".csv, with .electrodes.csv and .sources.csv beside it.";
  m.inputs = {{"mesh", {PortType::TetMesh}, "tetrahedral head mesh with material labels (mm)"}};
  m.outputs = {{"lead field", {PortType::DenseMatrix}, "electrodes x (3 sources): column 3 s + k = unit dipole along axis k at source s (V per mA mm)"},
               {"report", {PortType::Report}, "lead field figures (same as the module report)"}};
  const std::vector<ParamSpec> cp = conductivityParamSpecs();
  const ParamSpec &cond = cp[0], &def = cp[1];
  ParamSpec ef = makeParam("electrodes_file", ParamType::String, std::string(), "",
                           "electrode positions: .csv/.tsv/.txt (name, x, y, z in mm), .elc or .sfp; "
                           "relative names resolve against the network file's folder");
  ef.isInputPath = true;
  ParamSpec unit = makeParam("electrode_unit_scale", ParamType::Double, 0.0, "",
                             "multiplies the electrode coordinates to get mm (10 for cm); 0 = the "
                             "file's unit (.elc UnitPosition, otherwise mm)");
  unit.min = 0.0;
  ParamSpec ref = makeParam("reference", ParamType::String, std::string("average"), "",
                            "average (subtract the mean over the electrodes) or an electrode name");
  const std::vector<ParamSpec> lf = leadFieldParamSpecs(); // source_labels, sources_file, filename
  const std::vector<ParamSpec> sp = solverParamSpecs("auto");
  m.params = {cond, def, ef, unit, ref, lf[0], lf[1], sp[0], sp[1], sp[2], sp[3], sp[4], sp[5], lf[2], cp[2], sourceModelParamSpec(true)};
  m.summaryKeys = {"electrodes", "sources", "solves", "iterations_max", "snap_distance_max", "converged"};
  m.factory = [] { return std::make_unique<ComputeLeadField>(); };
  r.add(std::move(m));
}

} // namespace tetflow
