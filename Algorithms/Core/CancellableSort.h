#pragma once
// Sorting large arrays of integer keys on all OpenMP threads, in pieces that each take a small
// fraction of a second, with a cancellation check between pieces (docs/reliability.md: a
// cancelled run stops within a second; one uninterruptible sort of 22 M keys took a whole one).
//
// A sample sort: splitters drawn from evenly spaced keys cut the key range into buckets of
// similar size; keys are scattered into their buckets (each thread a fixed block of the input,
// so positions do not depend on timing), and the buckets are sorted independently. For keys whose
// order is total (equal means identical: integers, tuples of integers) the result is exactly
// what std::sort gives, for any thread count.
// Extra memory: one copy of the keys (as a parallel merge sort needs too). A cancelled sort
// leaves `keys` in no particular order.
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "Progress.h"

namespace tetflow {

template <class Key>
void cancellableSort(std::vector<Key>& keys, const Progress& progress) {
  const size_t n = keys.size();
  constexpr size_t kSmall = size_t(1) << 18; // below this one std::sort takes a few ms
  if (n <= kSmall) {
    std::sort(keys.begin(), keys.end());
    progress.checkCancel();
    return;
  }
  // Splitters: about 64 k keys per bucket, from 8 evenly spaced samples per bucket.
  const size_t buckets = std::min<size_t>(4096, n / (size_t(1) << 16) + 1);
  std::vector<Key> sample;
  sample.reserve(8 * buckets);
  for (size_t i = 0; i < 8 * buckets; ++i) sample.push_back(keys[i * (n / (8 * buckets))]);
  std::sort(sample.begin(), sample.end());
  std::vector<Key> split; // bucket b holds keys k with split[b-1] < k <= split[b]
  for (size_t b = 1; b < buckets; ++b) split.push_back(sample[b * 8 - 1]);
  split.erase(std::unique(split.begin(), split.end(),
                          [](const Key& a, const Key& b) { return !(a < b) && !(b < a); }),
              split.end());
  const size_t nb = split.size() + 1;
  auto bucketOf = [&split](const Key& k) {
    return static_cast<size_t>(std::lower_bound(split.begin(), split.end(), k) - split.begin());
  };

  // Fixed input blocks of a copy of the keys; count per (block, bucket), then scatter back into
  // `keys` at prefix offsets. (The copy is not zeroed first: its pages are touched by the threads
  // that fill it.)
  constexpr size_t kBlock = size_t(1) << 20;
  const size_t blocks = (n + kBlock - 1) / kBlock;
  // body(block, first, last) for every block, on all threads, cancellable between blocks.
  auto forEachBlock = [&](auto&& body) {
    LoopCancel cancel(progress);
#pragma omp parallel for schedule(dynamic, 1)
    for (int64_t blk = 0; blk < static_cast<int64_t>(blocks); ++blk) {
      if (cancel.skip()) continue;
      const size_t lo = size_t(blk) * kBlock;
      body(size_t(blk), lo, std::min(n, lo + kBlock));
    }
    cancel.rethrow();
  };
  const auto copy = std::make_unique_for_overwrite<Key[]>(n);
  std::vector<int64_t> count(blocks * nb, 0);
  forEachBlock([&](size_t blk, size_t lo, size_t hi) {
    int64_t* c = &count[blk * nb];
    for (size_t i = lo; i < hi; ++i) {
      copy[i] = keys[i];
      ++c[bucketOf(keys[i])];
    }
  });
  std::vector<int64_t> start(nb + 1, 0); // bucket starts
  std::vector<int64_t> at(blocks * nb);  // where each block writes into each bucket
  {
    int64_t pos = 0;
    for (size_t b = 0; b < nb; ++b) {
      start[b] = pos;
      for (size_t blk = 0; blk < blocks; ++blk) {
        at[blk * nb + b] = pos;
        pos += count[blk * nb + b];
      }
    }
    start[nb] = pos;
  }
  forEachBlock([&](size_t blk, size_t lo, size_t hi) {
    int64_t* w = &at[blk * nb];
    for (size_t i = lo; i < hi; ++i) keys[size_t(w[bucketOf(copy[i])]++)] = copy[i];
  });
  LoopCancel sortCancel(progress);
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t b = 0; b < static_cast<int64_t>(nb); ++b) {
    if (sortCancel.skip()) continue;
    std::sort(keys.begin() + start[size_t(b)], keys.begin() + start[size_t(b) + 1]);
  }
  sortCancel.rethrow();
}

// Sorts each bucket [first + start[b], first + start[b + 1]) of a counting sort (start: nb + 1
// offsets) on every thread; throws Cancelled when progress asks.
template <class It>
void sortEachBucket(It first, const std::vector<int64_t>& start, const Progress& progress) {
  const int64_t buckets = static_cast<int64_t>(start.size()) - 1;
  LoopCancel cancel(progress);
#pragma omp parallel for schedule(dynamic, 4096)
  for (int64_t b = 0; b < buckets; ++b) {
    if (cancel.skip(b)) continue;
    std::sort(first + start[size_t(b)], first + start[size_t(b) + 1]);
  }
  cancel.rethrow();
}

// A counting sort into buckets: records(i, emit) calls emit(bucket, value) for each record of item
// i (the same records every time it is called); list[start[b] .. start[b + 1]) then holds bucket
// b's values, sorted (T's operator<, a total order, so the result does not depend on which thread
// filed what). Counted and filled on every thread (atomic counters); throws Cancelled when
// progress asks.
template <class T, class Records>
void fileByBucket(int64_t n, size_t buckets, Records records, std::vector<int64_t>& start, std::vector<T>& list,
                  const Progress& progress) {
  start.assign(buckets + 1, 0);
  LoopCancel countCancel(progress);
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    if (countCancel.skip(i)) continue;
    records(i, [&](int64_t b, const T&) {
      std::atomic_ref<int64_t>(start[size_t(b) + 1]).fetch_add(1, std::memory_order_relaxed);
    });
  }
  countCancel.rethrow();
  for (size_t b = 0; b < buckets; ++b) start[b + 1] += start[b];
  list.resize(static_cast<size_t>(start[buckets]));
  {
    std::vector<int64_t> fill(start.begin(), start.end() - 1);
    LoopCancel fillCancel(progress);
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < n; ++i) {
      if (fillCancel.skip(i)) continue;
      records(i, [&](int64_t b, const T& value) {
        list[size_t(std::atomic_ref<int64_t>(fill[size_t(b)]).fetch_add(1, std::memory_order_relaxed))] = value;
      });
    }
    fillCancel.rethrow();
  }
  sortEachBucket(list.begin(), start, progress);
}

} // namespace tetflow
