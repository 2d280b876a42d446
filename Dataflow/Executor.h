#pragma once
// Scheduler and executor (DESIGN §3, issue 3).
//
// execute() runs a network in topological order on a pool of worker threads: independent
// branches run in parallel. A module re-runs only when something it depends on changed since its
// last successful run: its parameters, the identity of any input data object, or (for input-file
// parameters) the file's size/modification time; otherwise its earlier outputs are reused. A
// failed module stops everything downstream of it (reported as Skipped, never run). cancel()
// reaches every running module through its Progress sink; modules not yet started are reported as
// Cancelled. Errors carry the module id. The network is copied at the start of execute(), so the
// caller may keep editing it (the GUI does) while a run is in flight.
#include <atomic>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "Network.h"

namespace tetflow {

// Stable values (shown by tools and the GUI).
enum class ModuleStatus : int {
  Idle = 0,      // never executed
  Waiting = 1,   // scheduled, inputs not ready
  Running = 2,
  Done = 3,      // ran (or reused its earlier result) successfully
  Error = 4,     // threw; see ModuleState::error
  Skipped = 5,   // not run because an upstream module failed
  Cancelled = 6
};
const char* moduleStatusName(ModuleStatus s);

struct ModuleState {
  std::string moduleName; // type the state belongs to
  ModuleStatus status = ModuleStatus::Idle;
  bool reused = false;    // last execute() kept the earlier result
  std::vector<DataPtr> outputs;
  Report report;
  std::vector<std::string> messages;
  std::vector<Progress::StageTime> stages;
  std::string error;      // Error: message (starts with the module id)
  std::string errorKind;  // "input", "processing", "internal"
  std::string skippedBecause; // Skipped: id of the failed upstream module
  bool released = false;  // outputs dropped after their last consumer (Options::releaseConsumed)
  // Error from a GateFailure: the outputs were set and go on downstream (the module still failed).
  bool passedOn = false;
  double seconds = 0.0;
  double progress = 0.0;
  int64_t progressReports = 0; // report() calls the module made while observed (progress_benchmark)
  // What the last successful run used (re-execution decisions).
  bool valid = false;
  std::string signature;
  std::vector<uint64_t> inputIds;
};

// Callbacks of one execute(); they run on the executor's threads (and, for onProgress, on a
// module's worker threads), so they must be thread-safe and quick.
struct ExecutionObserver {
  // Every status change: Waiting, Running, then Done / Error / Cancelled (or Done at once for a
  // reused result, Skipped for a module behind a failure).
  std::function<void(const std::string& id, ModuleStatus status)> onStatus;
  // Within a running module: fraction 0 when a stage begins; then, while the stage reports, its
  // highest fraction so far, at most once per 0.1 s and only when it grew; 1 when the stage
  // ends. So within a stage the fractions never decrease, and every stage ends at 1.
  std::function<void(const std::string& id, const std::string& stage, double fraction)> onProgress;
};

class Executor {
public:
  struct Options {
    int threads = 0; // worker threads (and OpenMP threads per module); 0 = all cores
    // Execute these modules and everything downstream of them (plus any upstream module that has
    // no current result). Empty = the whole network.
    std::vector<std::string> only;
    // With `only`: execute those modules and whatever upstream of them has no current result,
    // nothing downstream; a requested module whose result is current is reused, not re-run (the
    // node editor's "Execute up to here": a background's predicted tet count before cleaving).
    bool upstreamOnly = false;
    bool force = false; // re-run even when nothing changed
    // Drop a module's outputs as soon as every module downstream of it in this run has finished
    // (the headless runner: a run's peak memory then holds only what is still to be consumed).
    // Such a module is left without a current result (ModuleState::released), so a later
    // execute() runs it again. Outputs nothing in the run consumes are kept.
    bool releaseConsumed = false;
  };
  struct Summary {
    bool success = true;
    int ran = 0, reused = 0, failed = 0, skipped = 0, cancelled = 0;
    double seconds = 0.0;
    std::vector<std::string> order; // modules in the order they finished
  };

  Summary execute(const Network& net, const Options& options, const ExecutionObserver& obs = {});
  Summary execute(const Network& net) { return execute(net, Options{}); }
  // Thread-safe; may be called from any thread (signal watcher, GUI) while execute() runs.
  void cancel();
  bool running() const { return running_.load(); }

  // State after the last execution (nullptr for an unknown id). Not to be read while running.
  const ModuleState* state(const std::string& id) const;
  // Forget all results (next execute() runs everything).
  void reset();

private:
  mutable std::mutex mutex_;
  std::map<std::string, ModuleState> states_;
  std::atomic<bool> cancel_{false};
  std::atomic<bool> running_{false};
  std::vector<Progress*> active_; // guarded by mutex_
};

} // namespace tetflow
