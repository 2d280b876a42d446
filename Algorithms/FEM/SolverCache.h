#pragma once
// Set-ups kept between solves of one system (issue 49 item 5): the node editor re-running a
// changed dipole or tDCS montage on an unchanged mesh, an EEG and a MEG lead field of one head,
// or a second ComputeLeadField with other sources reuse the Cholesky factor of K instead of
// computing it again. The cache keeps the four most recently used factors at most, and together
// at most half of what this process could take without them (a head's factor is GBs: then it is
// one); the least recently used goes first. A lookup compares the whole matrix, pattern and
// values, with the one a factor was analysed from (SparseCholesky::sameMatrix: one pass over K,
// ~20 ms at 1 M unknowns), never a hash, so a changed conductivity, mesh or ground misses.
// requireMemory() releases the kept factors when a stage needs their memory (MemoryBudget.h). Thread-safe; solves on a shared factor are serialised
// by the factor itself.
#include <cstdint>
#include <memory>

#include "Assembly.h"

namespace tetflow {

class SparseCholesky;

namespace solver_cache {

// A kept factor made from exactly K (factorised), else nullptr. Counts a hit or a miss.
std::shared_ptr<SparseCholesky> findCholesky(const SparseMatrix& K);
// Keeps f (factorised) as the most recently used, dropping the least recently used beyond the
// bounds above (f itself is always kept).
void keepCholesky(std::shared_ptr<SparseCholesky> f);
// Drops every kept factor (their memory is freed once no solver holds it); true if one was kept.
bool release();

struct Stats {
  int64_t hits = 0, misses = 0;
  int64_t kept = 0;     // factors kept
  double keptBytes = 0; // of their L
};
Stats stats();

} // namespace solver_cache
} // namespace tetflow
