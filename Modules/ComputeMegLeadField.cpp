// ComputeMegLeadField: the MEG lead field by a transfer matrix (Algorithms/FEM/Meg.h): one FEM
// solve per sensor with the adjoint load of its volume-current functional, plus the primary field.
// Inputs: 0 mesh (TetMesh). Outputs: 0 lead field (DenseMatrix, sensors x 3 sources, fT per
// mA mm), 1 report. Sensors from a file, sources from labels (tet centroids) or a point file; the
// matrix is written to `filename` (.npy or .csv) with .sensors.csv / .sources.csv beside it.
#include <sstream>

#include "Algorithms/FEM/Meg.h"
#include "Algorithms/IO/ElectrodeIO.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
class ComputeMegLeadField : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const TetMesh& mesh = ctx.inputAs<TetMeshData>(0).value;
    MegLeadFieldParams p;
    p.conductivities = conductivitiesFrom(ctx, mesh, ctx.report());
    p.sensors = megSensorsFrom(ctx);
    leadFieldSourcesFrom(ctx, p.sourceLabels, p.sourcePoints);
    p.solver = solverParamsFrom(ctx);
    p.sourceModel = sourceModelFrom(ctx);

    MegLeadFieldResult r = computeMegLeadField(mesh, p, ctx.progress());
    Report& rep = ctx.report();
    const auto i64 = [](auto v) { return ReportValue(int64_t(v)); };
    int64_t coils = 0;
    for (const MegSensor& s : p.sensors) coils += int64_t(s.coils.size());
    rep.set("sensors", i64(r.names.size()));
    rep.set("coils", i64(coils));
    rep.set("sources", i64(r.sources.size()));
    rep.set("coils_inside_mesh", i64(r.coilsInsideMesh));
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
    rep.set("kernel_seconds", ReportValue(r.kernelSeconds));
    rep.set("solve_seconds", ReportValue(r.solveSeconds));
    rep.set("matrix_seconds", ReportValue(r.matrixSeconds));
    for (const auto& note : r.notes) ctx.log(note);
    if (!ctx.getString("filename").empty()) {
      const std::string path = ctx.getPath("filename");
      ctx.progress().beginStage("write");
      writeMegLeadField(r, p.sensors, path);
      ctx.progress().endStage();
      rep.set("file", path);
    }
    ctx.setOutput(0, makeData<DenseMatrixData>(std::make_shared<const Eigen::MatrixXd>(std::move(r.matrix))));
    ctx.setOutput(1, makeData<ReportData>(Report(rep)));
  }
};
} // namespace

void registerComputeMegLeadField(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "ComputeMegLeadField";
  m.category = "FEM";
  m.description =
      "MEG lead field by a transfer matrix: for every sensor (read from a file: magnetometers, or "
      "gradiometers as coils with weights) one FEM solve with the adjoint load of its "
      "volume-current field (Biot-Savart over the tets, exact per tet) gives the field of a unit "
      "dipole along x, y, z at every source (the centroids of the tets of source_labels, or the "
      "points of sources_file), the same numbers as a direct dipole solve with AssembleFEMPoisson "
      "followed by ComputeMEG; the primary field is added. Output: the matrix (sensors x 3 "
      "sources, fT per mA mm), written to filename as .npy (shape sensors x sources x 3) or .csv, "
      "with .sensors.csv and .sources.csv beside it.";
  m.inputs = {{"mesh", {PortType::TetMesh}, "tetrahedral head mesh with material labels (mm)"}};
  m.outputs = {{"lead field", {PortType::DenseMatrix}, "sensors x (3 sources): column 3 s + k = unit dipole along axis k at source s (fT per mA mm)"},
               {"report", {PortType::Report}, "lead field figures (same as the module report)"}};
  const std::vector<ParamSpec> cp = conductivityParamSpecs();
  const std::vector<ParamSpec> ms = megSensorParamSpecs(); // sensors_file, sensor_unit_scale
  const std::vector<ParamSpec> lf = leadFieldParamSpecs();  // source_labels, sources_file, filename
  const std::vector<ParamSpec> sp = solverParamSpecs("auto");
  m.params = {cp[0], cp[1], ms[0], ms[1], lf[0], lf[1], sp[0], sp[1], sp[2], sp[3], sp[4], sp[5], lf[2], cp[2], sourceModelParamSpec(false)};
  m.summaryKeys = {"sensors", "sources", "solves", "iterations_max", "converged"};
  m.factory = [] { return std::make_unique<ComputeMegLeadField>(); };
  r.add(std::move(m));
}

} // namespace tetflow
