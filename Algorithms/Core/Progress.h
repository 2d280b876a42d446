#pragma once
// Progress / cancellation sink for long algorithms (DESIGN §7).
// An algorithm announces named stages, reports a fraction in [0,1] within the current stage, and
// calls checkCancel() at safe points; checkCancel() throws tetflow::Cancelled when cancellation
// was requested. Implementations must be thread-safe: worker threads may call report() and
// checkCancel() concurrently.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include "Errors.h"

namespace tetflow {

class Progress {
public:
  virtual ~Progress() = default;
  // Start a named stage; ends the previous one (its time is recorded).
  void beginStage(const std::string& name);
  // Finish the current stage (also done by the next beginStage or by finish()).
  void endStage();
  // Fraction done within the current stage, 0..1.
  void report(double fraction) { onReport(fraction); }
  void requestCancel() { cancel_.store(true); }
  // (The default arguments name the caller's source line, for the diagnostic below; the
  // builtins work in g++ and clang 14, which lacks std::source_location.)
  bool cancelRequested(const char* file = __builtin_FILE(), unsigned line = __builtin_LINE()) const {
    noteCheck(file, line);
    return cancel_.load();
  }
  void checkCancel(const char* file = __builtin_FILE(), unsigned line = __builtin_LINE()) const {
    noteCheck(file, line);
    if (cancel_.load(std::memory_order_relaxed)) throw Cancelled();
  }
  // checkCancel() when i is a multiple of 2^log2Stride: for serial loops, `checkCancelEvery(t)`
  // checks once per 2^20 iterations.
  void checkCancelEvery(int64_t i, int log2Stride = 20, const char* file = __builtin_FILE(),
                        unsigned line = __builtin_LINE()) const {
    if ((i & ((int64_t(1) << log2Stride) - 1)) == 0) checkCancel(file, line);
  }

  struct StageTime {
    std::string name;
    double seconds = 0.0;
  };
  // Completed stages with their wall time, in order.
  const std::vector<StageTime>& stageTimes() const { return stages_; }

protected:
  virtual void onStage(const std::string& /*name*/) {}
  virtual void onReport(double /*fraction*/) {}
  // The current stage ended (endStage, the next beginStage, or the module's end).
  virtual void onStageEnd(const std::string& /*name*/, double /*seconds*/) {}

private:
  // Diagnostic for the cancellation promise (docs/reliability.md): with the environment variable
  // TETFLOW_CANCEL_GAPS set, every stage prints to stderr the longest wall-clock stretch in which
  // no thread checked for cancellation (from the stage's start to its end), and the two checks
  // (source lines) around it. That stretch bounds how long a Ctrl-C waits in the stage. Off by
  // default; costs one relaxed load per check.
  static bool gapTracing() { return gapTracing_.load(std::memory_order_relaxed); }
  void noteCheck(const char* file, unsigned line) const {
    if (gapTracing()) recordCheck(file, line);
  }
  void recordCheck(const char* file, unsigned line) const;
  void reportGap() const;

  static std::atomic<bool> gapTracing_;
  struct Where {
    const char* file = nullptr;
    uint32_t line = 0;
  };
  // Diagnostic state, used only while tracing (so a mutex is fine).
  mutable std::mutex traceMutex_;
  mutable int64_t lastCheckNs_ = 0; // steady clock, ns
  mutable int64_t maxGapNs_ = 0;
  mutable Where lastWhere_, gapFrom_, gapTo_;
  std::atomic<bool> cancel_{false};
  std::vector<StageTime> stages_;
  std::string current_;
  bool inStage_ = false;
  std::chrono::steady_clock::time_point start_;
};

// Cancellation inside an OpenMP loop, whose body must not throw: `if (c.skip(i)) continue;` at the
// top of the body polls the progress every 16 k iterations (`c.skip()`: every iteration) and, once
// cancellation is seen, skips the rest; `c.rethrow()` after the loop throws Cancelled. skip(i)
// polls where i is a multiple of 16384, so use it with schedule(static) or chunks handed out in
// order (dynamic): with small interleaved static chunks a thread may never meet such an i.
class LoopCancel {
public:
  explicit LoopCancel(const Progress& p, const char* file = __builtin_FILE(),
                      unsigned line = __builtin_LINE())
      : p_(p), file_(file), line_(line) {}
  bool skip(int64_t i) {
    if ((i & 0x3fff) == 0 && p_.cancelRequested(file_, line_)) stop_.store(true, std::memory_order_relaxed);
    return stop_.load(std::memory_order_relaxed);
  }
  // Polls every time: for loops whose iterations are large (blocks, local searches).
  bool skip() {
    if (p_.cancelRequested(file_, line_)) stop_.store(true, std::memory_order_relaxed);
    return stop_.load(std::memory_order_relaxed);
  }
  void rethrow() const {
    if (stop_.load()) throw Cancelled();
  }

private:
  const Progress& p_;
  const char* file_; // where the loop is (for the TETFLOW_CANCEL_GAPS diagnostic)
  unsigned line_;
  std::atomic<bool> stop_{false};
};

// A sink that only records stage times and honours cancellation.
class NullProgress : public Progress {};

// The progress sink of the module running on this thread (set by the executor for the duration
// of a module), or nullptr. Lets deep helpers that have no Progress parameter honour
// cancellation: an atomic output file checks it before it replaces its target, so a cancelled
// run never replaces an old output.
Progress* currentProgress();
class ScopedCurrentProgress {
public:
  explicit ScopedCurrentProgress(Progress* p);
  ~ScopedCurrentProgress();
  ScopedCurrentProgress(const ScopedCurrentProgress&) = delete;
  ScopedCurrentProgress& operator=(const ScopedCurrentProgress&) = delete;

private:
  Progress* previous_;
};

} // namespace tetflow
