#include "SolverCache.h"

#include <iterator>
#include <list>
#include <mutex>

#include "Algorithms/Core/MemoryBudget.h"
#include "SparseCholesky.h"

namespace tetflow::solver_cache {

namespace {
constexpr size_t kMaxKept = 4;

struct Cache {
  std::mutex mutex;
  std::list<std::shared_ptr<SparseCholesky>> factors; // most recently used first
  Stats stats;
  Cache() {
    addMemoryReclaimer([] { return release(); });
  }
  void count() {
    stats.keptBytes = 0;
    for (const auto& f : factors) stats.keptBytes += f->factorBytes();
    stats.kept = int64_t(factors.size());
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
  for (auto it = c.factors.begin(); it != c.factors.end(); ++it)
    if ((*it)->factorized() && (*it)->sameMatrix(K)) {
      ++c.stats.hits;
      c.factors.splice(c.factors.begin(), c.factors, it); // most recently used
      return c.factors.front();
    }
  ++c.stats.misses;
  return nullptr;
}

void keepCholesky(std::shared_ptr<SparseCholesky> f) {
  if (!f || !f->factorized()) return;
  Cache& c = cache();
  std::list<std::shared_ptr<SparseCholesky>> dropped; // freed outside the lock
  {
    std::lock_guard<std::mutex> lock(c.mutex);
    for (auto it = c.factors.begin(); it != c.factors.end(); ++it)
      if (*it == f) {
        c.factors.erase(it);
        break;
      }
    c.factors.push_front(std::move(f));
    // At most kMaxKept, and together at most half of what this process could have without them.
    double kept = 0;
    for (const auto& g : c.factors) kept += g->factorBytes();
    const double allowed = 0.5 * (double(memoryAvailable()) + kept);
    while (c.factors.size() > 1 && (c.factors.size() > kMaxKept || kept > allowed)) {
      kept -= c.factors.back()->factorBytes();
      dropped.splice(dropped.begin(), c.factors, std::prev(c.factors.end()));
    }
    c.count();
  }
}

bool release() {
  Cache& c = cache();
  std::list<std::shared_ptr<SparseCholesky>> dropped;
  {
    std::lock_guard<std::mutex> lock(c.mutex);
    dropped.swap(c.factors);
    c.count();
  }
  return !dropped.empty();
}

Stats stats() {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  return c.stats;
}

} // namespace tetflow::solver_cache
