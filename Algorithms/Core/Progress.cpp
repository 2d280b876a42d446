#include "Progress.h"

namespace tetflow {

void Progress::beginStage(const std::string& name) {
  endStage();
  current_ = name;
  inStage_ = true;
  start_ = std::chrono::steady_clock::now();
  onStage(name);
}

void Progress::endStage() {
  if (!inStage_) return;
  const auto now = std::chrono::steady_clock::now();
  stages_.push_back({current_, std::chrono::duration<double>(now - start_).count()});
  inStage_ = false;
}

namespace {
thread_local Progress* tCurrent = nullptr;
}

Progress* currentProgress() { return tCurrent; }
ScopedCurrentProgress::ScopedCurrentProgress(Progress* p) : previous_(tCurrent) { tCurrent = p; }
ScopedCurrentProgress::~ScopedCurrentProgress() { tCurrent = previous_; }

} // namespace tetflow
