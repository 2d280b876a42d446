#pragma once
// Wall-clock seconds of a stage (steady clock), for the *Seconds figures of results and reports.
#include <chrono>

namespace tetflow {

inline double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

} // namespace tetflow
