#pragma once
// Small modules for Dataflow tests: they count executions, record concurrency, fail or wait for
// cancellation on request. Registered in a test registry next to the standard modules.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <string>
#include <thread>

#include "Dataflow/ModuleRegistry.h"
#include "Modules/StandardModules.h"

namespace tetflow::test {

struct Counters {
  std::mutex m;
  std::map<std::string, int> runs; // module id -> executions
  std::atomic<int> running{0};
  std::atomic<int> maxRunning{0};
  void ran(const std::string& id) {
    std::lock_guard<std::mutex> l(m);
    ++runs[id];
  }
  int count(const std::string& id) {
    std::lock_guard<std::mutex> l(m);
    return runs[id];
  }
  void clear() {
    std::lock_guard<std::mutex> l(m);
    runs.clear();
    maxRunning = 0;
  }
};
inline Counters& counters() {
  static Counters c;
  return c;
}

// "Number": outputs a Report {value: param value + sum of input values}. Params: value (double),
// fail (bool: throw InputError), wait_for_peers (int: wait up to 5 s until that many modules run
// at once, to observe parallelism), wait_for_cancel (bool: loop until cancelled, max 10 s).
class NumberModule : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    counters().ran(ctx.moduleId());
    const int now = ++counters().running;
    int prev = counters().maxRunning.load();
    while (now > prev && !counters().maxRunning.compare_exchange_weak(prev, now)) {}
    struct Dec { ~Dec() { --counters().running; } } dec;
    const auto t0 = std::chrono::steady_clock::now();
    const int64_t peers = ctx.getInt("wait_for_peers");
    while (peers > 0 && counters().maxRunning.load() < peers &&
           std::chrono::steady_clock::now() - t0 < std::chrono::seconds(5))
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    if (ctx.getBool("wait_for_cancel")) {
      ctx.progress().beginStage("waiting");
      while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(10)) {
        ctx.progress().checkCancel();
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
    }
    if (ctx.getBool("fail")) throw InputError("asked to fail");
    double v = ctx.getDouble("value");
    for (size_t p = 0; p < 2; ++p)
      if (ctx.hasInput(p)) v += ctx.inputAs<ReportData>(p).value.number("value");
    Report r;
    r.set("value", ReportValue(v));
    ctx.report().set("value", ReportValue(v));
    ctx.log("computed " + formatDouble(v));
    ctx.setOutput(0, makeData<ReportData>(std::move(r)));
  }
};

// "Staged": `stages` stages named "stage 1", "stage 2", ... of `stage_seconds` each, in which two
// worker threads report fractions as fast as they can, out of order (the second lags the first by
// a tenth), as an OpenMP loop's threads do. Counts its report() calls (reportCalls()).
inline std::atomic<int64_t>& reportCalls() {
  static std::atomic<int64_t> n{0};
  return n;
}
class StagedModule : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const int64_t stages = ctx.getInt("stages");
    const double seconds = ctx.getDouble("stage_seconds");
    for (int64_t s = 1; s <= stages; ++s) {
      ctx.progress().beginStage("stage " + std::to_string(s));
      const auto t0 = std::chrono::steady_clock::now();
      auto work = [&](double lag) {
        for (;;) {
          const double f = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / seconds;
          if (f >= 1.0) break;
          ctx.progress().report(std::max(0.0, f - lag));
          ++reportCalls();
        }
      };
      std::thread other(work, 0.1);
      work(0.0);
      other.join();
      ctx.progress().checkCancel();
    }
    ctx.report().set("stages", ReportValue(stages));
  }
};

inline void registerTestModules(ModuleRegistry& reg) {
  registerStandardModules(reg);
  ModuleInfo m;
  m.name = "Number";
  m.category = "Test";
  m.description = "test module";
  m.inputs = {{"a", {PortType::Report}, "", true}, {"b", {PortType::Report}, "", true}};
  m.outputs = {{"out", {PortType::Report}, ""}};
  ParamSpec value{"value", ParamType::Double, 0.0, {}, {}, {}, "", "", false, false};
  ParamSpec fail{"fail", ParamType::Bool, false, {}, {}, {}, "", "", false, false};
  ParamSpec peers{"wait_for_peers", ParamType::Int, int64_t(0), 0.0, 64.0, {}, "", "", false, false};
  ParamSpec cancel{"wait_for_cancel", ParamType::Bool, false, {}, {}, {}, "", "", false, false};
  m.params = {value, fail, peers, cancel};
  m.summaryKeys = {"value"};
  m.factory = [] { return std::make_unique<NumberModule>(); };
  reg.add(m);
  // A module with a required LabelVolume input, for type checks.
  ModuleInfo sink;
  sink.name = "NeedsVolume";
  sink.category = "Test";
  sink.inputs = {{"volume", {PortType::LabelVolume}, ""}};
  sink.factory = [] { return std::make_unique<NumberModule>(); };
  reg.add(sink);
  ModuleInfo staged;
  staged.name = "Staged";
  staged.category = "Test";
  staged.params = {{"stages", ParamType::Int, int64_t(2), 0.0, 100.0, {}, "", "", false, false},
                   {"stage_seconds", ParamType::Double, 0.3, 0.0, 60.0, {}, "", "", false, false}};
  staged.factory = [] { return std::make_unique<StagedModule>(); };
  reg.add(staged);
}

} // namespace tetflow::test
