#pragma once
// Progress / cancellation sink for long algorithms (DESIGN §7).
// An algorithm announces named stages, reports a fraction in [0,1] within the current stage, and
// calls checkCancel() at safe points; checkCancel() throws tetflow::Cancelled when cancellation
// was requested. Implementations must be thread-safe: worker threads may call report() and
// checkCancel() concurrently.
#include <atomic>
#include <chrono>
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
  bool cancelRequested() const { return cancel_.load(); }
  void checkCancel() const {
    if (cancel_.load(std::memory_order_relaxed)) throw Cancelled();
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

private:
  std::atomic<bool> cancel_{false};
  std::vector<StageTime> stages_;
  std::string current_;
  bool inStage_ = false;
  std::chrono::steady_clock::time_point start_;
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
