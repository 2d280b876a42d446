#include "LeadField.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <iomanip>
#include <limits>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Timing.h"
#include "Algorithms/Core/MemoryBudget.h"
#include "Algorithms/FEM/SourceModels.h"
#include "Algorithms/FEM/SparseCholesky.h"
#include "Algorithms/FEM/TetLocator.h"
#include "Algorithms/FEM/Subtraction.h"
#include "Algorithms/IO/FileUtil.h"
#include "Assembly.h"
#include "BoundaryConditions.h"

namespace tetflow {

namespace {
std::string vecText(const Vec3& p) {
  std::ostringstream s;
  s << "(" << p[0] << ", " << p[1] << ", " << p[2] << ")";
  return s.str();
}
} // namespace

size_t transferBlockSize(int64_t dofs) {
  const double perColumn = SparseCholesky::solveBytes(dofs, 1) + 8.0 * double(dofs); // and the expanded u
  const double fits = 0.05 * double(memoryAvailable()) / std::max(1.0, perColumn);
  return size_t(std::clamp(fits, 1.0, 16.0));
}

double setUpTransferSolver(IterativeSolver& solver, Progress& progress, std::vector<std::string>& notes) {
  const auto t0 = std::chrono::steady_clock::now();
  if (solver.params().kind == SolverKind::Auto) {
    progress.beginStage("choose solver"); // with CHOLMOD's analysis when the factor may pay
    solver.choose();
    if (!solver.choiceNote().empty()) notes.push_back(solver.choiceNote());
    progress.endStage();
  }
  const bool petsc = solver.params().backend == SolverBackend::Petsc;
  if (!solver.direct() && !petsc) return secondsSince(t0);
  progress.beginStage(petsc ? "set up" : "factorize");
  solver.setUp();
  if (const SparseCholesky* f = solver.cholesky()) {
    std::ostringstream m;
    m << "cholesky: " << f->ordering() << " ordering, " << f->factorNonzeros() << " nonzeros in L ("
      << formatBytes(f->factorBytes()) << "), " << f->flops() << " flops; ";
    if (solver.factorReused())
      m << "the factor was kept from an earlier solve of this system (no factorisation)";
    else
      m << "analysis " << f->analyzeSeconds() << " s, numeric factorisation " << f->factorizeSeconds() << " s";
    notes.push_back(m.str());
  }
  progress.endStage();
  return secondsSince(t0);
}

void leadFieldSources(const TetMesh& mesh, const std::vector<int32_t>& labels, const std::vector<Vec3>& points,
                      std::vector<Vec3>& sources, std::vector<int64_t>& sourceTets, Progress& progress) {
  if (labels.empty() == points.empty())
    throw InputError("sources: give either source labels (the centroids of their tets) or source points, "
                     "not both and not neither");
  sources.clear();
  sourceTets.clear();
  if (!labels.empty()) {
    for (int32_t l : labels) {
      if (std::find(mesh.materials.begin(), mesh.materials.end(), l) == mesh.materials.end())
        throw InputError("source_labels: label " + std::to_string(l) + " is not in the mesh");
    }
    for (size_t t = 0; t < mesh.numTets(); ++t)
      if (std::find(labels.begin(), labels.end(), mesh.materials[t]) != labels.end()) {
        const auto& q = mesh.tets[t];
        Vec3 c{0, 0, 0};
        for (int a = 0; a < 4; ++a) c = c + 0.25 * mesh.points[size_t(q[a])];
        sources.push_back(c);
        sourceTets.push_back(int64_t(t));
      }
  } else {
    const TetLocator locator(mesh);
    for (size_t i = 0; i < points.size(); ++i) {
      const auto loc = locator.locate(points[i]);
      if (!loc)
        throw InputError("sources: point " + std::to_string(i + 1) + " at " + vecText(points[i]) +
                         " mm lies outside the mesh");
      sources.push_back(points[i]);
      sourceTets.push_back(loc->tet);
      progress.checkCancel();
    }
  }
}

LeadFieldResult computeLeadField(const TetMesh& mesh, const LeadFieldParams& params, Progress& progress) {
  LeadFieldResult res;
  mesh.validateStructure("mesh");
  if (mesh.numTets() == 0) throw InputError("mesh: no tets; the lead field needs a tetrahedral mesh");
  if (params.electrodes.empty()) throw InputError("electrodes: none given; the lead field needs at least two");
  if (params.electrodes.size() < 2) throw InputError("electrodes: only one given; the lead field needs at least two");
  if (params.sourceLabels.empty() == params.sourcePoints.empty())
    throw InputError("sources: give either source labels (the centroids of their tets) or source points, "
                     "not both and not neither");
  params.solver.validate();
  params.conductivities.validate();
  const size_t ne = params.electrodes.size(), np = mesh.numPoints();

  // --- sources ---
  progress.beginStage("sources");
  leadFieldSources(mesh, params.sourceLabels, params.sourcePoints, res.sources, res.sourceTets, progress);
  const size_t ns = res.sources.size();
  {
    // The subtraction model keeps every electrode's solution (vertices x electrodes) and, per thread,
    // a source's three loads (vertices x 3).
    const double perVertex = params.sourceModel == SourceModel::Subtraction ? 8.0 * double(ne) + 48.0 : 0.0;
    const double bytes = 8.0 * double(ne) * 3.0 * double(ns) + 100.0 * double(mesh.numTets()) +
                         perVertex * double(mesh.numPoints());
    requireMemory(bytes, "the lead field of " + std::to_string(ne) + " electrodes x " + std::to_string(ns) + " sources",
                  [&](double avail) {
                    const double fits = std::floor(std::max(0.0, avail - 100.0 * double(mesh.numTets())) / (24.0 * double(ne)));
                    std::ostringstream f;
                    f << "use at most " << fits << " sources (a source point list, or fewer source labels)";
                    return f.str();
                  });
  }

  progress.endStage();

  // --- assemble ---
  auto t0 = std::chrono::steady_clock::now();
  progress.beginStage("assemble");
  const SparseMatrix K = assembleStiffness(mesh, params.conductivities, progress);
  progress.endStage();
  res.assembleSeconds = secondsSince(t0);

  // --- snap electrodes to the nearest boundary vertex ---
  progress.beginStage("snap electrodes");
  for (const Electrode& e : params.electrodes) {
    res.names.push_back(e.name);
    res.given.push_back(e.position);
  }
  for (const SurfaceSnap& s : snapToBoundary(mesh, res.given)) {
    res.vertex.push_back(s.vertex);
    res.snapDistance.push_back(s.distance);
  }
  for (size_t a = 0; a < ne; ++a)
    for (size_t b = a + 1; b < ne; ++b)
      if (res.vertex[a] == res.vertex[b])
        res.notes.push_back("electrodes " + res.names[a] + " and " + res.names[b] + " snap to the same vertex " +
                            std::to_string(res.vertex[a]) + ": their rows are equal");
  res.reference = params.reference;
  if (params.reference != "average") {
    auto it = std::find(res.names.begin(), res.names.end(), params.reference);
    if (it == res.names.end())
      throw InputError("reference '" + params.reference + "' is not an electrode name; use 'average' or one of "
                       "the names in the electrode file (e.g. " + res.names[0] + ")");
    res.ground = int(it - res.names.begin());
  }
  int32_t ncomp = 0;
  const std::vector<int32_t> comp = vertexComponents(mesh, ncomp);
  const int32_t groundVertex = res.vertex[size_t(res.ground)];
  for (size_t e = 0; e < ne; ++e)
    if (comp[size_t(res.vertex[e])] != comp[size_t(groundVertex)])
      throw InputError("electrodes " + res.names[e] + " and " + res.names[size_t(res.ground)] +
                       " snap to different connected pieces of the mesh; every electrode must be on the "
                       "surface of the same piece");
  DirichletSet dir(np);
  dir.set(size_t(groundVertex), 0.0);
  {
    std::vector<uint8_t> used(np, 0), anchored(size_t(ncomp), 0);
    for (const auto& t : mesh.tets)
      for (int32_t v : t) used[size_t(v)] = 1;
    anchored[size_t(comp[size_t(groundVertex)])] = 1;
    for (size_t v = 0; v < np; ++v) {
      if (!used[v]) {
        dir.set(v, 0.0);
      } else if (!anchored[size_t(comp[v])]) { // other pieces: their lowest vertex at 0 V
        anchored[size_t(comp[v])] = 1;
        dir.set(v, 0.0);
      }
    }
    if (ncomp > 1)
      res.notes.push_back("the mesh has " + std::to_string(ncomp) + " separate pieces; sources in pieces without "
                          "electrodes have zero lead field");
  }
  ReducedSystem sys = eliminateDirichlet(K, Eigen::VectorXd::Zero(Eigen::Index(np)), dir);
  res.dofs = sys.K.rows();
  res.nnz = sys.K.nonZeros();
  progress.endStage();

  // --- one solve per electrode (a direct solver: the factorisation, then blocks of them) ---
  std::vector<size_t> toSolve; // V_e - V_g = 0 for the ground's vertex
  for (size_t e = 0; e < ne; ++e)
    if (res.vertex[e] != groundVertex) toSolve.push_back(e);
  IterativeSolver solver(params.solver);
  solver.setOperator(sys.K);
  solver.setRightHandSides(int64_t(toSolve.size()));
  solver.setProgress(&progress, false); // cancellable; the fraction is the electrodes'
  res.setupSeconds = setUpTransferSolver(solver, progress, res.notes);
  res.solverUsed = solverKindName(solver.params().kind);
  t0 = std::chrono::steady_clock::now();
  progress.beginStage("solve");
  res.matrix = Eigen::MatrixXd::Zero(Eigen::Index(ne), Eigen::Index(3 * ns));
  const bool subtraction = params.sourceModel == SourceModel::Subtraction;
  const DipoleLoads loads = subtraction ? DipoleLoads{} : dipoleLoads(mesh, res.sources, res.sourceTets, params.sourceModel);
  // Subtraction: every electrode's solution, for the sources' loads after the solves.
  Eigen::MatrixXd solutions = subtraction ? Eigen::MatrixXd::Zero(Eigen::Index(np), Eigen::Index(ne)) : Eigen::MatrixXd();
  double mSeconds = 0;
  // Direct: blocks of right-hand sides (transferBlockSize), each cancellable while it runs.
  const size_t block = solver.direct() ? transferBlockSize(res.dofs) : 1;
  Eigen::MatrixXd B, X;
  Eigen::VectorXd x;
  size_t done = 0;
  for (size_t first = 0; first < toSolve.size(); first += block) {
    progress.checkCancel();
    const size_t count = std::min(block, toSolve.size() - first);
    if (solver.direct()) {
      B = Eigen::MatrixXd::Zero(res.dofs, Eigen::Index(count));
      for (size_t j = 0; j < count; ++j)
        B(sys.reducedIndex[size_t(res.vertex[toSolve[first + j]])], Eigen::Index(j)) = 1.0;
      solver.solveBlock(B, X);
    }
    for (size_t j = 0; j < count; ++j) {
      const size_t e = toSolve[first + j];
      if (!solver.direct()) {
        Eigen::VectorXd b = Eigen::VectorXd::Zero(res.dofs);
        b[sys.reducedIndex[size_t(res.vertex[e])]] = 1.0; // 1 mA in at e, out at the ground
        solver.solve(b, x);
      }
      countTransferSolve(res, solver, "electrode " + res.names[e]);
      const auto tm = std::chrono::steady_clock::now();
      const Eigen::VectorXd u = solver.direct() ? sys.expand(X.col(Eigen::Index(j))) : sys.expand(x);
      if (subtraction) {
        solutions.col(Eigen::Index(e)) = u;
      } else {
#pragma omp parallel for schedule(static)
        for (int64_t s = 0; s < int64_t(ns); ++s)
          for (int k = 0; k < 3; ++k)
            res.matrix(Eigen::Index(e), Eigen::Index(3 * s + k)) = loads.apply(size_t(3 * s + k), u);
      }
      mSeconds += secondsSince(tm);
      progress.report(double(++done) / double(toSolve.size()));
    }
  }
  progress.endStage();
  res.solveSeconds = secondsSince(t0) - mSeconds;

  // --- reference ---
  t0 = std::chrono::steady_clock::now();
  progress.beginStage("lead field");
  if (subtraction) {
    // V_e - V_g = u_inf(e) - u_inf(g) + w(e), and w(e) = u_e^T F m by reciprocity (w(g) = 0), F the
    // source's unit loads (Subtraction.h). The loads are parallel inside, so sources go one by one.
    const SubtractionSources sub(mesh, params.conductivities);
    for (size_t s = 0; s < ns; ++s) {
      progress.checkCancel();
      const Eigen::MatrixX3d F = sub.unitLoads(res.sources[s]);
      const double sigma = sub.sigmaAt(res.sources[s]);
      Eigen::MatrixXd block = solutions.transpose() * F; // electrodes x 3
      for (size_t e = 0; e < ne; ++e)
        for (int k = 0; k < 3; ++k) {
          Vec3 m{0, 0, 0};
          m[size_t(k)] = 1.0;
          block(Eigen::Index(e), k) +=
              SubtractionSources::singularPotential(res.sources[s], m, sigma, mesh.points[size_t(res.vertex[e])]) -
              SubtractionSources::singularPotential(res.sources[s], m, sigma, mesh.points[size_t(groundVertex)]);
        }
      res.matrix.block(0, Eigen::Index(3 * s), Eigen::Index(ne), 3) = block;
      progress.report(double(s + 1) / double(ns));
    }
  }
  if (params.reference == "average") {
    const Eigen::RowVectorXd mean = res.matrix.colwise().mean();
    res.matrix.rowwise() -= mean;
  }
  progress.endStage();
  res.matrixSeconds = mSeconds + secondsSince(t0);
  return res;
}

void writeLeadFieldMatrix(const std::string& path, const std::string& what, const std::string& rowTitle,
                          const std::vector<std::string>& names, const Eigen::MatrixXd& matrix,
                          const std::vector<Vec3>& sources, const std::vector<int64_t>& sourceTets) {
  const std::string ext = fileExtension(path);
  const size_t nr = names.size(), ns = sources.size();
  if (ext != ".npy" && ext != ".csv")
    throw InputError(what + " file " + path + ": unknown extension '" + ext + "'; use .npy (binary) or .csv (text)");
  {
    AtomicOutputFile out(path, ext == ".npy");
    auto& s = out.stream();
    if (ext == ".npy") {
      writeNpyFloat64Header(s, {nr, ns, 3});
      // Row-major (row, source, axis): the matrix row, in column order.
      std::vector<double> row(3 * ns);
      for (size_t e = 0; e < nr; ++e) {
        for (size_t c = 0; c < 3 * ns; ++c) row[c] = matrix(Eigen::Index(e), Eigen::Index(c));
        s.write(reinterpret_cast<const char*>(row.data()), std::streamsize(row.size() * sizeof(double)));
      }
    } else {
      s << rowTitle;
      for (size_t j = 0; j < ns; ++j) s << ",s" << j << "_x,s" << j << "_y,s" << j << "_z";
      s << "\n" << std::setprecision(17);
      for (size_t e = 0; e < nr; ++e) {
        s << names[e];
        for (size_t c = 0; c < 3 * ns; ++c) s << ',' << matrix(Eigen::Index(e), Eigen::Index(c));
        s << "\n";
      }
    }
    out.commit();
  }
  AtomicOutputFile out(path + ".sources.csv", false);
  auto& s = out.stream();
  s << "index,x,y,z,tet\n" << std::setprecision(10);
  for (size_t j = 0; j < ns; ++j)
    s << j << ',' << sources[j][0] << ',' << sources[j][1] << ',' << sources[j][2] << ',' << sourceTets[j] << "\n";
  out.commit();
}

void writeLeadField(const LeadFieldResult& r, const TetMesh& mesh, const std::string& path) {
  writeLeadFieldMatrix(path, "lead field", "electrode", r.names, r.matrix, r.sources, r.sourceTets);
  AtomicOutputFile out(path + ".electrodes.csv", false);
  auto& s = out.stream();
  s << "name,x,y,z,vertex,vertex_x,vertex_y,vertex_z,distance_mm\n" << std::setprecision(10);
  for (size_t e = 0; e < r.names.size(); ++e) {
    const Vec3& p = mesh.points[size_t(r.vertex[e])];
    s << r.names[e] << ',' << r.given[e][0] << ',' << r.given[e][1] << ',' << r.given[e][2] << ',' << r.vertex[e]
      << ',' << p[0] << ',' << p[1] << ',' << p[2] << ',' << r.snapDistance[e] << "\n";
  }
  out.commit();
}

} // namespace tetflow
