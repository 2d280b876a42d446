#include "SolverCache.h"

#include <mutex>

#include "Algorithms/Core/MemoryBudget.h"
#include "SparseCholesky.h"

namespace tetflow::solver_cache {

namespace {
struct Cache {
  std::mutex mutex;
  std::shared_ptr<SparseCholesky> factor;
  Stats stats;
  Cache() {
    addMemoryReclaimer([] { return release(); });
  }
};
Cache& cache() {
  static Cache c;
  return c;
}
} // namespace

std::shared_ptr<SparseCholesky> findCholesky(const SparseMatrix& K) {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  if (c.factor && c.factor->factorized() && c.factor->sameMatrix(K)) {
    ++c.stats.hits;
    return c.factor;
  }
  ++c.stats.misses;
  return nullptr;
}

void keepCholesky(std::shared_ptr<SparseCholesky> f) {
  if (!f || !f->factorized()) return;
  Cache& c = cache();
  std::shared_ptr<SparseCholesky> old;
  {
    std::lock_guard<std::mutex> lock(c.mutex);
    old = std::move(c.factor);
    c.factor = std::move(f);
    c.stats.keptBytes = c.factor->factorBytes();
  }
  // old is freed here, outside the lock
}

bool release() {
  Cache& c = cache();
  std::shared_ptr<SparseCholesky> old;
  {
    std::lock_guard<std::mutex> lock(c.mutex);
    old = std::move(c.factor);
    c.factor.reset();
    c.stats.keptBytes = 0;
  }
  return old != nullptr;
}

Stats stats() {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  return c.stats;
}

} // namespace tetflow::solver_cache
