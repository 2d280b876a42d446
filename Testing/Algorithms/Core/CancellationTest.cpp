// Cancellation building blocks: the sample sort that checks for cancellation between pieces and
// the OpenMP loop helper. (How fast a real run stops: Testing/Benchmarks/cancel_latency.sh.)
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <random>
#include <vector>

#include "Algorithms/Core/CancellableSort.h"
#include "Algorithms/Core/Progress.h"

using namespace tetflow;

namespace {

template <class Key, class Make>
void expectSameAsStdSort(size_t n, uint32_t seed, Make make) {
  std::mt19937_64 rng(seed);
  std::vector<Key> keys(n);
  for (auto& k : keys) k = make(rng);
  std::vector<Key> expected = keys;
  std::sort(expected.begin(), expected.end());
  for (int threads : {1, 2, 3}) {
    std::vector<Key> got = keys;
    NullProgress progress;
    omp_set_num_threads(threads);
    cancellableSort(got, progress);
    EXPECT_TRUE(got == expected) << "n=" << n << " seed=" << seed << " threads=" << threads;
  }
  omp_set_num_threads(omp_get_num_procs());
}

} // namespace

TEST(CancellableSort, GivesExactlyWhatStdSortGivesForAnyThreadCount) {
  // Sizes on both sides of the small-input cut-off, uniform keys, few distinct keys (most
  // splitters equal), and sorted / reversed input.
  for (size_t n : {size_t(0), size_t(1), size_t(1000), size_t(300000), size_t(1500000)}) {
    expectSameAsStdSort<uint64_t>(n, 7 + uint32_t(n), [](auto& r) { return r(); });
    expectSameAsStdSort<uint64_t>(n, 11, [](auto& r) { return r() % 5; });
  }
  std::vector<uint64_t> up(2000000);
  for (size_t i = 0; i < up.size(); ++i) up[i] = i / 3;
  std::vector<uint64_t> down(up.rbegin(), up.rend());
  NullProgress progress;
  cancellableSort(down, progress);
  EXPECT_TRUE(down == up);
  cancellableSort(up, progress);
  EXPECT_TRUE(std::is_sorted(up.begin(), up.end()));
}

TEST(CancellableSort, TuplesOfIntegersSortLikeStdSort) {
  expectSameAsStdSort<std::array<int32_t, 3>>(700000, 3, [](auto& r) {
    return std::array<int32_t, 3>{int32_t(r() % 1000), int32_t(r() % 1000), int32_t(r() % 7)};
  });
}

TEST(CancellableSort, ACancelledRunStopsWithCancelledAndLosesNoKey) {
  std::mt19937_64 rng(5);
  std::vector<uint64_t> keys(3000000);
  for (auto& k : keys) k = rng();
  std::vector<uint64_t> sorted = keys;
  std::sort(sorted.begin(), sorted.end());
  NullProgress progress;
  progress.requestCancel();
  EXPECT_THROW(cancellableSort(keys, progress), Cancelled);
  // Stopped at its first piece: the keys are still all there (in some order).
  std::sort(keys.begin(), keys.end());
  EXPECT_TRUE(keys == sorted);
}

TEST(LoopCancel, SkipsTheRestOfAnOpenMpLoopAndRethrowsAfterIt) {
  NullProgress progress;
  LoopCancel cancel(progress);
  std::atomic<int64_t> ran{0};
  const int64_t n = int64_t(1) << 20;
  // Contiguous blocks per thread (as in the code's loops): the thread that asks at i = 100000
  // polls again itself at i = 114688 and stops; the others stop at their next poll. (With small
  // interleaved chunks, schedule(static, 1024), the asking thread never met a multiple of 16 k,
  // and under ASan the other thread could finish first: no poll after the request, no throw.)
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    if (i == 100000) progress.requestCancel();
    if (cancel.skip(i)) continue;
    ++ran;
  }
  EXPECT_THROW(cancel.rethrow(), Cancelled);
  // Every thread stops at its next poll (every 16 k iterations) after the request.
  EXPECT_LT(ran.load(), n);

  NullProgress quiet;
  LoopCancel none(quiet);
  int64_t all = 0;
#pragma omp parallel for reduction(+ : all)
  for (int64_t i = 0; i < n; ++i) {
    if (none.skip(i)) continue;
    ++all;
  }
  EXPECT_NO_THROW(none.rethrow());
  EXPECT_EQ(all, n);
}
