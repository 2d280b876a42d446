// EEG lead field benchmark (issue "the simulation at the speed of the mesh"): one solver on one
// head mesh, as ComputeLeadField runs it (computeLeadField, LeadField.h).
//
//   leadfield_benchmark MESH --solver minres|cg|cholesky|auto [--preconditioner jacobi|none|gamg|hypre]
//                       [--backend eigen|petsc] [--electrodes 128] [--sources 5000]
//                       [--scalp 1] [--grey 4] [--check K] [--tolerance 1e-8]
//   leadfield_benchmark MESH --choose K      what solver = auto picks for K right-hand sides on
//                                            the lead field's system (no solve)
//   leadfield_benchmark MESH --meg N ...     the MEG lead field instead (computeMegLeadField, Meg.h)
//                                            of N radial magnetometers on a helmet (the upper
//                                            part of a sphere 10 mm outside the whole mesh),
//                                            the same sources
//
// Electrodes: boundary vertices of `--scalp` tets in the upper 60 % of the
// head, spread by farthest-point sampling from the top vertex; the first is the reference (its
// rows are V_e - V_E0, so any subset of electrodes gives the same rows). Sources: the centroids of
// `--sources` grey-matter tets (`--grey`) drawn at random (fixed seed). Conductivities 0.43 /
// 0.01 / 1.79 / 0.33 / 0.14 S/m for labels 1-5 (scalp, skull, CSF, grey, white), others 0.43.
// Prints one line of key=value figures: unknowns, solves, seconds per stage (sources, assemble,
// snap, factorize, solve, lead field), per solve, iterations, and with --check K the largest
// relative difference of each lead-field column (restricted to electrodes 1..K) against MINRES +
// Jacobi at tolerance --check-tolerance (1e-12). With --solver auto the line names the solver it
// chose and why. Testing/Benchmarks/leadfield_benchmark.sh runs it per solver under /usr/bin/time
// (peak memory) and writes results/leadfield.txt; solver_scaling.sh runs it on a family of meshes.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <random>
#include <string>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/FEM/Assembly.h"
#include "Algorithms/FEM/BoundaryConditions.h"
#include "Algorithms/FEM/LeadField.h"
#include "Algorithms/FEM/Meg.h"
#include "Algorithms/FEM/SolverChoice.h"
#include "Algorithms/FEM/SparseCholesky.h"
#include "Algorithms/IO/MeshIO.h"

using namespace tetflow;

namespace {

struct Options {
  std::string mesh, solver = "minres", preconditioner = "jacobi", backend = "eigen";
  int electrodes = 128, sources = 5000, scalp = 1, grey = 4, check = 0, choose = 0, meg = 0;
  double tolerance = 1e-8, checkTolerance = 1e-12;
};

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw InputError(a + " needs a value");
      return argv[++i];
    };
    if (a == "--solver") o.solver = next();
    else if (a == "--preconditioner") o.preconditioner = next();
    else if (a == "--backend") o.backend = next();
    else if (a == "--electrodes") o.electrodes = std::stoi(next());
    else if (a == "--sources") o.sources = std::stoi(next());
    else if (a == "--scalp") o.scalp = std::stoi(next());
    else if (a == "--grey") o.grey = std::stoi(next());
    else if (a == "--check") o.check = std::stoi(next());
    else if (a == "--choose") o.choose = std::stoi(next());
    else if (a == "--meg") o.meg = std::stoi(next());
    else if (a == "--tolerance") o.tolerance = std::stod(next());
    else if (a == "--check-tolerance") o.checkTolerance = std::stod(next());
    else if (o.mesh.empty() && a[0] != '-') o.mesh = a;
    else throw InputError("unknown argument " + a);
  }
  if (o.mesh.empty()) throw InputError("usage: leadfield_benchmark MESH --solver minres|cg|cholesky [...]");
  return o;
}

std::vector<Electrode> scalpElectrodes(const TetMesh& m, int scalp, int count) {
  const std::vector<uint8_t> boundary = boundaryVertexFlags(m);
  std::vector<uint8_t> onScalp(m.numPoints(), 0);
  for (size_t t = 0; t < m.numTets(); ++t)
    if (m.materials[t] == scalp)
      for (int32_t v : m.tets[t]) onScalp[size_t(v)] = 1;
  double zlo = 1e300, zhi = -1e300;
  for (const Vec3& p : m.points) zlo = std::min(zlo, p[2]), zhi = std::max(zhi, p[2]);
  std::vector<int32_t> verts;
  for (size_t v = 0; v < m.numPoints(); ++v)
    if (boundary[v] && onScalp[v] && m.points[v][2] >= zlo + 0.4 * (zhi - zlo)) verts.push_back(int32_t(v));
  const std::vector<int32_t>& cand = verts;
  if (cand.empty()) throw InputError("no scalp surface vertices (label " + std::to_string(scalp) + ")");
  size_t first = 0;
  for (size_t i = 1; i < cand.size(); ++i)
    if (m.points[size_t(cand[i])][2] > m.points[size_t(cand[first])][2]) first = i;
  std::vector<double> dist(cand.size(), 1e300);
  std::vector<Electrode> out;
  size_t pick = first;
  for (int e = 0; e < count && e < int(cand.size()); ++e) {
    out.push_back({std::string("E").append(std::to_string(e)), m.points[size_t(cand[pick])], e + 1});
    const Vec3 p = m.points[size_t(cand[pick])];
    size_t far = 0;
    for (size_t i = 0; i < cand.size(); ++i) {
      dist[i] = std::min(dist[i], norm(m.points[size_t(cand[i])] - p));
      if (dist[i] > dist[far]) far = i;
    }
    pick = far;
  }
  return out;
}

std::vector<Vec3> greySources(const TetMesh& m, int grey, int count) {
  std::vector<int64_t> tets;
  for (size_t t = 0; t < m.numTets(); ++t)
    if (m.materials[t] == grey) tets.push_back(int64_t(t));
  if (tets.empty()) throw InputError("no grey-matter tets (label " + std::to_string(grey) + ")");
  std::mt19937_64 rng(1);
  std::vector<Vec3> out;
  for (int s = 0; s < count && s < int(tets.size()); ++s) {
    std::uniform_int_distribution<size_t> pick(size_t(s), tets.size() - 1);
    std::swap(tets[size_t(s)], tets[pick(rng)]);
    const auto& q = m.tets[size_t(tets[size_t(s)])];
    Vec3 c{0, 0, 0};
    for (int a = 0; a < 4; ++a) c = c + 0.25 * m.points[size_t(q[a])];
    out.push_back(c);
  }
  return out;
}

// Prints " NAME_s=SECONDS" for every stage the progress recorded; returns their sum.
double printStages(const NullProgress& np) {
  double stages = 0;
  for (const auto& st : np.stageTimes()) {
    std::string key = st.name;
    std::replace(key.begin(), key.end(), ' ', '_');
    std::printf(" %s_s=%.2f", key.c_str(), st.seconds);
    stages += st.seconds;
  }
  return stages;
}

// The MEG lead field of o.meg radial magnetometers (see the header), printed as one line.
int runMeg(const TetMesh& mesh, const LeadFieldParams& eeg, const Options& o, double readSeconds) {
  // A helmet: o.meg points spread over the upper part of a sphere around the mesh (Fibonacci
  // spiral), 10 mm outside its farthest point, each a magnetometer along the radius.
  Vec3 centre{0, 0, 0};
  for (const Vec3& q : mesh.points) centre = centre + (1.0 / double(mesh.numPoints())) * q;
  double radius = 0;
  for (const Vec3& q : mesh.points) radius = std::max(radius, norm(q - centre));
  radius += 10.0;
  MegLeadFieldParams p;
  p.conductivities = eeg.conductivities;
  p.sourcePoints = eeg.sourcePoints;
  p.solver = eeg.solver;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < o.meg; ++i) {
    const double z = 1.0 - 1.2 * (double(i) + 0.5) / double(o.meg); // cos(polar angle) from 1 to -0.2
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const Vec3 d{r * std::cos(golden * i), r * std::sin(golden * i), z};
    MegCoil c;
    c.position = centre + radius * d;
    c.normal = d;
    p.sensors.push_back({std::string("M").append(std::to_string(i)), {c}});
  }
  NullProgress np;
  const auto t0 = std::chrono::steady_clock::now();
  const MegLeadFieldResult r = computeMegLeadField(mesh, p, np);
  np.endStage();
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("meg=%zu solver=%s preconditioner=%s backend=%s tets=%zu dofs=%lld nnz=%lld sources=%zu "
              "coils_inside_mesh=%lld read_s=%.2f total_s=%.2f",
              r.names.size(), o.solver.c_str(), o.preconditioner.c_str(), o.backend.c_str(), mesh.numTets(),
              (long long)r.dofs, (long long)r.nnz, r.sources.size(), (long long)r.coilsInsideMesh, readSeconds, total);
  const double stages = printStages(np);
  std::printf(" stages_sum_s=%.2f solves=%lld ran=%s per_solve_s=%.3f iterations_max=%lld converged=%d", stages,
              (long long)r.solves, r.solverUsed.c_str(), r.solves ? r.solveSeconds / double(r.solves) : 0.0,
              (long long)r.iterationsMax, r.converged ? 1 : 0);
  for (const auto& n : r.notes)
    if (n.rfind("cholesky: ", 0) == 0 || n.rfind("auto: ", 0) == 0) std::printf(" note=\"%s\"", n.c_str());
  std::printf("\n");
  return r.converged ? 0 : 1;
}

} // namespace

int main(int argc, char** argv) {
  try {
    const Options o = parse(argc, argv);
    auto t0 = std::chrono::steady_clock::now();
    const TetMesh mesh = readMesh(o.mesh);
    const double readSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    LeadFieldParams p;
    p.conductivities = parseConductivities({"1:0.43", "2:0.01", "3:1.79", "4:0.33", "5:0.14"}, 0.43);
    p.electrodes = scalpElectrodes(mesh, o.scalp, o.electrodes);
    p.reference = p.electrodes[0].name;
    p.sourcePoints = greySources(mesh, o.grey, o.sources);
    p.solver.kind = solverKindFromName(o.solver);
    p.solver.preconditioner = preconditionerKindFromName(o.preconditioner);
    p.solver.backend = solverBackendFromName(o.backend);
    p.solver.tolerance = o.tolerance;
    NullProgress np;
    if (o.choose > 0) {
      // The lead field's reduced system: the first electrode's vertex (and unused vertices) at 0 V.
      const SparseMatrix K = assembleStiffness(mesh, p.conductivities, np);
      DirichletSet dir(mesh.numPoints());
      dir.set(size_t(snapToBoundary(mesh, {p.electrodes[0].position})[0].vertex), 0.0);
      std::vector<uint8_t> used(mesh.numPoints(), 0);
      for (const auto& t : mesh.tets)
        for (int32_t v : t) used[size_t(v)] = 1;
      for (size_t v = 0; v < used.size(); ++v)
        if (!used[v]) dir.set(v, 0.0);
      const ReducedSystem sys = eliminateDirichlet(K, Eigen::VectorXd::Zero(Eigen::Index(mesh.numPoints())), dir);
      SolverParams sp = p.solver;
      sp.kind = SolverKind::Auto;
      t0 = std::chrono::steady_clock::now();
      const SolverChoice c = chooseSolver(sys.K, sp, o.choose, np);
      std::printf("choose=%d dofs=%lld nnz=%lld picked=%s choose_s=%.2f predicted_cholesky_s=%.1f "
                  "predicted_iterative_s=%.1f note=\"%s\"\n",
                  o.choose, (long long)sys.K.rows(), (long long)sys.K.nonZeros(), solverKindName(c.kind),
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                  c.predictedCholeskySeconds, c.predictedIterativeSeconds, c.note.c_str());
      return 0;
    }
    if (o.meg > 0) return runMeg(mesh, p, o, readSeconds);
    t0 = std::chrono::steady_clock::now();
    const LeadFieldResult r = computeLeadField(mesh, p, np);
    np.endStage();
    const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("solver=%s preconditioner=%s backend=%s tets=%zu dofs=%lld nnz=%lld electrodes=%zu sources=%zu "
                "read_s=%.2f total_s=%.2f",
                o.solver.c_str(), o.preconditioner.c_str(), o.backend.c_str(), mesh.numTets(), (long long)r.dofs,
                (long long)r.nnz, r.names.size(), r.sources.size(), readSeconds, total);
    const double stages = printStages(np);
    std::printf(" stages_sum_s=%.2f solves=%lld ran=%s per_solve_s=%.3f iterations_mean=%.1f iterations_max=%lld converged=%d",
                stages, (long long)r.solves, r.solverUsed.c_str(), r.solves ? r.solveSeconds / double(r.solves) : 0.0,
                r.solves ? double(r.iterationsTotal) / double(r.solves) : 0.0, (long long)r.iterationsMax,
                r.converged ? 1 : 0);
    if (o.check > 0) {
      LeadFieldParams q = p;
      q.electrodes.resize(size_t(std::min<int>(o.check + 1, int(p.electrodes.size()))));
      q.solver = SolverParams{SolverKind::Minres, PreconditionerKind::Jacobi, o.checkTolerance, 100000};
      const LeadFieldResult ref = computeLeadField(mesh, q, np);
      double worst = 0;
      const Eigen::Index rows = ref.matrix.rows();
      for (Eigen::Index c = 0; c < ref.matrix.cols(); ++c) {
        const double den = ref.matrix.col(c).norm();
        if (den > 0) worst = std::max(worst, (r.matrix.col(c).head(rows) - ref.matrix.col(c)).norm() / den);
      }
      std::printf(" check_rows=%lld check_tolerance=%g check_max_rel_diff=%.3g check_iterations_mean=%.0f", (long long)(rows - 1),
                  o.checkTolerance, worst, ref.solves ? double(ref.iterationsTotal) / double(ref.solves) : 0.0);
    }
    for (const auto& n : r.notes)
      if (n.rfind("cholesky: ", 0) == 0 || n.rfind("auto: ", 0) == 0) std::printf(" note=\"%s\"", n.c_str());
    std::printf("\n");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "leadfield_benchmark: %s\n", e.what());
    return 1;
  }
}
