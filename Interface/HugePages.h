#pragma once
// Transparent huge pages for the large arrays of a run (docs/benchmarks.md).
//
// Meshing touches hundreds of megabytes of fresh memory per stage, and on kernels whose
// transparent-huge-page mode is `madvise` (Debian's default) every 4 KiB page of it is a separate
// fault: on the 2-core test machine that alone was a third of the head phantom's run time.
// glibc (>= 2.35) asks for huge pages on its large allocations when the tunable
// `glibc.malloc.hugetlb=1` is set, but reads tunables only at start-up. So, at the very top of
// main(), before any thread exists: when the kernel's mode is `madvise` and the tunable is not
// set yet, set it and exec the same program again with the same arguments. Nothing changes in
// what the program computes. TETFLOW_NO_HUGEPAGES=1 (any value but empty or 0) turns it off; if anything fails (no
// /proc/self/exe, exec refused) the program just goes on without.
namespace tetflow {

void useTransparentHugePages(char** argv);

} // namespace tetflow
