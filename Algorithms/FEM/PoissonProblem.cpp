#include "PoissonProblem.h"
#include "SourceModels.h"
#include "Subtraction.h"

#include "MaterialCurrents.h"

#include <cstdio>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <random>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Timing.h"
#include "Algorithms/Core/MemoryBudget.h"

namespace tetflow {

namespace {

std::string labelList(const std::vector<int32_t>& labels) {
  std::string s;
  for (int32_t l : labels) {
    if (!s.empty()) s += ' ';
    s += std::to_string(l);
  }
  return s;
}

// Checks that every label named by a per-label parameter occurs in the mesh.
void requireLabels(const std::vector<int32_t>& present, const std::vector<int32_t>& named, const char* what) {
  for (int32_t l : named)
    if (!std::binary_search(present.begin(), present.end(), l)) {
      std::string msg = what;
      msg += ": label ";
      msg += std::to_string(l);
      msg += " does not occur in the mesh (labels present: ";
      msg += labelList(present);
      msg += ")";
      throw InputError(msg);
    }
}

const char* kAxisNames[] = {"x", "y", "z"};

} // namespace

void computeFluxFields(const TetMesh& mesh, const ConductivityTable& sigma, const Eigen::VectorXd& u,
                       std::vector<double>& gradMagnitude, std::vector<double>& currentDensity) {
  const int64_t nt = static_cast<int64_t>(mesh.numTets());
  gradMagnitude.assign(size_t(nt), 0.0);
  currentDensity.assign(size_t(nt), 0.0);
  std::map<int32_t, Mat3> tensors;
  for (int32_t l : mesh.materials)
    if (!tensors.count(l)) tensors[l] = tensorMatrix(sigma.tensor(l));
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < nt; ++t) {
    const TetGradients g = tetGradients(mesh, size_t(t));
    const auto& q = mesh.tets[size_t(t)];
    Vec3 grad{0, 0, 0};
    for (int a = 0; a < 4; ++a) grad = grad + u[q[a]] * g.grad[size_t(a)];
    gradMagnitude[size_t(t)] = norm(grad);
    currentDensity[size_t(t)] = norm(mul(tensors.at(mesh.materials[size_t(t)]), grad));
  }
}

PoissonResult solvePoisson(const TetMesh& mesh, const PoissonParams& params, Progress& progress) {
  PoissonResult res;
  res.boundary = params.boundary;
  res.solver = params.solver;
  mesh.validateStructure("mesh");
  if (mesh.numTets() == 0) throw InputError("mesh: no tets; the FEM problem needs a tetrahedral mesh");
  // Peak memory above the input mesh: 60 bytes per tet measured (head phantom, 0.47 M tets: the
  // stiffness matrix, solver vectors, the output fields and the mesh copy they go on); 100 assumed.
  {
    constexpr double kBytesPerTet = 100.0;
    const double tets = double(mesh.numTets());
    requireMemory(kBytesPerTet * tets, "the FEM problem on " + std::to_string(mesh.numTets()) + " tets",
                  [&](double avail) {
                    const double fits = std::floor(avail / kBytesPerTet);
                    std::ostringstream f;
                    f << "use a mesh of at most " << fits << " tets (a cell_size about "
                      << roundUpForAdvice(std::cbrt(tets / std::max(fits, 1.0)) * 1.02) << " times the present one)";
                    return f.str();
                  });
  }
  params.solver.validate();
  params.conductivities.validate();
  res.vertices = int64_t(mesh.numPoints());
  res.tets = int64_t(mesh.numTets());
  res.labels.assign(mesh.materials.begin(), mesh.materials.end());
  std::sort(res.labels.begin(), res.labels.end());
  res.labels.erase(std::unique(res.labels.begin(), res.labels.end()), res.labels.end());
  {
    std::vector<int32_t> named;
    for (const auto& [l, s] : params.conductivities.byLabel) named.push_back(l);
    requireLabels(res.labels, named, "conductivities");
  }
  const size_t np = mesh.numPoints();

  // --- assemble -------------------------------------------------------------------------
  auto t0 = std::chrono::steady_clock::now();
  progress.beginStage("assemble");
  const SparseMatrix K = assembleStiffness(mesh, params.conductivities, progress);
  Eigen::VectorXd f = Eigen::VectorXd::Zero(Eigen::Index(np));
  if (params.boundary == BoundaryCondition::Boundary) f = assembleLoad(mesh, params.source);
  std::optional<SubtractionSources> subtraction;
  if (params.boundary == BoundaryCondition::Dipole && params.sourceModel != SourceModel::PartialIntegration) {
    if (params.dipole_separation != 0.0)
      throw InputError(std::string("source_model ") + sourceModelName(params.sourceModel) +
                       " models the dipole itself, not two monopoles: dipole_separation must be 0");
    if (params.sourceModel == SourceModel::Venant) {
      VenantSources(mesh).add(params.dipole_position, params.dipole_moment, f);
    } else {
      subtraction.emplace(mesh, params.conductivities);
      subtraction->addLoad(params.dipole_position, params.dipole_moment, f);
    }
    res.dipoleTets = {*locatePoint(mesh, params.dipole_position)}; // add() checked it is inside
  } else if (params.boundary == BoundaryCondition::Dipole) {
    res.dipoleTets = addDipole(mesh, params.dipole_position, params.dipole_moment,
                               params.dipole_separation, f);
  }
  progress.endStage();
  res.assembleSeconds = secondsSince(t0);

  // --- boundary conditions --------------------------------------------------------------
  t0 = std::chrono::steady_clock::now();
  progress.beginStage("boundary conditions");
  const std::vector<uint8_t> onBoundary = boundaryVertexFlags(mesh);
  for (uint8_t b : onBoundary) res.boundaryVertices += b;
  DirichletSet dir(np);
  std::vector<uint8_t> used(np, 0);
  for (const auto& t : mesh.tets)
    for (int32_t v : t) used[size_t(v)] = 1;
  // Electrode groups for the reaction currents: (name, vertices).
  struct Group {
    std::string name;
    double potential;
    std::vector<int32_t> vertices;
    int32_t label = -1;
  };
  std::vector<Group> electrodes;
  switch (params.boundary) {
  case BoundaryCondition::Boundary:
    for (size_t v = 0; v < np; ++v)
      if (onBoundary[v]) dir.set(v, 0.0);
    break;
  case BoundaryCondition::Electrodes: {
    if (params.injected_current != 0.0)
      throw InputError("injected_current: use boundary_condition material_electrodes (two electrode materials)");
    const int ax = params.electrode_axis;
    if (ax < 0 || ax > 2)
      throw InputError("electrode_axis = " + std::to_string(ax) + ": use 0 (x), 1 (y) or 2 (z)");
    if (!(params.electrode_fraction > 0 && params.electrode_fraction < 0.5)) {
      std::ostringstream m;
      m << "electrode fraction " << params.electrode_fraction << ": must be in (0, 0.5)";
      throw InputError(m.str());
    }
    double lo = INFINITY, hi = -INFINITY;
    for (size_t v = 0; v < np; ++v)
      if (used[v]) {
        lo = std::min(lo, mesh.points[v][size_t(ax)]);
        hi = std::max(hi, mesh.points[v][size_t(ax)]);
      }
    const double extent = hi - lo;
    if (!(extent > 0)) {
      std::string msg = "electrodes: the mesh has no extent along ";
      msg += kAxisNames[ax];
      throw InputError(msg);
    }
    const double band = params.electrode_fraction * extent;
    std::vector<int32_t> minSide, maxSide;
    for (size_t v = 0; v < np; ++v) {
      if (!onBoundary[v]) continue;
      const double c = mesh.points[v][size_t(ax)];
      if (c <= lo + band) {
        dir.set(v, params.electrode_potential_min);
        minSide.push_back(int32_t(v));
      } else if (c >= hi - band) {
        dir.set(v, params.electrode_potential_max);
        maxSide.push_back(int32_t(v));
      }
    }
    electrodes.push_back({"min", params.electrode_potential_min, std::move(minSide)});
    electrodes.push_back({"max", params.electrode_potential_max, std::move(maxSide)});
    break;
  }
  case BoundaryCondition::MaterialElectrodes: {
    if (params.injected_current != 0.0) {
      if (!std::isfinite(params.injected_current))
        throw InputError("injected_current: must be a finite number of mA");
      bool distinct = params.electrode_potentials.size() == 2 &&
                      params.electrode_potentials.begin()->second != params.electrode_potentials.rbegin()->second;
      if (!distinct)
        throw InputError("injected_current: give exactly two electrode materials at different potentials in "
                         "electrode_potentials (e.g. 5:1; 6:0); the current flows from the first to the second");
    }
    if (params.electrode_potentials.empty())
      throw InputError("electrode_potentials: give at least one 'label:volts' entry (e.g. 5:1; 6:0) "
                       "for boundary_condition material_electrodes");
    std::vector<int32_t> named;
    for (const auto& [l, u] : params.electrode_potentials) named.push_back(l);
    requireLabels(res.labels, named, "electrode_potentials");
    std::vector<int32_t> owner(np, INT32_MIN); // label that fixed the vertex
    std::map<int32_t, std::vector<int32_t>> groups;
    for (size_t t = 0; t < mesh.numTets(); ++t) {
      auto it = params.electrode_potentials.find(mesh.materials[t]);
      if (it == params.electrode_potentials.end()) continue;
      for (int32_t v : mesh.tets[t]) {
        int32_t& o = owner[size_t(v)];
        if (o == INT32_MIN) {
          o = it->first;
          dir.set(size_t(v), it->second);
          groups[it->first].push_back(v);
        } else if (o != it->first && params.electrode_potentials.at(o) != it->second) {
          std::ostringstream m;
          m << "electrode_potentials: electrode materials " << o << " and " << it->first
            << " touch at vertex " << v << " but are held at different potentials ("
            << params.electrode_potentials.at(o) << " V and " << it->second
            << " V); separate them by another material";
          throw InputError(m.str());
        }
      }
    }
    for (auto& [l, vs] : groups)
      electrodes.push_back({"label_" + std::to_string(l), params.electrode_potentials.at(l), std::move(vs), l});
    break;
  }
  case BoundaryCondition::Dipole:
    break;
  }
  // Exclude unused vertices (value 0), then give every component without a Dirichlet vertex a
  // reference vertex.
  for (size_t v = 0; v < np; ++v)
    if (!used[v]) {
      dir.set(v, 0.0);
      ++res.unusedVertices;
    }
  int32_t ncomp = 0;
  const std::vector<int32_t> comp = vertexComponents(mesh, ncomp);
  res.components = ncomp;
  int32_t dipoleReference = -1; // the reference vertex of the dipole's piece
  {
    std::vector<uint8_t> anchored(size_t(ncomp), 0);
    for (size_t v = 0; v < np; ++v)
      if (used[v] && dir.fixed[v]) anchored[size_t(comp[v])] = 1;
    if (params.boundary == BoundaryCondition::Dipole && res.dipoleTets.size() == 2) {
      const int32_t c0 = comp[size_t(mesh.tets[size_t(res.dipoleTets[0].tet)][0])];
      const int32_t c1 = comp[size_t(mesh.tets[size_t(res.dipoleTets[1].tet)][0])];
      if (c0 != c1)
        throw InputError("dipole: the two poles lie in different connected pieces of the mesh; "
                         "use a smaller dipole_separation");
    }
    std::vector<int32_t> ref(size_t(ncomp), -1);
    std::vector<double> refDist(size_t(ncomp), -1.0);
    const bool dipole = params.boundary == BoundaryCondition::Dipole;
    for (size_t v = 0; v < np; ++v) {
      if (!used[v]) continue;
      const int32_t c = comp[v];
      if (anchored[size_t(c)]) continue;
      if (ref[size_t(c)] < 0) ref[size_t(c)] = int32_t(v); // fallback: lowest index
      if (!onBoundary[v]) continue;
      const double d = dipole ? norm(mesh.points[v] - params.dipole_position) : 0.0;
      if (refDist[size_t(c)] < 0 || d > refDist[size_t(c)]) { // strict: lowest index on ties
        refDist[size_t(c)] = d;
        ref[size_t(c)] = int32_t(v);
      }
    }
    for (int32_t c = 0; c < ncomp; ++c) {
      if (anchored[size_t(c)]) continue;
      const int32_t v = ref[size_t(c)];
      dir.set(size_t(v), 0.0);
      res.referenceVertices.push_back(v);
      if (!dipole) {
        std::ostringstream m;
        m << "mesh piece " << c << " has no Dirichlet vertex; vertex " << v
          << " is held at 0 V as its reference";
        res.notes.push_back(m.str());
      }
    }
    if (dipole) dipoleReference = ref[size_t(comp[size_t(mesh.tets[size_t(res.dipoleTets[0].tet)][0])])];
    if (dipole && ncomp > 1) {
      std::ostringstream m;
      m << "the mesh has " << ncomp << " separate pieces; each has its own 0 V reference vertex";
      res.notes.push_back(m.str());
    }
  }
  res.dirichletVertices = int64_t(dir.count()) - res.unusedVertices;
  ReducedSystem sys = eliminateDirichlet(K, f, dir);
  res.dofs = sys.K.rows();
  res.nnz = sys.K.nonZeros();
  progress.endStage();
  res.boundarySeconds = secondsSince(t0);

  // --- solve ----------------------------------------------------------------------------
  t0 = std::chrono::steady_clock::now();
  progress.beginStage("solve");
  IterativeSolver solver(params.solver);
  solver.setOperator(sys.K);
  solver.setProgress(&progress);
  Eigen::VectorXd x;
  if (res.dofs > 0) solver.solve(sys.b, x);
  if (!solver.choiceNote().empty()) res.notes.push_back(solver.choiceNote());
  if (solver.factorReused())
    res.notes.push_back("cholesky: the factor was kept from an earlier solve of this system (no factorisation)");
  res.solverUsed = solverKindName(solver.params().kind);
  res.status = res.dofs > 0 ? solver.status() : SolverStatus::Converged;
  res.converged = res.status == SolverStatus::Converged;
  res.iterations = solver.iterations();
  res.relativeResidual = solver.relativeResidual();
  res.trueResidual = solver.trueResidual();
  res.residualHistory = solver.residualHistory();
  res.ranks = solver.ranks();
  if (!res.converged) {
    std::ostringstream m;
    m << solverKindName(solver.params().kind) << " did not converge ("
      << solverStatusName(res.status) << " after " << res.iterations
      << " iterations, relative residual " << res.relativeResidual << " > tolerance "
      << params.solver.tolerance << ")";
    res.notes.push_back(m.str());
  }
  progress.endStage();
  res.solveSeconds = secondsSince(t0);

  // --- condition ------------------------------------------------------------------------
  t0 = std::chrono::steady_clock::now();
  progress.beginStage("condition");
  const bool jacobi = params.solver.preconditioner == PreconditionerKind::Jacobi;
  const bool petsc = params.solver.backend == SolverBackend::Petsc;
  const bool direct = solver.direct();
  if (petsc && std::isfinite(solver.kspEigenMin())) { // PETSc's CG: its own Lanczos estimate
    res.lanczos.lambdaMin = solver.kspEigenMin();
    res.lanczos.lambdaMax = solver.kspEigenMax();
    res.lanczos.kappa = res.lanczos.lambdaMax / res.lanczos.lambdaMin;
    res.lanczos.converged = true;
    res.lanczos.operations = res.iterations;
    res.lanczos.method = std::string("PETSc CG's Lanczos estimate (KSPComputeExtremeSingularValues) on M^-1 K, M = ") +
                         preconditionerKindName(params.solver.preconditioner);
  } else if (petsc) { // PETSc's MINRES keeps no Lanczos tridiagonal: the estimates below come from Eigen CG runs
    res.lanczos.method = "not available with solver_backend petsc and solver minres (cg gives PETSc's estimate)";
  } else if (direct) { // likewise a direct solve
    res.lanczos.method = "not available with solver = cholesky";
  } else {
    std::string what = solver.params().kind == SolverKind::Minres ? "MINRES" : "CG";
    what += jacobi ? " on M^-1 K, M = diag(K)" : " on K";
    res.lanczos = lanczosEstimate(solver.lanczos(), what);
  }
  if (!params.condition_numbers) {
    for (auto* est : {&res.kappa, &res.kappaJacobi}) est->method = "skipped (condition_numbers = false)";
  } else if (res.dofs > 0) {
    // A Lanczos run (CG, fixed-seed random right-hand side) with the other preconditioner.
    auto otherLanczos = [&](bool otherJacobi) {
      SolverParams p = params.solver;
      p.kind = SolverKind::Cg;
      p.backend = SolverBackend::Eigen;
      p.preconditioner = otherJacobi ? PreconditionerKind::Jacobi : PreconditionerKind::None;
      IterativeSolver s(p);
      s.setOperator(sys.K);
      s.setProgress(&progress);
      std::mt19937_64 rng(12345);
      std::uniform_real_distribution<double> uni(-1.0, 1.0);
      Eigen::VectorXd rhs(res.dofs), y;
      for (Eigen::Index i = 0; i < rhs.size(); ++i) rhs[i] = uni(rng);
      s.solve(rhs, y);
      return lanczosEstimate(s.lanczos(), otherJacobi ? "CG on M^-1 K, M = diag(K), random right-hand side"
                                                      : "CG on K, random right-hand side");
    };
    auto lanczosFor = [&](bool wantJacobi) {
      return wantJacobi == jacobi && !petsc && !direct ? res.lanczos : otherLanczos(wantJacobi);
    };
    const bool tooBig = params.condition.max_dofs > 0 && res.dofs > params.condition.max_dofs;
    if (params.estimate_condition && !tooBig) {
      const ConditionPair c = spectraConditionNumbers(sys.K, params.condition, &progress);
      res.kappa = c.matrix;
      res.kappaJacobi = c.jacobi;
      for (auto* est : {&res.kappa, &res.kappaJacobi})
        if (!est->converged) {
          const bool isJacobi = est == &res.kappaJacobi;
          SpectrumEstimate fallback = lanczosFor(isJacobi);
          fallback.method = est->method + "; using instead the " + fallback.method;
          res.notes.push_back("eigen solve did not converge: " + fallback.method);
          *est = fallback;
        }
    } else {
      res.kappa = lanczosFor(false);
      res.kappaJacobi = lanczosFor(true);
      if (params.estimate_condition) { // skipped for size: say so
        std::ostringstream why;
        why << "eigen solves skipped (" << res.dofs << " dofs > max_eigen_dofs "
            << params.condition.max_dofs << "); ";
        res.kappa.method = why.str() + res.kappa.method;
        res.kappaJacobi.method = why.str() + res.kappaJacobi.method;
        res.notes.push_back(why.str() + "condition numbers are Lanczos estimates");
      }
    }
  }
  progress.endStage();
  res.conditionSeconds = secondsSince(t0);

  // --- fields ---------------------------------------------------------------------------
  t0 = std::chrono::steady_clock::now();
  progress.beginStage("fields");
  Eigen::VectorXd u = res.dofs > 0 ? sys.expand(x) : sys.expand(Eigen::VectorXd());
  if (!electrodes.empty()) {
    // Reaction r = K u - f at the fixed vertices = current injected there (mA).
    Eigen::VectorXd ku;
    multiplySymmetric(K, u, ku);
    for (const auto& g : electrodes) {
      double I = 0.0;
      for (int32_t v : g.vertices) I += ku[v] - f[v];
      res.electrodes.push_back({g.name, g.potential, I, g.label});
    }
  }
  if (subtraction && dipoleReference >= 0) {
    // u = u_inf + w on the dipole's piece, still 0 V at its reference vertex.
    const std::vector<double> uInf = subtraction->singularPotential(params.dipole_position, params.dipole_moment);
    const int32_t dc = comp[size_t(dipoleReference)];
    const double shift = uInf[size_t(dipoleReference)];
    res.singularPotential.assign(np, 0.0);
    for (size_t v = 0; v < np; ++v)
      if (used[v] && comp[v] == dc) {
        res.singularPotential[v] = uInf[v] - shift;
        u[Eigen::Index(v)] += uInf[v] - shift;
      }
  }
  if (params.injected_current != 0.0) {
    // f = 0: the solution is linear in the electrode potentials, so scaling it by I / I_0 gives
    // the electrodes' potentials for the injected current (perfectly conducting electrodes).
    const auto& first = res.electrodes[0].potential > res.electrodes[1].potential ? res.electrodes[0] : res.electrodes[1];
    if (!(std::abs(first.current) > 0))
      throw InputError("injected_current: no current flows between the two electrode materials (they are not "
                       "connected through the mesh)");
    res.injectedCurrent = params.injected_current;
    res.injectionScale = params.injected_current / first.current;
    u *= res.injectionScale;
    for (auto& e : res.electrodes) e.potential *= res.injectionScale, e.current *= res.injectionScale;
  }
  res.potential.assign(u.data(), u.data() + u.size());
  res.potentialMin = INFINITY;
  res.potentialMax = -INFINITY;
  for (size_t v = 0; v < np; ++v)
    if (used[v]) {
      res.potentialMin = std::min(res.potentialMin, u[Eigen::Index(v)]);
      res.potentialMax = std::max(res.potentialMax, u[Eigen::Index(v)]);
    }
  computeFluxFields(mesh, params.conductivities, u, res.gradMagnitude, res.currentDensity);
  if (!electrodes.empty()) {
    res.materialCurrents = materialCurrents(mesh, params.conductivities, u, progress);
    if (params.boundary == BoundaryCondition::MaterialElectrodes) // electrode materials: the exact reaction
      for (const auto& e : res.electrodes) res.materialCurrents[e.label] = std::abs(e.current);
  }
  {
    // Swapped, not moved: Eigen 3.4's SparseMatrix has no move constructor (std::move copies).
    auto matrix = std::make_shared<SparseMatrix>();
    matrix->swap(sys.K);
    res.matrix = std::move(matrix);
  }
  progress.endStage();
  res.fieldsSeconds = secondsSince(t0);
  return res;
}

void addPoissonFields(const PoissonResult& r, TetMesh& mesh) {
  mesh.pointFields["potential"] = Field{1, r.potential};
  if (!r.singularPotential.empty()) mesh.pointFields["singular_potential"] = Field{1, r.singularPotential};
  mesh.cellFields["grad_magnitude"] = Field{1, r.gradMagnitude};
  mesh.cellFields["current_density"] = Field{1, r.currentDensity};
}

void writePoissonReport(const PoissonResult& r, Report& rep) {
  auto i64 = [](int64_t v) { return ReportValue(v); };
  rep.set("vertices", i64(r.vertices));
  rep.set("tets", i64(r.tets));
  rep.set("materials", labelList(r.labels));
  rep.set("boundary_condition", boundaryConditionName(r.boundary));
  rep.set("boundary_vertices", i64(r.boundaryVertices));
  rep.set("dirichlet_vertices", i64(r.dirichletVertices));
  rep.set("reference_vertices", i64(int64_t(r.referenceVertices.size())));
  rep.set("unused_vertices", i64(r.unusedVertices));
  rep.set("dofs", i64(r.dofs));
  rep.set("nnz", i64(r.nnz));
  rep.set("solver", r.solverUsed.empty() ? std::string(solverKindName(r.solver.kind)) : r.solverUsed);
  if (r.solver.kind == SolverKind::Auto) rep.set("solver_requested", std::string("auto"));
  rep.set("preconditioner", preconditionerKindName(r.solver.preconditioner));
  rep.set("solver_backend", solverBackendName(r.solver.backend));
  rep.set("ranks", i64(r.ranks));
  rep.set("tolerance", ReportValue(r.solver.tolerance));
  rep.set("max_iterations", i64(r.solver.max_iterations));
  rep.set("iterations", i64(r.iterations));
  rep.set("relative_residual", ReportValue(r.relativeResidual));
  rep.set("true_residual", ReportValue(r.trueResidual));
  rep.set("converged", ReportValue(r.converged));
  rep.set("solver_status", solverStatusName(r.status));
  {
    // Relative residual per iteration (the GUI plots it on a log scale).
    std::string hist;
    char buf[32];
    for (double x : r.residualHistory) {
      std::snprintf(buf, sizeof buf, "%.4g", x);
      if (!hist.empty()) hist += ' ';
      hist += buf;
    }
    rep.set("residual_history", hist);
  }
  rep.set("kappa", ReportValue(r.kappa.kappa));
  rep.set("kappa_method", r.kappa.method);
  rep.set("lambda_min", ReportValue(r.kappa.lambdaMin));
  rep.set("lambda_max", ReportValue(r.kappa.lambdaMax));
  rep.set("kappa_jacobi", ReportValue(r.kappaJacobi.kappa));
  rep.set("kappa_jacobi_method", r.kappaJacobi.method);
  rep.set("lambda_min_jacobi", ReportValue(r.kappaJacobi.lambdaMin));
  rep.set("lambda_max_jacobi", ReportValue(r.kappaJacobi.lambdaMax));
  rep.set("kappa_lanczos", ReportValue(r.lanczos.kappa));
  rep.set("kappa_lanczos_method", r.lanczos.method);
  rep.set("potential_min", ReportValue(r.potentialMin));
  rep.set("potential_max", ReportValue(r.potentialMax));
  for (const auto& e : r.electrodes) {
    std::string key = "electrode_";
    key += e.name;
    key += "_current";
    rep.set(key, ReportValue(e.current));
  }
  if (r.boundary == BoundaryCondition::Electrodes && r.electrodes.size() == 2) {
    const double I = r.electrodes[0].current;
    const double dU = r.electrodes[0].potential - r.electrodes[1].potential;
    rep.set("resistance", ReportValue(I != 0.0 ? dU / I : INFINITY));
  }
  if (r.injectedCurrent != 0.0) { // the electrodes' potentials for that current
    for (const auto& e : r.electrodes) rep.set("electrode_" + e.name + "_potential", ReportValue(e.potential));
    rep.set("injection_scale", ReportValue(r.injectionScale));
  }
  for (const auto& [label, I] : r.materialCurrents) {
    std::string key = "material_";
    key += std::to_string(label);
    key += "_current";
    rep.set(key, ReportValue(I));
  }
  if (r.boundary == BoundaryCondition::Dipole) {
    std::string tets;
    for (const auto& loc : r.dipoleTets) {
      if (!tets.empty()) tets += ' ';
      tets += std::to_string(loc.tet);
    }
    rep.set("dipole_tet", tets);
    rep.set("reference_vertex", i64(r.referenceVertices.empty() ? -1 : r.referenceVertices.front()));
  }
  rep.set("assemble_seconds", ReportValue(r.assembleSeconds));
  rep.set("boundary_seconds", ReportValue(r.boundarySeconds));
  rep.set("solve_seconds", ReportValue(r.solveSeconds));
  rep.set("condition_seconds", ReportValue(r.conditionSeconds));
  rep.set("fields_seconds", ReportValue(r.fieldsSeconds));
}

} // namespace tetflow
