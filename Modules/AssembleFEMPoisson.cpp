// AssembleFEMPoisson: P1 FEM for -div(sigma grad u) = f on a tet mesh (DESIGN §3, §6):
// assembly, boundary conditions, MINRES/CG solve, conditioning (Algorithms/FEM/PoissonProblem.h).
// Inputs: 0 mesh (TetMesh). Outputs: 0 mesh with point field "potential" and cell fields
// "grad_magnitude", "current_density"; 1 matrix (the reduced stiffness matrix K); 2 report.
#include "Algorithms/FEM/PoissonProblem.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
class AssembleFEMPoisson : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const TetMesh& in = ctx.inputAs<TetMeshData>(0).value;
    PoissonParams p;
    Report conductivityReport;
    p.conductivities = conductivitiesFrom(ctx, in, conductivityReport);
    p.boundary = boundaryConditionFromName(ctx.getString("boundary_condition"));
    const std::string axis = ctx.getString("electrode_axis");
    p.electrode_axis = axis == "x" ? 0 : axis == "y" ? 1 : 2;
    if (p.boundary == BoundaryCondition::MaterialElectrodes)
      p.electrode_potentials = parseLabelValues(ctx.getList("electrode_potentials"), "electrode_potentials");
    if (p.boundary == BoundaryCondition::Dipole) {
      p.dipole_position = parseVec3(ctx.getString("dipole_position"), "dipole_position");
      p.dipole_moment = parseVec3(ctx.getString("dipole_moment"), "dipole_moment");
      p.dipole_separation = ctx.getDouble("dipole_separation");
      p.sourceModel = sourceModelFrom(ctx);
    }
    p.solver = solverParamsFrom(ctx);
    p.estimate_condition = ctx.getBool("estimate_condition");
    p.condition.max_dofs = ctx.getInt("max_eigen_dofs");
    p.condition_numbers = ctx.getBool("condition_numbers");
    p.injected_current = ctx.getDouble("injected_current");

    PoissonResult r = solvePoisson(in, p, ctx.progress());
    Report report;
    writePoissonReport(r, report);
    for (const auto& [key, value] : conductivityReport.entries()) report.set(key, value);
    for (const auto& [key, value] : report.entries()) ctx.report().set(key, value);
    for (const auto& note : r.notes) ctx.log(note);

    TetMesh out = in;
    addPoissonFields(r, out);
    ctx.setOutput(0, makeData<TetMeshData>(std::move(out)));
    ctx.setOutput(1, makeData<MatrixData>(std::shared_ptr<const Eigen::SparseMatrix<double>>(r.matrix)));
    ctx.setOutput(2, makeData<ReportData>(std::move(report)));
  }
};

} // namespace

void registerAssembleFEMPoisson(ModuleRegistry& r) {
  const PoissonParams d;
  ModuleInfo m;
  m.name = "AssembleFEMPoisson";
  m.category = "FEM";
  m.description =
      "Assembles and solves the P1 finite-element problem -div(sigma grad u) = f on a tet mesh "
      "(sigma per material label in S/m, coordinates in mm, u in V, currents in mA). Boundary "
      "conditions: boundary (u = 0 on the boundary, f = 1), electrodes (u = 1 V / 0 V on the "
      "boundary within 5 % of the extent at the two ends of an axis, insulated elsewhere), "
      "material_electrodes (chosen materials held at given potentials), dipole (EEG forward "
      "problem: a current dipole, reference vertex at 0 V). Dirichlet values are eliminated "
      "symmetrically; the reduced SPD system is solved by Jacobi-preconditioned MINRES (or CG) "
      "and its condition number reported (Spectra eigen solves, or a Lanczos estimate from the "
      "solver). Outputs the mesh with the point field potential and the cell fields "
      "grad_magnitude (V/mm) and current_density (mA/mm^2), the reduced stiffness matrix, and a "
      "report.";
  m.inputs = {{"mesh", {PortType::TetMesh}, "tetrahedral mesh with material labels (mm)"}};
  m.outputs = {{"mesh", {PortType::TetMesh}, "the mesh with potential, grad_magnitude, current_density"},
               {"matrix", {PortType::Matrix}, "reduced stiffness matrix K over the free vertices (mS)"},
               {"report", {PortType::Report}, "FEM figures (same as the module report)"}};

  const std::vector<ParamSpec> cp = conductivityParamSpecs();
  const ParamSpec &cond = cp[0], &def = cp[1];
  ParamSpec bc = makeParam("boundary_condition", ParamType::Enum, std::string("boundary"), "",
                           "boundary, electrodes, material_electrodes or dipole (DESIGN §6)");
  bc.choices = {"boundary", "electrodes", "material_electrodes", "dipole"};
  ParamSpec axis = makeParam("electrode_axis", ParamType::Enum, std::string("x"), "",
                             "electrodes: axis whose min / max ends carry 1 V / 0 V");
  axis.choices = {"x", "y", "z"};
  ParamSpec pots = makeParam("electrode_potentials", ParamType::List, std::vector<std::string>{}, "V",
                             "material_electrodes: label:volts entries separated by ';' (e.g. 5:1; 6:0)");
  ParamSpec dpos = makeParam("dipole_position", ParamType::String, std::string("0 0 0"), "mm",
                             "dipole: position \"x y z\"");
  ParamSpec dmom = makeParam("dipole_moment", ParamType::String, std::string("0 0 1"), "mA mm",
                             "dipole: moment \"x y z\" (current x separation)");
  ParamSpec dsep = makeParam("dipole_separation", ParamType::Double, d.dipole_separation, "mm",
                             "dipole: distance of the +I/-I monopoles; 0 = the limit (partial "
                             "integration: load m . grad phi in the tet containing the dipole)");
  dsep.min = 0.0;
  ParamSpec est = makeParam("estimate_condition", ParamType::Bool, true, "",
                            "compute kappa(K) and kappa(D^-1/2 K D^-1/2) with Spectra eigen solves "
                            "(sparse Cholesky; for large meshes set false: Lanczos estimates)");
  ParamSpec maxDofs = makeParam("max_eigen_dofs", ParamType::Int, int64_t(d.condition.max_dofs), "",
                                "estimate_condition: above this many unknowns use the Lanczos "
                                "estimates instead of the eigen solves (0 = no limit)");
  maxDofs.min = 0;
  ParamSpec condNumbers = makeParam("condition_numbers", ParamType::Bool, true, "",
                                    "false: skip the condition stage (no kappa; on large meshes it "
                                    "costs one or two extra CG runs)");
  ParamSpec inj = makeParam("injected_current", ParamType::Double, 0.0, "mA",
                            "material_electrodes with two labels (tDCS): the current driven from the "
                            "higher-potential electrode to the other; the potentials are scaled to "
                            "it (0 = the potentials as given)");
  const std::vector<ParamSpec> sp = solverParamSpecs();
  m.params = {cond, def, bc, axis, pots, dpos, dmom, dsep, sp[0], sp[1], sp[2], sp[3], est, maxDofs, sp[4], sp[5], condNumbers, inj, cp[2], sourceModelParamSpec(true)};
  m.summaryKeys = {"dofs", "nnz", "kappa", "iterations", "relative_residual", "converged"};
  m.factory = [] { return std::make_unique<AssembleFEMPoisson>(); };
  r.add(std::move(m));
}

} // namespace tetflow
