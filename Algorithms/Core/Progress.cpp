#include "Progress.h"

#include <cstdio>
#include <cstdlib>
#include <string>

namespace tetflow {

namespace {
int64_t steadyNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}
} // namespace

std::atomic<bool> Progress::gapTracing_{std::getenv("TETFLOW_CANCEL_GAPS") != nullptr};

void Progress::recordCheck(const char* file, unsigned line) const {
  const int64_t now = steadyNs();
  const Where here{file, line};
  const std::lock_guard<std::mutex> lock(traceMutex_);
  if (lastCheckNs_ != 0 && now - lastCheckNs_ > maxGapNs_) {
    maxGapNs_ = now - lastCheckNs_;
    gapFrom_ = lastWhere_;
    gapTo_ = here;
  }
  lastCheckNs_ = now;
  lastWhere_ = here;
}

void Progress::reportGap() const {
  // The stretch from the last check to the stage's end counts too.
  recordCheck(__FILE__, __LINE__);
  auto name = [](const Where& w) {
    if (!w.file) return std::string("stage start");
    std::string f = w.file;
    const size_t slash = f.find_last_of('/');
    if (slash != std::string::npos) f = f.substr(slash + 1);
    return f + ":" + std::to_string(w.line);
  };
  const std::lock_guard<std::mutex> lock(traceMutex_);
  std::fprintf(stderr, "cancel-gap  %-28s %8.3f s  (%s -> %s)\n", current_.c_str(),
               static_cast<double>(maxGapNs_) * 1e-9, name(gapFrom_).c_str(), name(gapTo_).c_str());
}

void Progress::beginStage(const std::string& name) {
  endStage();
  current_ = name;
  inStage_ = true;
  start_ = std::chrono::steady_clock::now();
  if (gapTracing()) {
    const std::lock_guard<std::mutex> lock(traceMutex_);
    lastCheckNs_ = steadyNs();
    maxGapNs_ = 0;
    lastWhere_ = gapFrom_ = gapTo_ = Where{};
  }
  onStage(name);
}

void Progress::endStage() {
  if (!inStage_) return;
  if (gapTracing()) reportGap();
  const auto now = std::chrono::steady_clock::now();
  stages_.push_back({current_, std::chrono::duration<double>(now - start_).count()});
  inStage_ = false;
  onStageEnd(current_, stages_.back().seconds);
}

namespace {
thread_local Progress* tCurrent = nullptr;
}

Progress* currentProgress() { return tCurrent; }
ScopedCurrentProgress::ScopedCurrentProgress(Progress* p) : previous_(tCurrent) { tCurrent = p; }
ScopedCurrentProgress::~ScopedCurrentProgress() { tCurrent = previous_; }

} // namespace tetflow
