#pragma once
// EEG lead field by reciprocity (Helmholtz; Weinstein et al. 2000, Wolters et al. 2004): one FEM
// solve per electrode instead of one per source.
//
// Electrodes are snapped to the nearest boundary (scalp surface) vertex; the snap distance is
// reported per electrode. The first electrode (or the one named by `reference`) is the ground g:
// its vertex is held at 0 V. For every other electrode e, K u_e = 1 mA injected at e's vertex
// (and drawn out at g) is solved on the same reduced matrix K (the solver's Jacobi preconditioner
// or, with solver_backend petsc, the distributed system and its AMG hierarchy, set up once and
// reused). With the partial-integration dipole of AssembleFEMPoisson (Assembly.h addDipole,
// load b_a = m . grad l_a on the tet T containing the source), the potential difference of a
// direct solve is V_e - V_g = u_e^T b = m . grad u_e|_T, so
//   L(e, 3 s + k) = d/dx_k u_e on the tet of source s        (V per mA mm, i.e. per unit moment)
// agrees with direct dipole solves to the solver tolerance (tested). Rows are then referenced:
// `reference` = "average" subtracts every column's mean over the electrodes (average reference);
// an electrode name keeps V_e - V_name (that electrode's row is 0).
//
// Sources: the centroids of every tet whose label is in `sourceLabels` (e.g. the brain), in tet
// order, or the points `sourcePoints` (each located in its tet; a point outside the mesh is an
// InputError naming it). Units: mm, S/m, mA mm, V.
//
// Stages: sources, assemble, snap electrodes, [factorize (cholesky, auto) or set up (petsc):
// setUpTransferSolver,] solve (one per electrode, fraction reported; cholesky: blocks of
// transferBlockSize() electrodes), lead field; they sum to the whole call.
// Errors (InputError): no electrodes, both or neither source kind, a source label absent from the
// mesh, electrodes in different connected pieces of the mesh, an unknown reference name, bad
// conductivities or solver parameters, not enough memory for the matrix (the message says how
// many sources would fit). A solve that does not converge is noted (and `converged` false).
#include <Eigen/Core>

#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/IO/ElectrodeIO.h"
#include "Conductivity.h"
#include "IterativeSolver.h"
#include "SourceModels.h"

namespace tetflow {

struct LeadFieldParams {
  ConductivityTable conductivities;
  std::vector<Electrode> electrodes;
  std::string reference = "average"; // "average" or an electrode name
  std::vector<int32_t> sourceLabels; // sources at the centroids of these labels' tets, or
  std::vector<Vec3> sourcePoints;    // at these points
  SolverParams solver;
  SourceModel sourceModel = SourceModel::PartialIntegration; // partial integration or Venant (SourceModels.h)
};

struct LeadFieldResult {
  std::vector<std::string> names;    // electrodes, in input order (rows)
  std::vector<Vec3> given;           // their positions as given (mm)
  std::vector<int32_t> vertex;       // snapped boundary vertex
  std::vector<double> snapDistance;  // mm
  int ground = 0;                    // electrode held at 0 V in the solves
  std::string reference;             // "average" or the electrode name
  std::vector<Vec3> sources;         // source positions (mm)
  std::vector<int64_t> sourceTets;   // containing tet
  Eigen::MatrixXd matrix;            // electrodes x (3 sources), V / (mA mm)
  int64_t dofs = 0, nnz = 0, solves = 0, iterationsTotal = 0, iterationsMax = 0;
  int64_t ranks = 1;
  bool converged = true;
  std::string solverUsed;            // the solver that ran (auto: the one it chose)
  double assembleSeconds = 0, setupSeconds = 0, solveSeconds = 0, matrixSeconds = 0; // setup: a direct solver's factorisation
  std::vector<std::string> notes;
};

// Counts one transfer-matrix solve of a lead field (EEG or MEG result: solves, iterations, ranks)
// and notes it, naming `what` (e.g. "electrode Fz"), when it did not converge.
template <class Result>
void countTransferSolve(Result& res, const IterativeSolver& solver, const std::string& what) {
  ++res.solves;
  res.iterationsTotal += solver.iterations();
  res.iterationsMax = std::max<int64_t>(res.iterationsMax, solver.iterations());
  res.ranks = solver.ranks();
  if (!solver.converged()) {
    res.converged = false;
    std::ostringstream m;
    m << "the solve for " << what << " did not converge (" << solverStatusName(solver.status())
      << ", relative residual " << solver.relativeResidual() << ")";
    res.notes.push_back(m.str());
  }
}

// The sources of a lead field (also used by Meg.h): the centroids of every tet whose label is in
// `labels`, in tet order, or `points`, each located in its tet. InputError for both or neither, a
// label absent from the mesh, a point outside it (numbered from 1).
void leadFieldSources(const TetMesh& mesh, const std::vector<int32_t>& labels, const std::vector<Vec3>& points,
                      std::vector<Vec3>& sources, std::vector<int64_t>& sourceTets, Progress& progress);

// Sets up a transfer-matrix solver (its operator, right-hand-side count and progress given) as
// stages of their own and returns their seconds: for solver auto first "choose solver" (the
// prediction, and CHOLMOD's analysis when the factor may pay), then "factorize" when cholesky runs
// (nothing numeric when SolverCache holds the factor of this K) or "set up" when the backend is
// petsc, given or chosen (distribution and preconditioner on every rank); nothing for the eigen
// iterative solvers. Appends the choice and the factor's figures to `notes`.
double setUpTransferSolver(IterativeSolver& solver, Progress& progress, std::vector<std::string>& notes);

// Right-hand sides a direct solver takes per pass in a transfer matrix of `dofs` unknowns: as many
// as fit in a twentieth of the memory left, 1 to 16 (more saved no time on the 1 mm head, and 64
// cost 1.4 GB there).
size_t transferBlockSize(int64_t dofs);

LeadFieldResult computeLeadField(const TetMesh& mesh, const LeadFieldParams& params, Progress& progress);

// Writes the matrix by extension, atomically (temp file + rename):
//   .npy  NumPy format 1.0, little-endian float64, C order, shape (electrodes, sources, 3):
//         numpy.load(path)[e, s, k]; MATLAB: readNPY, or fread after the header.
//   .csv  text: a header "electrode,s0_x,s0_y,s0_z,s1_x,...", then one row per electrode (name,
//         values with 17 significant digits).
// Beside it, PATH.electrodes.csv (name, given x y z, vertex, vertex x y z, distance_mm) and
// PATH.sources.csv (index, x y z, tet) say what the rows and columns are. InputError for another
// extension or an unwritable folder.
void writeLeadField(const LeadFieldResult& r, const TetMesh& mesh, const std::string& path);

// What the EEG and MEG lead field files share: the matrix (rows x 3 sources) to `path` as .npy
// (shape (rows, sources, 3)) or .csv (header "rowTitle,s0_x,s0_y,s0_z,...", a row per name), and
// the sources to PATH.sources.csv (index, x, y, z, tet), atomically. InputError naming `what`
// and the file for another extension, before anything is written.
void writeLeadFieldMatrix(const std::string& path, const std::string& what, const std::string& rowTitle,
                          const std::vector<std::string>& names, const Eigen::MatrixXd& matrix,
                          const std::vector<Vec3>& sources, const std::vector<int64_t>& sourceTets);

} // namespace tetflow
