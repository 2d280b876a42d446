#pragma once
// Memory checked before it is spent (docs/reliability.md). A stage whose memory grows with a
// parameter estimates its peak from sizes it knows before allocating (lattice cells, background
// tets, samples, mesh tets) and calls requireMemory(). The budget is what this process may still
// take: the machine's available memory (MemAvailable, and a cgroup's memory.max less its usage
// when lower), or, when a limit is set (`tetflow run --max-memory`), that limit less what the
// process already holds (resident set), whichever is smaller. Over budget is an InputError that
// names the parameter, the estimate, the budget and a value that fits, e.g.
//   "cell_size 0.05 mm would need ~180 GB (bytes per background tet x tets); 21 GB available;
//    use cell_size >= 0.4"
// The estimates are per stage and measured (the figures are in each caller, with the input they
// were measured on); they aim a little high, so a refusal is never wrong by a large factor.
#include <cstdint>
#include <functional>
#include <string>

namespace tetflow {

// Bytes this process may still allocate (see above). Never negative.
int64_t memoryAvailable();
// The limit set by setMemoryLimit (0 = none: the machine's memory only). Process-wide.
void setMemoryLimit(int64_t bytes);
int64_t memoryLimit();
// Resident set of this process in bytes (0 if unknown).
int64_t residentBytes();

// "512M", "8G", "1.5 GB", "2048" (bytes), "64 MiB" -> bytes; InputError naming `what` otherwise.
int64_t parseMemorySize(const std::string& text, const std::string& what);
// 1536 -> "1.5 KB", 2.5e9 -> "2.3 GB" (binary units, two significant digits at most).
std::string formatBytes(double bytes);

// Throws InputError "<what> would need ~<bytes>; <available> available[ (limit ...)]; <fix(available)>"
// when `bytes` exceeds memoryAvailable(). `fix` gets the available bytes and returns the advice
// (e.g. "use cell_size >= 0.4"); it may be empty.
// Before refusing, requireMemory() asks every registered reclaimer to let go of what it keeps
// for reuse (SolverCache.h: the last Cholesky factor) and measures again. A reclaimer returns
// true when it freed something; it must not call requireMemory().
void requireMemory(double bytes, const std::string& what, const std::function<std::string(double)>& fix);
void addMemoryReclaimer(std::function<bool()> release);
bool reclaimMemory(); // runs every reclaimer now; true when one freed something

// Rounds a suggested lower bound up / upper bound down to two significant digits, so the printed
// value is on the safe side.
double roundUpForAdvice(double x);
double roundDownForAdvice(double x);

} // namespace tetflow
