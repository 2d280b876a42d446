// The solver parameters shared by AssembleFEMPoisson and ComputeLeadField (StandardModules.h).
#include "Algorithms/FEM/IterativeSolver.h"
#include "Algorithms/Core/Errors.h"
#include "Algorithms/IO/ElectrodeIO.h"
#include "StandardModules.h"

namespace tetflow {

std::vector<ParamSpec> solverParamSpecs(const std::string& defaultSolver) {
  const SolverParams d;
  ParamSpec solver = makeParam("solver", ParamType::Enum, defaultSolver, "",
                               "minres (Paige-Saunders), cg, cholesky (sparse Cholesky factorisation, "
                               "CHOLMOD: factorised once, then two triangular solves per right-hand side; "
                               "solver_backend eigen), or auto (whichever is predicted fastest for the solves at hand "
                               "within the memory available: cholesky, minres with this preconditioner, or "
                               "cg + hypre on PETSc in this process when the build has PETSc; the log says "
                               "which and why)");
  solver.choices = {"minres", "cg", "cholesky", "auto"};
  ParamSpec prec = makeParam("preconditioner", ParamType::Enum, std::string("jacobi"), "",
                             "jacobi (M = diag(K)), none, or with solver_backend petsc: gamg "
                             "(PETSc's algebraic multigrid) or hypre (BoomerAMG)");
  prec.choices = {"jacobi", "none", "gamg", "hypre"};
  ParamSpec tol = makeParam("tolerance", ParamType::Double, d.tolerance, "",
                            "stop when ||r||_{M^-1} <= tolerance * ||b||_{M^-1}");
  tol.min = 1e-16; // below double precision a relative residual is not reachable
  tol.max = 0.999;
  ParamSpec maxit = makeParam("max_iterations", ParamType::Int, int64_t(d.max_iterations), "",
                              "iteration limit (not converging is reported, not an error)");
  maxit.min = 1;
  ParamSpec backend = makeParam("solver_backend", ParamType::Enum, std::string("eigen"), "",
                                "eigen (this process, both cores) or petsc (PETSc KSP on every MPI "
                                "rank: mpirun -n N tetflow run NET.srn)");
  backend.choices = {"eigen", "petsc"};
  ParamSpec popts = makeParam("petsc_options", ParamType::String, std::string(""), "",
                              "solver_backend petsc: PETSc options applied after TetFlow's, e.g. "
                              "-ksp_view or -pc_gamg_threshold 0.02");
  return {solver, prec, tol, maxit, backend, popts};
}

SolverParams solverParamsFrom(const ExecutionContext& ctx) {
  SolverParams p;
  p.kind = solverKindFromName(ctx.getString("solver"));
  p.preconditioner = preconditionerKindFromName(ctx.getString("preconditioner"));
  p.tolerance = ctx.getDouble("tolerance");
  p.max_iterations = ctx.getInt("max_iterations");
  p.backend = solverBackendFromName(ctx.getString("solver_backend"));
  p.petsc_options = ctx.getString("petsc_options");
  return p;
}

ParamSpec sourceModelParamSpec(bool withSubtraction) {
  std::string help = "dipole: partial_integration (load m . grad phi on the dipole's tet, or two monopoles with "
                     "dipole_separation > 0) or venant (St. Venant: monopoles on the nearest vertex and its "
                     "neighbours matching the moments to second order)";
  if (withSubtraction)
    help += " or subtraction (the singular potential of the dipole in the unbounded brain conductivity, in "
            "closed form, plus a smooth correction solved by FEM)";
  ParamSpec model = makeParam("source_model", ParamType::Enum, std::string("partial_integration"), "", help);
  model.choices = {"partial_integration", "venant"};
  if (withSubtraction) model.choices.push_back("subtraction");
  return model;
}

SourceModel sourceModelFrom(const ExecutionContext& ctx) { return sourceModelFromName(ctx.getString("source_model")); }

std::vector<ParamSpec> leadFieldParamSpecs() {
  ParamSpec sl = makeParam("source_labels", ParamType::List, std::vector<std::string>{}, "",
                           "sources at the centroids of every tet of these labels (e.g. 4 for the brain)");
  ParamSpec sf = makeParam("sources_file", ParamType::String, std::string(), "",
                           "or sources at these points: a .csv/.txt of x, y, z in mm (name optional)");
  sf.isInputPath = true;
  ParamSpec out = makeParam("filename", ParamType::String, std::string(), "",
                            "output .npy or .csv (empty = port only); relative names resolve against "
                            "the output folder");
  out.isOutputPath = true;
  return {sl, sf, out};
}

void leadFieldSourcesFrom(const ExecutionContext& ctx, std::vector<int32_t>& labels, std::vector<Vec3>& points) {
  labels = parseLabels(ctx.getList("source_labels"), "source_labels");
  points.clear();
  if (!ctx.getString("sources_file").empty())
    for (const Electrode& e : readElectrodes(ctx.getPath("sources_file"), 0.0)) points.push_back(e.position);
}

std::vector<ParamSpec> megSensorParamSpecs() {
  ParamSpec sf = makeParam("sensors_file", ParamType::String, std::string(), "",
                           "MEG sensors: one coil per line, 'name x y z nx ny nz [weight]' (mm); lines "
                           "with the same name are one sensor's coils (Algorithms/FEM/Meg.h)");
  sf.isInputPath = true;
  ParamSpec unit = makeParam("sensor_unit_scale", ParamType::Double, 0.0, "",
                             "multiplies the sensor positions to get mm (10 for cm, 1000 for m); 0 = mm");
  unit.min = 0.0;
  return {sf, unit};
}

std::vector<MegSensor> megSensorsFrom(const ExecutionContext& ctx) {
  if (ctx.getString("sensors_file").empty())
    throw InputError("sensors_file: give the MEG sensors (lines 'name x y z nx ny nz [weight]' in mm)");
  return readMegSensors(ctx.getPath("sensors_file"), ctx.getDouble("sensor_unit_scale"));
}

} // namespace tetflow
