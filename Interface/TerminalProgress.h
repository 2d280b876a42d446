#pragma once
// The headless runner's live lines on a terminal (docs/headless.md, issue 29): one line
// per running module (once it has run a quarter of a second) below everything printed so far, redrawn in place five times a second by a
// thread of its own; lines printed through above() appear above them, so a module's summary line
// replaces its live line when it ends. Only for a terminal that moves its cursor (isatty, TERM not
// "dumb"); the runner does not create one otherwise, so logs and pipes see no escape codes.
#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "Dataflow/RunProgress.h"

namespace tetflow {

class TerminalProgress {
public:
  // fd is a terminal that understands cursor movement.
  static bool usable(int fd);
  TerminalProgress(const RunProgress& board, int fd);
  ~TerminalProgress(); // stop()
  TerminalProgress(const TerminalProgress&) = delete;
  TerminalProgress& operator=(const TerminalProgress&) = delete;

  // Erases the live lines, runs print (which writes its lines to stdout or stderr), flushes
  // both, and draws the live lines again below. Thread-safe.
  void above(const std::function<void()>& print);
  // Stops redrawing and erases the live lines (idempotent).
  void stop();
  // Redraws so far, and the time they took (Testing/Benchmarks/progress_benchmark).
  int64_t redraws() const { return redraws_.load(); }
  double redrawSeconds() const { return double(redrawNs_.load()) * 1e-9; }

private:
  void loop();
  std::string eraseText() const; // needs mutex_
  std::string drawText();        // needs mutex_; sets shown_
  void put(const std::string& s) const;

  const RunProgress& board_;
  int fd_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  size_t shown_ = 0; // live lines on screen now
  std::atomic<int64_t> redraws_{0}, redrawNs_{0};
  std::thread thread_;
};

} // namespace tetflow
