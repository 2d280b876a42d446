#include "SparseCholesky.h"

#include <cholmod.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <condition_variable>
#include <cstdlib>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Timing.h"
#include "Algorithms/Core/MemoryBudget.h"

namespace tetflow {

namespace {
const char* orderingName(int o) {
  switch (o) {
  case CHOLMOD_NATURAL: return "natural";
  case CHOLMOD_GIVEN: return "given";
  case CHOLMOD_AMD: return "amd";
  case CHOLMOD_METIS: return "metis";
  case CHOLMOD_NESDIS: return "nesdis";
  case CHOLMOD_COLAMD: return "colamd";
  case CHOLMOD_POSTORDERED: return "postordered";
  default: return "?";
  }
}
// CHOLMOD's numeric work (factorisations and triangular solves) calls the threaded OpenBLAS,
// which is entered from one thread at a time here: a factorisation cancelled while it runs goes
// on in the background, and OpenBLAS's thread pool, entered concurrently from several threads,
// could hang the process at exit (seen once in CI). So every numeric call holds this lock, a
// worker whose caller gave up before it got the lock does nothing, and the process waits at exit
// for a background worker still inside OpenBLAS (atexit runs before OpenBLAS's own shutdown).
std::mutex& numericMutex() {
  static std::mutex m;
  return m;
}
std::mutex gWorkersMutex;
std::condition_variable gWorkersDone;
int gWorkers = 0;
void waitForWorkers() {
  std::unique_lock<std::mutex> lock(gWorkersMutex);
  gWorkersDone.wait(lock, [] { return gWorkers == 0; });
}
// Counts a worker from its start to its end; the first registers waitForWorkers at exit.
struct WorkerCount {
  WorkerCount() {
    static const bool registered = [] { return std::atexit(waitForWorkers) == 0; }();
    (void)registered;
    std::lock_guard<std::mutex> lock(gWorkersMutex);
    ++gWorkers;
  }
  ~WorkerCount() {
    std::lock_guard<std::mutex> lock(gWorkersMutex);
    if (--gWorkers == 0) gWorkersDone.notify_all();
  }
};
} // namespace

struct SparseCholesky::State {
  cholmod_common c;
  cholmod_sparse* A = nullptr; // lower triangle of K, 64-bit indices
  cholmod_factor* L = nullptr;
  std::atomic<bool> done{false};
  std::atomic<bool> abandoned{false}; // the caller cancelled: a worker not yet started skips the work
  std::atomic<bool> factorized{false};
  std::mutex solveMutex; // cholmod_common is not thread-safe: one solve at a time
  int status = CHOLMOD_OK;
  int64_t minor = 0; // first column that is not positive definite (== n when all are)
  double analyzeSeconds = 0, factorizeSeconds = 0;

  State() {
    cholmod_l_start(&c);
    c.print = 0;
    c.error_handler = nullptr;
    c.supernodal = CHOLMOD_SUPERNODAL;
    c.final_ll = 1;
  }
  ~State() {
    if (L) cholmod_l_free_factor(&L, &c);
    if (A) cholmod_l_free_sparse(&A, &c);
    cholmod_l_finish(&c);
  }
};

SparseCholesky::SparseCholesky() : s_(std::make_shared<State>()) {}

SparseCholesky::~SparseCholesky() = default; // a cancelled worker keeps its own reference

void SparseCholesky::analyze(const SparseMatrix& K) {
  if (K.rows() != K.cols()) throw InputError("cholesky: the matrix is not square");
  if (!K.isCompressed()) throw InputError("cholesky: the matrix must be compressed");
  const auto t0 = std::chrono::steady_clock::now();
  if (s_->L || s_->A) s_ = std::make_shared<State>();
  State& s = *s_;
  const int64_t n = K.rows();
  int64_t nnzLower = 0;
  for (int64_t j = 0; j < n; ++j)
    for (SparseMatrix::InnerIterator it(K, Eigen::Index(j)); it; ++it)
      if (it.row() >= j) ++nnzLower;
  s.A = cholmod_l_allocate_sparse(size_t(n), size_t(n), size_t(nnzLower), 1, 1, -1, CHOLMOD_REAL, &s.c);
  if (!s.A) throw ProcessingError("cholesky: out of memory copying the matrix (" + std::to_string(nnzLower) +
                                  " nonzeros)");
  auto* p = static_cast<SuiteSparse_long*>(s.A->p);
  auto* idx = static_cast<SuiteSparse_long*>(s.A->i);
  auto* x = static_cast<double*>(s.A->x);
  int64_t k = 0;
  for (int64_t j = 0; j < n; ++j) {
    p[j] = SuiteSparse_long(k);
    for (SparseMatrix::InnerIterator it(K, Eigen::Index(j)); it; ++it)
      if (it.row() >= j) {
        idx[k] = SuiteSparse_long(it.row());
        x[k] = it.value();
        ++k;
      }
  }
  p[n] = SuiteSparse_long(k);
  if (n >= 50000) {
    // CHOLMOD's default tries AMD and then, as a 3-D mesh always has high fill, METIS as well;
    // METIS's nested dissection wins on every head mesh measured, so it is the only one tried.
    s.c.nmethods = 1;
    s.c.method[0].ordering = CHOLMOD_METIS;
  }
  s.L = cholmod_l_analyze(s.A, &s.c);
  if (!s.L || s.c.status < CHOLMOD_OK)
    throw ProcessingError("cholesky: the symbolic analysis failed (CHOLMOD status " + std::to_string(s.c.status) +
                          (s.c.status == CHOLMOD_OUT_OF_MEMORY ? ", out of memory)" : ")"));
  s.analyzeSeconds = secondsSince(t0);
}

void SparseCholesky::factorize(Progress& progress) {
  if (!s_->L) throw InputError("cholesky: analyze the matrix before factorising it");
  if (s_->factorized) return;
  const int64_t n = rows();
  {
    std::ostringstream what;
    what << "the Cholesky factor of the " << n << "-unknown system (" << factorNonzeros() << " nonzeros)";
    requireMemory(factorBytes() + 8.0 * double(n) * 8.0, what.str(), [](double) {
      return std::string("use solver = minres or cg (iterative: memory of the matrix only), or a coarser mesh");
    });
  }
  progress.checkCancel();
  const auto t0 = std::chrono::steady_clock::now();
  std::shared_ptr<State> s = s_;
  auto count = std::make_shared<WorkerCount>();
  std::thread worker([s, count] {
    {
      std::lock_guard<std::mutex> numeric(numericMutex());
      if (!s->abandoned) {
        cholmod_l_factorize(s->A, s->L, &s->c);
        s->status = s->c.status;
        s->minor = int64_t(s->L->minor);
      }
    }
    s->done = true;
  });
  count.reset(); // the worker holds the count to its end
  while (!s->done) {
    if (progress.cancelRequested()) {
      s->abandoned = true;
      worker.detach(); // it finishes on its own and frees the factor with the last reference
      s_ = std::make_shared<State>();
      throw Cancelled();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  worker.join();
  s->factorizeSeconds = secondsSince(t0);
  if (s->status == CHOLMOD_NOT_POSDEF || s->minor < n) {
    std::ostringstream m;
    m << "cholesky: the matrix is not positive definite (pivot of column " << s->minor
      << " <= 0); check the conductivities (every one > 0) and that the system has a Dirichlet condition";
    throw InputError(m.str());
  }
  if (s->status < CHOLMOD_OK)
    throw ProcessingError("cholesky: the factorisation failed (CHOLMOD status " + std::to_string(s->status) +
                          (s->status == CHOLMOD_OUT_OF_MEMORY ? ", out of memory)" : ")"));
  s->factorized = true;
  progress.checkCancel();
}

namespace {
// One block of triangular solves, owned jointly by the caller and (with a progress) its worker.
struct SolveJob {
  Eigen::MatrixXd B, X;
  std::atomic<bool> done{false};
  int status = CHOLMOD_OK;
  bool ok = false;
};

void runSolve(SparseCholesky::State& s, SolveJob& job) {
  std::lock_guard<std::mutex> lock(s.solveMutex);
  std::lock_guard<std::mutex> numeric(numericMutex());
  cholmod_dense b;
  std::memset(&b, 0, sizeof b);
  b.nrow = size_t(job.B.rows());
  b.ncol = size_t(job.B.cols());
  b.nzmax = b.nrow * b.ncol;
  b.d = b.nrow;
  b.x = job.B.data();
  b.xtype = CHOLMOD_REAL;
  b.dtype = CHOLMOD_DOUBLE;
  cholmod_dense* x = cholmod_l_solve(CHOLMOD_A, s.L, &b, &s.c);
  job.status = s.c.status;
  if (x) {
    job.X.resize(job.B.rows(), job.B.cols());
    std::memcpy(job.X.data(), x->x, sizeof(double) * b.nrow * b.ncol);
    cholmod_l_free_dense(&x, &s.c);
    job.ok = true;
  }
}
} // namespace

void SparseCholesky::solve(const Eigen::MatrixXd& B, Eigen::MatrixXd& X, Progress* progress) const {
  if (!factorized()) throw InputError("cholesky: factorise the matrix before solving");
  const int64_t n = rows();
  if (B.rows() != n)
    throw InputError("cholesky: right-hand side has " + std::to_string(B.rows()) + " rows for a matrix of size " +
                     std::to_string(n));
  if (B.cols() == 0) {
    X.resize(B.rows(), 0);
    return;
  }
  if (progress) progress->checkCancel();
  auto job = std::make_shared<SolveJob>();
  job->B = B;
  if (!progress) {
    runSolve(*s_, *job);
  } else {
    std::shared_ptr<State> s = s_;
    auto count = std::make_shared<WorkerCount>();
    std::thread worker([s, job, count] {
      runSolve(*s, *job);
      job->done = true;
    });
    count.reset();
    while (!job->done) {
      if (progress->cancelRequested()) {
        worker.detach(); // it finishes on its own copies and frees them with the last reference
        throw Cancelled();
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    worker.join();
  }
  if (!job->ok)
    throw ProcessingError("cholesky: the triangular solves failed (CHOLMOD status " + std::to_string(job->status) +
                          (job->status == CHOLMOD_OUT_OF_MEMORY ? ", out of memory)" : ")"));
  X = std::move(job->X);
}

bool SparseCholesky::sameMatrix(const SparseMatrix& K) const {
  const cholmod_sparse* A = s_->A;
  if (!A || !K.isCompressed() || K.rows() != int64_t(A->nrow) || K.cols() != int64_t(A->ncol)) return false;
  const auto* p = static_cast<const SuiteSparse_long*>(A->p);
  const auto* idx = static_cast<const SuiteSparse_long*>(A->i);
  const auto* x = static_cast<const double*>(A->x);
  const int64_t n = K.rows();
  for (int64_t j = 0; j < n; ++j) {
    int64_t k = p[j];
    for (SparseMatrix::InnerIterator it(K, Eigen::Index(j)); it; ++it) {
      if (it.row() < j) continue;
      if (k >= p[j + 1] || idx[k] != SuiteSparse_long(it.row()) || x[k] != it.value()) return false;
      ++k;
    }
    if (k != p[j + 1]) return false;
  }
  return true;
}

bool SparseCholesky::factorized() const { return s_->factorized; }
int64_t SparseCholesky::rows() const { return s_->A ? int64_t(s_->A->nrow) : 0; }
double SparseCholesky::factorBytes() const {
  if (!s_->L) return 0.0;
  // Supernodal: L->xsize values plus L->ssize row indices; simplicial: nzmax of each.
  const cholmod_factor& L = *s_->L;
  if (L.is_super) return 8.0 * double(L.xsize) + 8.0 * double(L.ssize) + 32.0 * double(L.nsuper);
  return 16.0 * double(s_->c.lnz) + 32.0 * double(L.n);
}
double SparseCholesky::factorNonzeros() const { return s_->L ? s_->c.lnz : 0.0; }
double SparseCholesky::flops() const { return s_->L ? s_->c.fl : 0.0; }
const char* SparseCholesky::ordering() const { return s_->L ? orderingName(s_->L->ordering) : "none"; }
double SparseCholesky::analyzeSeconds() const { return s_->analyzeSeconds; }
double SparseCholesky::factorizeSeconds() const { return s_->factorizeSeconds; }

double SparseCholesky::solveBytes(int64_t n, int64_t k) { return 4.0 * 8.0 * double(n) * double(k); }

} // namespace tetflow
