#pragma once
// Live progress of one run, as the headless runner shows it (docs/headless.md, issue 29):
// which modules are running, their stage, the stage's fraction, how long they have run and, where
// the stage reports fractions, an estimate of what is left of it. Fed by an ExecutionObserver
// (the events are already throttled by the executor); read by the terminal's live lines and by
// the `--progress jsonl` stream. Thread-safe. No terminal code here: that is the runner's.
#include <chrono>
#include <cstdio>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "Executor.h"

namespace tetflow {

class RunProgress {
public:
  using Clock = std::chrono::steady_clock;
  explicit RunProgress(Clock::time_point start = Clock::now()) : start_(start) {}

  struct Entry {
    std::string id, name, stage;
    double fraction = 0.0;        // of the current stage
    bool fractionKnown = false;   // the stage reported a fraction above 0
    double seconds = 0.0;         // since the module started
    double stageSeconds = 0.0;    // since the stage began
    double secondsLeft = -1.0;    // estimate for the rest of the stage; < 0: the stage cannot tell
  };

  void started(const std::string& id, const std::string& name, Clock::time_point now = Clock::now());
  void progress(const std::string& id, const std::string& stage, double fraction,
                Clock::time_point now = Clock::now());
  void ended(const std::string& id);
  // One running module's state; nullopt when it is not running.
  std::optional<Entry> entry(const std::string& id, Clock::time_point now = Clock::now()) const;
  // The running modules, in the order they started.
  std::vector<Entry> running(Clock::time_point now = Clock::now()) const;
  double sinceStart(Clock::time_point now = Clock::now()) const {
    return std::chrono::duration<double>(now - start_).count();
  }

private:
  struct State {
    std::string name, stage;
    uint64_t order = 0;
    Clock::time_point started, stageStarted, reported;
    double fraction = 0.0;
  };
  Entry entryOf(const std::string& id, const State& s, Clock::time_point now) const;

  Clock::time_point start_;
  mutable std::mutex mutex_;
  std::map<std::string, State> states_;
  uint64_t nextOrder_ = 0;
};

// The terminal's live line of a running module, at most `width` characters (0: no limit):
//   m3    CleaveMesh             running   12.3 s  stencil 45 % (~15 s left)
std::string liveProgressLine(const RunProgress::Entry& e, size_t width = 0);
// Its stage part: "stencil 45 % (~15 s left)"; the percent only where the stage reports one, the
// estimate only where it can be made; empty before the module's first stage.
std::string liveStageText(const RunProgress::Entry& e);

// `--progress jsonl`: one JSON object per line for each event of a run, flushed as it is
// written (docs/headless.md lists the fields). Thread-safe.
class JsonlProgressWriter {
public:
  JsonlProgressWriter(std::FILE* out, const RunProgress& board) : out_(out), board_(board) {}
  void start(const std::string& id, const std::string& name);
  void progress(const std::string& id, const std::string& stage, double fraction);
  // status: done, reused, error, cancelled, skipped.
  void end(const std::string& id, const std::string& name, const std::string& status, double seconds);
  void finish(const Executor::Summary& sum);

private:
  void write(const std::string& line);
  std::FILE* out_;
  const RunProgress& board_;
  std::mutex mutex_;
};

} // namespace tetflow
