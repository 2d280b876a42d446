#include "MemoryBudget.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <sstream>
#include <vector>
#include <unistd.h>

#include "Errors.h"

namespace tetflow {

namespace {

std::atomic<int64_t> gLimit{0};

// A number from a one-line file (cgroup v2), or -1 ("max" or missing).
int64_t readNumberFile(const char* path) {
  std::ifstream in(path);
  std::string s;
  if (!(in >> s) || s == "max") return -1;
  try {
    return std::stoll(s);
  } catch (...) {
    return -1;
  }
}

int64_t machineAvailable() {
  int64_t avail = -1;
  std::ifstream in("/proc/meminfo");
  std::string key;
  int64_t kb = 0;
  std::string unit;
  while (in >> key >> kb) {
    std::getline(in, unit);
    if (key == "MemAvailable:") {
      avail = kb * 1024;
      break;
    }
  }
  if (avail < 0) {
    const long pages = sysconf(_SC_AVPHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    avail = pages > 0 && page > 0 ? int64_t(pages) * page : (int64_t(1) << 62);
  }
  const int64_t cgMax = readNumberFile("/sys/fs/cgroup/memory.max");
  const int64_t cgNow = readNumberFile("/sys/fs/cgroup/memory.current");
  if (cgMax > 0 && cgNow >= 0) avail = std::min(avail, std::max<int64_t>(0, cgMax - cgNow));
  return std::max<int64_t>(0, avail);
}

double roundTo2(double x, bool up) {
  if (!(x > 0) || !std::isfinite(x)) return x;
  const double p = std::pow(10.0, std::floor(std::log10(x)) - 1);
  return (up ? std::ceil(x / p - 1e-9) : std::floor(x / p + 1e-9)) * p;
}

} // namespace

int64_t residentBytes() {
  std::ifstream in("/proc/self/statm");
  int64_t size = 0, resident = 0;
  if (!(in >> size >> resident)) return 0;
  return resident * int64_t(sysconf(_SC_PAGESIZE));
}

void setMemoryLimit(int64_t bytes) { gLimit = std::max<int64_t>(0, bytes); }
int64_t memoryLimit() { return gLimit; }

int64_t memoryAvailable() {
  int64_t a = machineAvailable();
  if (const int64_t lim = gLimit; lim > 0) a = std::min(a, std::max<int64_t>(0, lim - residentBytes()));
  return a;
}

int64_t parseMemorySize(const std::string& text, const std::string& what) {
  size_t i = 0;
  double v = 0;
  try {
    v = std::stod(text, &i);
  } catch (...) {
    i = 0;
  }
  std::string unit;
  for (size_t k = i; k < text.size(); ++k)
    if (!std::isspace(static_cast<unsigned char>(text[k])))
      unit.push_back(static_cast<char>(std::toupper(static_cast<unsigned char>(text[k]))));
  double scale = -1;
  if (unit.empty() || unit == "B") scale = 1;
  else if (unit == "K" || unit == "KB" || unit == "KIB") scale = 1024.0;
  else if (unit == "M" || unit == "MB" || unit == "MIB") scale = 1024.0 * 1024;
  else if (unit == "G" || unit == "GB" || unit == "GIB") scale = 1024.0 * 1024 * 1024;
  else if (unit == "T" || unit == "TB" || unit == "TIB") scale = 1024.0 * 1024 * 1024 * 1024;
  if (i == 0 || scale < 0 || !(v > 0) || !std::isfinite(v) || v * scale > 9.0e18)
    throw InputError(what + " '" + text + "' is not a memory size; use e.g. 512M, 8G or 1.5GB (> 0)");
  return int64_t(std::llround(v * scale));
}

std::string formatBytes(double bytes) {
  const char* units[] = {"bytes", "KB", "MB", "GB", "TB", "PB", "EB"};
  int u = 0;
  while (bytes >= 1024.0 && u < 6) {
    bytes /= 1024.0;
    ++u;
  }
  char buf[64];
  if (u == 0) std::snprintf(buf, sizeof buf, "%.0f %s", bytes, units[u]);
  else std::snprintf(buf, sizeof buf, bytes < 10 ? "%.1f %s" : "%.0f %s", bytes, units[u]);
  return buf;
}

namespace {
std::mutex gReclaimMutex;
std::vector<std::function<bool()>>& reclaimers() {
  static std::vector<std::function<bool()>> r;
  return r;
}
} // namespace

void addMemoryReclaimer(std::function<bool()> release) {
  std::lock_guard<std::mutex> lock(gReclaimMutex);
  reclaimers().push_back(std::move(release));
}

bool reclaimMemory() {
  std::vector<std::function<bool()>> r;
  {
    std::lock_guard<std::mutex> lock(gReclaimMutex);
    r = reclaimers();
  }
  bool freed = false;
  for (const auto& f : r) freed = f() || freed;
  return freed;
}

void requireMemory(double bytes, const std::string& what, const std::function<std::string(double)>& fix) {
  int64_t avail = memoryAvailable();
  if (bytes <= double(avail)) return;
  if (reclaimMemory()) { // a cache let go of what it kept: measure again
    avail = memoryAvailable();
    if (bytes <= double(avail)) return;
  }
  std::ostringstream m;
  m << what << " would need ~" << formatBytes(bytes) << "; " << formatBytes(double(avail)) << " available";
  if (const int64_t lim = gLimit; lim > 0) m << " (limit " << formatBytes(double(lim)) << ", from --max-memory or the GUI's memory limit)";
  const std::string advice = fix ? fix(double(avail)) : std::string();
  if (!advice.empty()) m << "; " << advice;
  throw InputError(m.str());
}

double roundUpForAdvice(double x) { return roundTo2(x, true); }
double roundDownForAdvice(double x) { return roundTo2(x, false); }

} // namespace tetflow
