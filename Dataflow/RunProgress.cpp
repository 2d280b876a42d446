#include "RunProgress.h"

#include <algorithm>
#include <cmath>

#include "RunReport.h"

namespace tetflow {

namespace {
double secondsBetween(RunProgress::Clock::time_point a, RunProgress::Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}
} // namespace

void RunProgress::started(const std::string& id, const std::string& name, Clock::time_point now) {
  const std::lock_guard<std::mutex> lock(mutex_);
  State& s = states_[id];
  s = State{};
  s.name = name;
  s.order = nextOrder_++;
  s.started = s.stageStarted = s.reported = now;
}

void RunProgress::progress(const std::string& id, const std::string& stage, double fraction,
                           Clock::time_point now) {
  const std::lock_guard<std::mutex> lock(mutex_);
  auto it = states_.find(id);
  if (it == states_.end()) return;
  State& s = it->second;
  if (fraction <= 0.0 || stage != s.stage) s.stageStarted = now; // a stage begins (the executor sends 0)
  s.stage = stage;
  s.fraction = std::clamp(fraction, 0.0, 1.0);
  s.reported = now;
}

void RunProgress::ended(const std::string& id) {
  const std::lock_guard<std::mutex> lock(mutex_);
  states_.erase(id);
}

RunProgress::Entry RunProgress::entryOf(const std::string& id, const State& s, Clock::time_point now) const {
  Entry e;
  e.id = id;
  e.name = s.name;
  e.stage = s.stage;
  e.fraction = s.fraction;
  e.fractionKnown = s.fraction > 0.0;
  e.seconds = std::max(0.0, secondsBetween(s.started, now));
  e.stageSeconds = std::max(0.0, secondsBetween(s.stageStarted, now));
  // The stage's rate so far, from its start to its last report, carried on to its end. Only once
  // there is something to go by: 1 % done and half a second of it.
  const double sofar = secondsBetween(s.stageStarted, s.reported);
  if (s.fraction >= 0.01 && s.fraction < 1.0 && sofar >= 0.5) {
    const double left = sofar * (1.0 - s.fraction) / s.fraction - secondsBetween(s.reported, now);
    if (left >= 0.5) e.secondsLeft = left;
  }
  return e;
}

std::optional<RunProgress::Entry> RunProgress::entry(const std::string& id, Clock::time_point now) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  auto it = states_.find(id);
  if (it == states_.end()) return std::nullopt;
  return entryOf(id, it->second, now);
}

std::vector<RunProgress::Entry> RunProgress::running(Clock::time_point now) const {
  std::vector<std::pair<uint64_t, Entry>> all;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [id, s] : states_) all.emplace_back(s.order, entryOf(id, s, now));
  }
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<Entry> out;
  for (auto& [order, e] : all) out.push_back(std::move(e));
  return out;
}

namespace {
std::string durationText(double s) {
  char b[32];
  if (s < 100) std::snprintf(b, sizeof b, "%.0f s", s);
  else if (s < 6000) std::snprintf(b, sizeof b, "%.0f min", s / 60);
  else std::snprintf(b, sizeof b, "%.1f h", s / 3600);
  return b;
}
} // namespace

std::string liveStageText(const RunProgress::Entry& e) {
  if (e.stage.empty()) return "";
  std::string t = e.stage;
  if (e.fractionKnown) {
    t += ' ';
    t += std::to_string(int(std::floor(e.fraction * 100)));
    t += " %";
  }
  if (e.secondsLeft >= 0) {
    t += " (~";
    t += durationText(e.secondsLeft);
    t += " left)";
  }
  return t;
}

std::string liveProgressLine(const RunProgress::Entry& e, size_t width) {
  char head[192];
  std::snprintf(head, sizeof head, "%-5s %-22s running %7.1f s", e.id.c_str(), e.name.c_str(), e.seconds);
  std::string line = head;
  if (!e.stage.empty()) line += "  " + liveStageText(e);
  if (width > 0 && line.size() > width) {
    size_t cut = width;
    while (cut > 0 && (static_cast<unsigned char>(line[cut]) & 0xC0) == 0x80) --cut; // whole UTF-8 characters
    line.resize(cut);
  }
  return line;
}

namespace {
std::string num(double v, const char* fmt = "%.3f") {
  if (!std::isfinite(v)) return "null";
  char b[48];
  std::snprintf(b, sizeof b, fmt, v);
  return b;
}
} // namespace

void JsonlProgressWriter::write(const std::string& line) {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::fputs(line.c_str(), out_);
  std::fputc('\n', out_);
  std::fflush(out_);
}

void JsonlProgressWriter::start(const std::string& id, const std::string& name) {
  write("{\"event\": \"start\", \"t\": " + num(board_.sinceStart()) + ", \"module\": " + jsonEscape(id) +
        ", \"name\": " + jsonEscape(name) + "}");
}

void JsonlProgressWriter::progress(const std::string& id, const std::string& stage, double fraction) {
  const auto now = RunProgress::Clock::now();
  const auto e = board_.entry(id, now);
  std::string line = "{\"event\": \"progress\", \"t\": " + num(board_.sinceStart(now)) +
                     ", \"module\": " + jsonEscape(id) + ", \"name\": " + jsonEscape(e ? e->name : "") +
                     ", \"stage\": " + jsonEscape(stage) + ", \"fraction\": " + num(fraction, "%.4f");
  if (e) {
    line += ", \"elapsed\": " + num(e->seconds) + ", \"stage_elapsed\": " + num(e->stageSeconds);
    if (e->secondsLeft >= 0) line += ", \"stage_left\": " + num(e->secondsLeft, "%.1f");
  }
  write(line + "}");
}

void JsonlProgressWriter::end(const std::string& id, const std::string& name, const std::string& status,
                              double seconds) {
  write("{\"event\": \"end\", \"t\": " + num(board_.sinceStart()) + ", \"module\": " + jsonEscape(id) +
        ", \"name\": " + jsonEscape(name) + ", \"status\": " + jsonEscape(status) +
        ", \"elapsed\": " + num(seconds) + "}");
}

void JsonlProgressWriter::finish(const Executor::Summary& sum) {
  write("{\"event\": \"finish\", \"t\": " + num(board_.sinceStart()) +
        ", \"success\": " + (sum.success ? "true" : "false") + ", \"ran\": " + std::to_string(sum.ran) +
        ", \"reused\": " + std::to_string(sum.reused) + ", \"failed\": " + std::to_string(sum.failed) +
        ", \"skipped\": " + std::to_string(sum.skipped) + ", \"cancelled\": " + std::to_string(sum.cancelled) +
        ", \"seconds\": " + num(sum.seconds) + "}");
}

} // namespace tetflow
