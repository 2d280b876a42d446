// The solver parameters shared by AssembleFEMPoisson and ComputeLeadField (StandardModules.h).
#include "Algorithms/FEM/IterativeSolver.h"
#include "StandardModules.h"

namespace tetflow {

std::vector<ParamSpec> solverParamSpecs() {
  const SolverParams d;
  ParamSpec solver = makeParam("solver", ParamType::Enum, std::string("minres"), "",
                               "minres (Paige-Saunders) or cg");
  solver.choices = {"minres", "cg"};
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

} // namespace tetflow
