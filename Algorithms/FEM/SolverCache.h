#pragma once
// Set-ups kept between solves of one system (issue 49 item 5): the node editor re-running a
// changed dipole or tDCS montage on an unchanged mesh, an EEG and a MEG lead field of one head,
// or a second ComputeLeadField with other sources reuse the Cholesky factor of K instead of
// computing it again. The cache keeps the most recent factor only (a head's factor is GBs). A
// lookup compares the whole matrix, pattern and values, with the one the factor was analysed
// from (SparseCholesky::sameMatrix: one pass over K, ~20 ms at 1 M unknowns), never a hash, so a
// changed conductivity, mesh or ground misses. requireMemory() releases the kept factor when a
// stage needs its memory (MemoryBudget.h). Thread-safe; solves on a shared factor are serialised
// by the factor itself.
#include <cstdint>
#include <memory>

#include "Assembly.h"

namespace tetflow {

class SparseCholesky;

namespace solver_cache {

// The kept factor when it was made from exactly K (factorised), else nullptr. Counts a hit or a
// miss.
std::shared_ptr<SparseCholesky> findCholesky(const SparseMatrix& K);
// Keeps f (factorised) in place of the previous one.
void keepCholesky(std::shared_ptr<SparseCholesky> f);
// Drops the kept factor (its memory is freed once no solver holds it); true if one was kept.
bool release();

struct Stats {
  int64_t hits = 0, misses = 0;
  double keptBytes = 0; // of the kept factor's L
};
Stats stats();

} // namespace solver_cache
} // namespace tetflow
