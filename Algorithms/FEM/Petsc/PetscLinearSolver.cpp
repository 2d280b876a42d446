#include "PetscLinearSolver.h"

#include <cstdlib>
#include <string>

#include "Algorithms/Core/Errors.h"

#ifdef TETFLOW_HAVE_PETSC
#include <petscksp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <sstream>
#endif

namespace tetflow {

int launcherRanks() {
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE", "MPI_LOCALNRANKS"})
    if (const char* v = std::getenv(var)) {
      const int n = std::atoi(v);
      if (n > 0) return n;
    }
  return 1;
}

#ifndef TETFLOW_HAVE_PETSC

bool petscAvailable() { return false; }

struct PetscLinearSolver::Impl {};
PetscLinearSolver::PetscLinearSolver(const SparseMatrix&, const SolverParams&) {
  throw InputError("solver_backend = petsc: this TetFlow was built without PETSc; install "
                   "libpetsc-real-dev and reconfigure with -DTETFLOW_WITH_PETSC=ON");
}
PetscLinearSolver::~PetscLinearSolver() = default;
bool PetscLinearSolver::sameSystem(const SparseMatrix&, const SolverParams&) const { return false; }
PetscLinearSolver::Outcome PetscLinearSolver::solve(const Eigen::VectorXd&, Eigen::VectorXd&, Progress*, bool) {
  return {};
}
int PetscLinearSolver::ranks() const { return 1; }

ParallelSession::ParallelSession() {
  if (launcherRanks() > 1)
    throw InputError("this TetFlow was built without PETSc, so it cannot share a solve between MPI "
                     "ranks (and every rank would run the whole net): run it without mpirun, or "
                     "install libpetsc-real-dev and reconfigure with -DTETFLOW_WITH_PETSC=ON");
}
ParallelSession::~ParallelSession() = default;
int ParallelSession::runWorker() { return 0; }

#else // TETFLOW_HAVE_PETSC

bool petscAvailable() { return true; }

namespace {

enum Command : int { kExit = 0, kSetup = 1, kSolve = 2, kRelease = 3 };

int commRank() {
  int r = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &r);
  return r;
}
int commSize() {
  int s = 1;
  MPI_Comm_size(PETSC_COMM_WORLD, &s);
  return s;
}

bool g_weInitialised = false;    // PETSc
bool g_weInitialisedMpi = false; // MPI (initialised before PETSc, so PETSc leaves it to us)

// The executor runs modules in threads: two solves on rank 0 must not interleave their commands
// and collectives. Every operation (set-up, solve, release, exit) holds this lock from its first
// broadcast to its last collective; MPI runs at MPI_THREAD_SERIALIZED.
std::mutex g_mpiMutex;

// PETSc error: one rank -> ProcessingError; several -> message and MPI_Abort (no hang).
void check(PetscErrorCode ierr, const char* call) {
  if (ierr == 0) return;
  const char* text = nullptr;
  PetscErrorMessage(ierr, &text, nullptr);
  std::string msg = std::string("PETSc error in ") + call + ": " + (text ? text : "unknown error");
  if (commSize() > 1) {
    std::fprintf(stderr, "tetflow: rank %d: %s; stopping all ranks\n", commRank(), msg.c_str());
    std::fflush(stderr);
    MPI_Abort(PETSC_COMM_WORLD, 1);
  }
  throw ProcessingError(msg);
}
#define TF_PETSC(call) check((call), #call)

void ensureInitialised() {
  PetscBool done = PETSC_FALSE;
  PetscInitialized(&done);
  if (done) return;
  int mpiDone = 0;
  MPI_Initialized(&mpiDone);
  if (!mpiDone) {
    int provided = 0;
    if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS)
      throw ProcessingError("MPI could not be initialised");
    g_weInitialisedMpi = true;
  }
  // PETSc must not install signal handlers: a crash stays a crash (and sanitizers see it).
  PetscOptionsSetValue(nullptr, "-no_signal_handler", nullptr);
  if (PetscInitializeNoArguments() != 0) throw ProcessingError("PETSc could not be initialised");
  g_weInitialised = true;
}

// Finalises what this process initialised, at exit, when no ParallelSession did.
struct Finaliser {
  ~Finaliser() {
    PetscBool init = PETSC_FALSE, fin = PETSC_FALSE;
    PetscInitialized(&init);
    PetscFinalized(&fin);
    if (g_weInitialised && init && !fin) PetscFinalize();
    int mpiFin = 0;
    MPI_Finalized(&mpiFin);
    if (g_weInitialisedMpi && !mpiFin) MPI_Finalize();
  }
} g_finaliser;

// Parameters every rank needs to set up the same KSP.
struct WireParams {
  int kind = 0, preconditioner = 0;
  double tolerance = 0;
  int64_t maxIterations = 0;
  int64_t n = 0;
  int64_t optionsLength = 0;
};

struct RowBlock {
  std::vector<PetscInt> ptr, cols;
  std::vector<PetscScalar> vals;
};

int64_t rowBegin(int64_t n, int rank, int size) { return n * rank / size; }

// Convergence test: PETSc's default plus rank 0's cancellation flag, broadcast every iteration.
struct TestContext {
  void* defaultContext = nullptr;
  Progress* progress = nullptr; // rank 0 only
  bool reportFraction = true;
  double tolerance = 1e-8;
  double initialNorm = 0.0;
  bool cancelled = false;
};
PetscErrorCode convergenceTest(KSP ksp, PetscInt it, PetscReal rnorm, KSPConvergedReason* reason, void* ctx) {
  auto* c = static_cast<TestContext*>(ctx);
  PetscErrorCode ierr = KSPConvergedDefault(ksp, it, rnorm, reason, c->defaultContext);
  if (ierr) return ierr;
  int cancel = 0;
  if (c->progress) {
    cancel = c->progress->cancelRequested() ? 1 : 0;
    if (it == 0) c->initialNorm = double(rnorm);
    if (c->reportFraction && it > 0 && (it & 7) == 0 && c->initialNorm > 0) {
      const double rel = double(rnorm) / c->initialNorm;
      const double frac = rel > 0 ? std::log(rel) / std::log(c->tolerance) : 1.0;
      c->progress->report(std::clamp(frac, 0.0, 1.0));
    }
  }
  if (commSize() > 1) MPI_Bcast(&cancel, 1, MPI_INT, 0, PETSC_COMM_WORLD);
  if (cancel) {
    c->cancelled = true;
    *reason = KSP_DIVERGED_ITS; // any nonzero reason ends the solve on every rank
  }
  return 0;
}
PetscErrorCode destroyTestContext(void* ctx) {
  auto* c = static_cast<TestContext*>(ctx);
  KSPConvergedDefaultDestroy(c->defaultContext);
  delete c;
  return 0;
}

// One distributed system: the same object on every rank.
struct Engine {
  Mat A = nullptr;
  KSP ksp = nullptr;
  Vec b = nullptr, x = nullptr, x0 = nullptr;
  VecScatter toZero = nullptr;
  TestContext* test = nullptr;
  int64_t n = 0, begin = 0, end = 0;

  void setUp(const WireParams& w, RowBlock& rows, const std::string& options) {
    n = w.n;
    const int rank = commRank(), size = commSize();
    begin = rowBegin(n, rank, size);
    end = rowBegin(n, rank + 1, size);
    const PetscInt m = PetscInt(end - begin);
    TF_PETSC(MatCreateMPIAIJWithArrays(PETSC_COMM_WORLD, m, m, PetscInt(n), PetscInt(n), rows.ptr.data(),
                                       rows.cols.data(), rows.vals.data(), &A));
    rows = RowBlock(); // PETSc copied the rows
    TF_PETSC(MatSetOption(A, MAT_SYMMETRIC, PETSC_TRUE));
    TF_PETSC(MatSetOption(A, MAT_SPD, PETSC_TRUE));
    TF_PETSC(MatCreateVecs(A, &x, &b));
    TF_PETSC(VecScatterCreateToZero(x, &toZero, &x0));
    TF_PETSC(KSPCreate(PETSC_COMM_WORLD, &ksp));
    TF_PETSC(KSPSetOperators(ksp, A, A));
    const bool minres = SolverKind(w.kind) == SolverKind::Minres;
    TF_PETSC(KSPSetType(ksp, minres ? KSPMINRES : KSPCG));
    if (!minres) {
      TF_PETSC(KSPSetNormType(ksp, KSP_NORM_NATURAL));
      TF_PETSC(KSPSetComputeSingularValues(ksp, PETSC_TRUE)); // condition estimate of M^-1 K
    }
    PC pc = nullptr;
    TF_PETSC(KSPGetPC(ksp, &pc));
    switch (PreconditionerKind(w.preconditioner)) {
    case PreconditionerKind::Jacobi: TF_PETSC(PCSetType(pc, PCJACOBI)); break;
    case PreconditionerKind::None: TF_PETSC(PCSetType(pc, PCNONE)); break;
    case PreconditionerKind::Gamg: TF_PETSC(PCSetType(pc, PCGAMG)); break;
    case PreconditionerKind::Hypre:
      TF_PETSC(PCSetType(pc, PCHYPRE));
      TF_PETSC(PCHYPRESetType(pc, "boomeramg"));
      // BoomerAMG's defaults (Falgout coarsening, classical interpolation, threshold 0.25) are
      // tuned for 2-D: on the 2.2 M-unknown head they took 5.6 GB and 56 s on one rank. The
      // settings hypre recommends for 3-D; petsc_options override them.
      TF_PETSC(PetscOptionsSetValue(nullptr, "-pc_hypre_boomeramg_strong_threshold", "0.5"));
      TF_PETSC(PetscOptionsSetValue(nullptr, "-pc_hypre_boomeramg_coarsen_type", "HMIS"));
      TF_PETSC(PetscOptionsSetValue(nullptr, "-pc_hypre_boomeramg_interp_type", "ext+i"));
      TF_PETSC(PetscOptionsSetValue(nullptr, "-pc_hypre_boomeramg_P_max", "4"));
      TF_PETSC(PetscOptionsSetValue(nullptr, "-pc_hypre_boomeramg_agg_nl", "1"));
      break;
    }
    TF_PETSC(KSPSetTolerances(ksp, w.tolerance, 0.0, PETSC_MAX_REAL, PetscInt(w.maxIterations)));
    TF_PETSC(KSPSetInitialGuessNonzero(ksp, PETSC_FALSE));
    TF_PETSC(KSPSetResidualHistory(ksp, nullptr, PetscInt(w.maxIterations + 1), PETSC_TRUE));
    if (!options.empty()) TF_PETSC(PetscOptionsInsertString(nullptr, options.c_str()));
    TF_PETSC(KSPSetFromOptions(ksp));
    test = new TestContext;
    test->tolerance = w.tolerance;
    TF_PETSC(KSPConvergedDefaultCreate(&test->defaultContext));
    TF_PETSC(KSPSetConvergenceTest(ksp, convergenceTest, test, destroyTestContext));
    TF_PETSC(KSPSetUp(ksp));
  }

  // Local block of b in, whole x out on rank 0 (others: x0 has length 0).
  void solve(const double* localB, Progress* progress, bool reportFraction, PetscLinearSolver::Outcome* out,
             double* xOut) {
    PetscScalar* p = nullptr;
    TF_PETSC(VecGetArray(b, &p));
    std::copy(localB, localB + (end - begin), p);
    TF_PETSC(VecRestoreArray(b, &p));
    test->progress = progress;
    test->reportFraction = reportFraction;
    test->cancelled = false;
    TF_PETSC(KSPSolve(ksp, b, x));
    test->progress = nullptr;
    PetscReal emax = 0, emin = 0;
    KSPType type = nullptr;
    TF_PETSC(KSPGetType(ksp, &type));
    const bool cg = type && std::string(type) == KSPCG;
    if (cg) TF_PETSC(KSPComputeExtremeSingularValues(ksp, &emax, &emin)); // on every rank
    TF_PETSC(VecScatterBegin(toZero, x, x0, INSERT_VALUES, SCATTER_FORWARD));
    TF_PETSC(VecScatterEnd(toZero, x, x0, INSERT_VALUES, SCATTER_FORWARD));
    if (!out) return;
    const PetscScalar* xs = nullptr;
    TF_PETSC(VecGetArrayRead(x0, &xs));
    std::copy(xs, xs + n, xOut);
    TF_PETSC(VecRestoreArrayRead(x0, &xs));
    PetscInt its = 0;
    KSPConvergedReason reason;
    TF_PETSC(KSPGetIterationNumber(ksp, &its));
    TF_PETSC(KSPGetConvergedReason(ksp, &reason));
    const PetscReal* h = nullptr;
    PetscInt nh = 0;
    TF_PETSC(KSPGetResidualHistory(ksp, &h, &nh));
    out->iterations = its;
    if (cg && emin > 0 && emax >= emin) {
      out->eigenMin = double(emin);
      out->eigenMax = double(emax);
    }
    out->history.clear();
    for (PetscInt k = 0; k < nh; ++k) out->history.push_back(h[0] > 0 ? double(h[k] / h[0]) : 0.0);
    if (out->history.empty()) out->history.push_back(1.0);
    out->relativeResidual = out->history.back();
    if (test->cancelled) throw Cancelled();
    if (reason > 0)
      out->status = SolverStatus::Converged;
    else if (reason == KSP_DIVERGED_ITS)
      out->status = SolverStatus::MaxIterations;
    else
      out->status = SolverStatus::Breakdown;
  }

  ~Engine() {
    if (ksp) KSPDestroy(&ksp);
    if (toZero) VecScatterDestroy(&toZero);
    if (x0) VecDestroy(&x0);
    if (x) VecDestroy(&x);
    if (b) VecDestroy(&b);
    if (A) MatDestroy(&A);
  }
};

void bcastCommand(int cmd, int id) {
  int c[2] = {cmd, id};
  MPI_Bcast(c, 2, MPI_INT, 0, PETSC_COMM_WORLD);
}

int g_nextId = 1;

} // namespace

struct PetscLinearSolver::Impl {
  int id = 0;
  const SparseMatrix* K = nullptr;
  SolverParams params;
  Engine engine;
  std::vector<int> counts, displs; // rows per rank (scatter of b)
};

PetscLinearSolver::PetscLinearSolver(const SparseMatrix& K, const SolverParams& params) : impl_(new Impl) {
  std::lock_guard<std::mutex> lock(g_mpiMutex);
  ensureInitialised();
  if (K.rows() != K.cols() || !K.isCompressed())
    throw InputError("PETSc backend: the matrix must be square and compressed");
  impl_->id = g_nextId++;
  impl_->K = &K;
  impl_->params = params;
  const int size = commSize();
  const int64_t n = K.rows();
  WireParams w;
  w.kind = int(params.kind);
  w.preconditioner = int(params.preconditioner);
  w.tolerance = params.tolerance;
  w.maxIterations = params.max_iterations;
  w.n = n;
  w.optionsLength = int64_t(params.petsc_options.size());
  const int* outer = K.outerIndexPtr();
  for (int r = 1; r < size; ++r)
    if (int64_t(outer[rowBegin(n, r + 1, size)]) - outer[rowBegin(n, r, size)] > INT32_MAX / int64_t(sizeof(PetscInt)))
      throw ProcessingError("PETSc backend: a rank's share of the matrix is too large for one MPI message; "
                            "use more ranks");
  if (size > 1) {
    bcastCommand(kSetup, impl_->id);
    MPI_Bcast(&w, sizeof w, MPI_BYTE, 0, PETSC_COMM_WORLD);
    MPI_Bcast(const_cast<char*>(params.petsc_options.data()), int(w.optionsLength), MPI_CHAR, 0, PETSC_COMM_WORLD);
  }
  const int* inner = K.innerIndexPtr();
  const double* vals = K.valuePtr();
  // The symmetric K's column j is its row j: rank r's rows are a contiguous slice of the arrays.
  auto blockOf = [&](int r) {
    RowBlock blk;
    const int64_t b0 = rowBegin(n, r, size), b1 = rowBegin(n, r + 1, size);
    const int64_t o0 = outer[b0];
    for (int64_t i = b0; i <= b1; ++i) blk.ptr.push_back(PetscInt(outer[i] - o0));
    blk.cols.assign(inner + o0, inner + outer[b1]);
    blk.vals.assign(vals + o0, vals + outer[b1]);
    return blk;
  };
  for (int r = 1; r < size; ++r) {
    RowBlock blk = blockOf(r);
    int64_t nnz = int64_t(blk.cols.size());
    MPI_Send(&nnz, 1, MPI_INT64_T, r, 0, PETSC_COMM_WORLD);
    MPI_Send(blk.ptr.data(), int(blk.ptr.size()) * int(sizeof(PetscInt)), MPI_BYTE, r, 1, PETSC_COMM_WORLD);
    MPI_Send(blk.cols.data(), int(nnz) * int(sizeof(PetscInt)), MPI_BYTE, r, 2, PETSC_COMM_WORLD);
    MPI_Send(blk.vals.data(), int(nnz), MPI_DOUBLE, r, 3, PETSC_COMM_WORLD);
  }
  for (int r = 0; r < size; ++r) {
    impl_->counts.push_back(int(rowBegin(n, r + 1, size) - rowBegin(n, r, size)));
    impl_->displs.push_back(int(rowBegin(n, r, size)));
  }
  RowBlock mine = blockOf(0);
  impl_->engine.setUp(w, mine, params.petsc_options);
}

PetscLinearSolver::~PetscLinearSolver() {
  if (!impl_) return;
  std::lock_guard<std::mutex> lock(g_mpiMutex);
  if (commSize() > 1) bcastCommand(kRelease, impl_->id);
  impl_.reset(); // the Engine's PETSc objects are destroyed under the lock too
}

bool PetscLinearSolver::sameSystem(const SparseMatrix& K, const SolverParams& p) const {
  const SolverParams& q = impl_->params;
  return &K == impl_->K && p.kind == q.kind && p.preconditioner == q.preconditioner &&
         p.tolerance == q.tolerance && p.max_iterations == q.max_iterations && p.petsc_options == q.petsc_options;
}

int PetscLinearSolver::ranks() const { return commSize(); }

PetscLinearSolver::Outcome PetscLinearSolver::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x, Progress* progress,
                                                    bool reportFraction) {
  std::lock_guard<std::mutex> lock(g_mpiMutex);
  const int64_t n = impl_->engine.n;
  if (b.size() != n) throw InputError("PETSc backend: right-hand side size does not match the matrix");
  std::vector<double> local(size_t(impl_->counts[0]));
  if (commSize() > 1) {
    bcastCommand(kSolve, impl_->id);
    MPI_Scatterv(b.data(), impl_->counts.data(), impl_->displs.data(), MPI_DOUBLE, local.data(),
                 impl_->counts[0], MPI_DOUBLE, 0, PETSC_COMM_WORLD);
  } else {
    std::copy(b.data(), b.data() + n, local.begin());
  }
  Outcome out;
  x.resize(n);
  impl_->engine.solve(local.data(), progress, reportFraction, &out, x.data());
  return out;
}

ParallelSession::ParallelSession() {
  if (launcherRanks() <= 1) return; // single process: PETSc starts on first use
  ensureInitialised();
  rank_ = commRank();
  size_ = commSize();
}

ParallelSession::~ParallelSession() {
  PetscBool init = PETSC_FALSE, fin = PETSC_FALSE;
  PetscInitialized(&init);
  PetscFinalized(&fin);
  if (!init || fin) return;
  std::lock_guard<std::mutex> lock(g_mpiMutex);
  if (rank_ == 0 && commSize() > 1) bcastCommand(kExit, 0);
  if (g_weInitialised) PetscFinalize();
  if (g_weInitialisedMpi) MPI_Finalize();
  g_weInitialised = g_weInitialisedMpi = false;
}

int ParallelSession::runWorker() {
  std::map<int, std::unique_ptr<Engine>> engines;
  const int rank = commRank(), size = commSize();
  for (;;) {
    int c[2] = {0, 0};
    MPI_Bcast(c, 2, MPI_INT, 0, PETSC_COMM_WORLD);
    try {
      switch (c[0]) {
      case kExit: return 0;
      case kSetup: {
        WireParams w;
        MPI_Bcast(&w, sizeof w, MPI_BYTE, 0, PETSC_COMM_WORLD);
        std::string options(size_t(w.optionsLength), '\0');
        MPI_Bcast(options.data(), int(w.optionsLength), MPI_CHAR, 0, PETSC_COMM_WORLD);
        int64_t nnz = 0;
        MPI_Recv(&nnz, 1, MPI_INT64_T, 0, 0, PETSC_COMM_WORLD, MPI_STATUS_IGNORE);
        RowBlock rows;
        rows.ptr.resize(size_t(rowBegin(w.n, rank + 1, size) - rowBegin(w.n, rank, size) + 1));
        rows.cols.resize(size_t(nnz));
        rows.vals.resize(size_t(nnz));
        MPI_Recv(rows.ptr.data(), int(rows.ptr.size() * sizeof(PetscInt)), MPI_BYTE, 0, 1, PETSC_COMM_WORLD,
                 MPI_STATUS_IGNORE);
        MPI_Recv(rows.cols.data(), int(nnz * int64_t(sizeof(PetscInt))), MPI_BYTE, 0, 2, PETSC_COMM_WORLD,
                 MPI_STATUS_IGNORE);
        MPI_Recv(rows.vals.data(), int(nnz), MPI_DOUBLE, 0, 3, PETSC_COMM_WORLD, MPI_STATUS_IGNORE);
        auto e = std::make_unique<Engine>();
        e->setUp(w, rows, options);
        engines[c[1]] = std::move(e);
        break;
      }
      case kSolve: {
        Engine& e = *engines.at(c[1]);
        std::vector<double> local(size_t(e.end - e.begin));
        MPI_Scatterv(nullptr, nullptr, nullptr, MPI_DOUBLE, local.data(), int(local.size()), MPI_DOUBLE, 0,
                     PETSC_COMM_WORLD);
        e.solve(local.data(), nullptr, false, nullptr, nullptr);
        break;
      }
      case kRelease: engines.erase(c[1]); break;
      default:
        std::fprintf(stderr, "tetflow: rank %d: unknown command %d from rank 0; stopping all ranks\n", rank, c[0]);
        MPI_Abort(PETSC_COMM_WORLD, 1);
      }
    } catch (const std::exception& ex) { // e.g. out of memory: the others wait in a collective
      std::fprintf(stderr, "tetflow: rank %d: %s; stopping all ranks\n", rank, ex.what());
      std::fflush(stderr);
      MPI_Abort(PETSC_COMM_WORLD, 1);
    }
  }
}

#endif // TETFLOW_HAVE_PETSC

} // namespace tetflow
