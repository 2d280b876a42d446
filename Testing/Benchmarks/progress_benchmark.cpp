// What live progress costs (docs/headless.md, issue 29). Runs a net in this process as
// `tetflow run` does, again and again, in two ways, interleaved:
//   none  no observer of progress: what `tetflow run` does with --progress none in a pipe, and
//         what every run did before there was live progress
//   full  everything at once: the progress board, the JSON lines (to a file) and the terminal's
//         live lines (to a pseudo-terminal, read by a thread)
// The wall times of whole runs differ by more than 1 % from run to run on a shared 2-core
// machine, so the cost is also counted directly, in the full runs:
//   observer   time spent in the observer's callbacks (board, JSON line, flush), timed around them
//   redraws    time the live lines' thread spent redrawing, timed inside it
//   reports    the modules' report() calls times what a call costs when observed, less what it
//              costs unobserved (both measured on a module that reports in a tight loop on two
//              threads, as an OpenMP loop does)
// and their sum is set against the run's time.
//
//   progress_benchmark [RESULTS_FILE] [NET] [REPEATS]
//     defaults: progress_results.txt, Nets/default.srn, 5
#include <poll.h>
#include <pty.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>
#include <vector>

#include "Dataflow/Executor.h"
#include "Dataflow/NetworkFile.h"
#include "Dataflow/RunProgress.h"
#include "Interface/TerminalProgress.h"
#include "Modules/StandardModules.h"

using namespace tetflow;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

double secs(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

// Reports as fast as it can on two threads for `seconds`, in one stage.
class TightReporter : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const double seconds = ctx.getDouble("seconds");
    ctx.progress().beginStage("report");
    std::atomic<int64_t> calls{0};
    const auto t0 = Clock::now();
    auto work = [&] {
      int64_t n = 0;
      for (;;) {
        const double f = secs(t0, Clock::now()) / seconds;
        if (f >= 1.0) break;
        ctx.progress().report(f);
        ++n;
      }
      calls += n;
    };
    std::thread other(work);
    work();
    other.join();
    ctx.report().set("calls", ReportValue(calls.load()));
  }
};

struct Full {
  RunProgress board;
  std::FILE* jsonFile = nullptr;
  std::unique_ptr<JsonlProgressWriter> jsonl;
  std::unique_ptr<TerminalProgress> live;
  std::atomic<int64_t> observerNs{0}, events{0};
};

// One run of net; with `full` set, observed by everything tetflow run can show.
double runOnce(const Network& net, Full* full, Executor& exec) {
  Executor::Options opt;
  opt.releaseConsumed = true;
  ExecutionObserver obs;
  if (full) {
    obs.onStatus = [&, full](const std::string& id, ModuleStatus st) {
      const auto t0 = Clock::now();
      if (st == ModuleStatus::Running) {
        const std::string& name = net.module(id)->info->name;
        full->board.started(id, name);
        full->jsonl->start(id, name);
      } else if (st != ModuleStatus::Waiting) {
        full->board.ended(id);
        const ModuleState* s = exec.state(id);
        full->jsonl->end(id, net.module(id)->info->name, moduleStatusName(st), s ? s->seconds : 0.0);
        full->live->above([] {}); // where the runner prints the module's summary line
      }
      full->observerNs += std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - t0).count();
      ++full->events;
    };
    obs.onProgress = [full](const std::string& id, const std::string& stage, double f) {
      const auto t0 = Clock::now();
      full->board.progress(id, stage, f);
      full->jsonl->progress(id, stage, f);
      full->observerNs += std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - t0).count();
      ++full->events;
    };
  }
  const auto t0 = Clock::now();
  const auto sum = exec.execute(net, opt, obs);
  const double s = secs(t0, Clock::now());
  if (!sum.success) throw std::runtime_error("the net failed");
  return s;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

} // namespace

int main(int argc, char** argv) {
  const std::string results = argc > 1 ? argv[1] : "progress_results.txt";
  const std::string netPath =
      argc > 2 ? argv[2] : (fs::path(TETFLOW_TEST_DATA).parent_path().parent_path() / "Nets" / "default.srn").string();
  const int repeats = argc > 3 ? std::max(1, std::atoi(argv[3])) : 5;

  ModuleRegistry reg;
  registerStandardModules(reg);
  ModuleInfo tight;
  tight.name = "TightReporter";
  tight.category = "Benchmark";
  tight.params = {{"seconds", ParamType::Double, 1.0, 0.0, 60.0, {}, "s", "", false, false}};
  tight.factory = [] { return std::make_unique<TightReporter>(); };
  reg.add(tight);

  const fs::path work = fs::temp_directory_path() / "tetflow_progress_bench";
  fs::create_directories(work);
  Network net = loadNetwork(netPath, reg);
  net.setOutputDir(work.string());

  // A pseudo-terminal for the live lines, drained by a thread as a terminal would be.
  int master = -1, slave = -1;
  if (openpty(&master, &slave, nullptr, nullptr, nullptr) != 0) {
    std::cerr << "progress_benchmark: no pseudo-terminal\n";
    return 1;
  }
  std::atomic<bool> draining{true};
  std::atomic<int64_t> ttyBytes{0};
  std::thread drain([&] {
    char buf[4096];
    while (draining) {
      pollfd p{master, POLLIN, 0};
      if (poll(&p, 1, 50) > 0) {
        const ssize_t n = read(master, buf, sizeof buf);
        if (n > 0) ttyBytes += n;
      }
    }
  });

  std::vector<double> none, full;
  int64_t reportCalls = 0, events = 0, redraws = 0;
  double observerS = 0, redrawS = 0, fullS = 0;
  for (int r = 0; r < repeats; ++r) {
    {
      Executor exec;
      none.push_back(runOnce(net, nullptr, exec));
    }
    Full f;
    f.jsonFile = std::fopen((work / "events.jsonl").c_str(), "w");
    f.jsonl = std::make_unique<JsonlProgressWriter>(f.jsonFile, f.board);
    f.live = std::make_unique<TerminalProgress>(f.board, slave);
    Executor exec;
    const double s = runOnce(net, &f, exec);
    f.live->stop();
    std::fclose(f.jsonFile);
    full.push_back(s);
    int64_t calls = 0;
    for (const auto& m : net.modules())
      if (const ModuleState* st = exec.state(m.id)) calls += st->progressReports;
    reportCalls = calls;
    events = f.events;
    redraws = f.live->redraws();
    observerS += double(f.observerNs) * 1e-9;
    redrawS += f.live->redrawSeconds();
    fullS += s;
  }

  // The cost of one report() call, observed and not (a net of one TightReporter).
  auto perCall = [&](bool observed) {
    Network t(reg);
    const auto id = t.addModule("TightReporter");
    Executor exec;
    Full f;
    f.jsonFile = std::fopen((work / "tight.jsonl").c_str(), "w");
    f.jsonl = std::make_unique<JsonlProgressWriter>(f.jsonFile, f.board);
    f.live = std::make_unique<TerminalProgress>(f.board, slave);
    runOnce(t, observed ? &f : nullptr, exec);
    f.live->stop();
    std::fclose(f.jsonFile);
    const double calls = exec.state(id)->report.number("calls");
    return 2.0 * exec.state(id)->seconds / calls * 1e9; // ns per call per thread
  };
  const double nsUnobserved = perCall(false), nsObserved = perCall(true);
  draining = false;
  drain.join();
  close(master);
  close(slave);

  const double meanFull = fullS / repeats;
  const double reportS = double(reportCalls) * std::max(0.0, nsObserved - nsUnobserved) * 1e-9;
  const double costS = observerS / repeats + redrawS / repeats + reportS;
  std::ostringstream out;
  char line[256];
  out << "# progress_benchmark: " << fs::relative(netPath, fs::current_path()).string() << " run in-process as "
      << "`tetflow run` runs it, " << repeats << " times each way, interleaved\n";
  out << "# " << std::thread::hardware_concurrency() << " hardware threads\n";
  std::snprintf(line, sizeof line, "wall_none_median_s   %.3f  (min %.3f, max %.3f)\n", median(none),
                *std::min_element(none.begin(), none.end()), *std::max_element(none.begin(), none.end()));
  out << line;
  std::snprintf(line, sizeof line, "wall_full_median_s   %.3f  (min %.3f, max %.3f)\n", median(full),
                *std::min_element(full.begin(), full.end()), *std::max_element(full.begin(), full.end()));
  out << line;
  std::snprintf(line, sizeof line, "events_per_run       %lld  (status and progress events the observer got)\n",
                static_cast<long long>(events));
  out << line;
  std::snprintf(line, sizeof line, "observer_ms_per_run  %.3f\n", observerS / repeats * 1e3);
  out << line;
  std::snprintf(line, sizeof line, "redraws_per_run      %lld  taking %.3f ms in all\n", static_cast<long long>(redraws),
                redrawS / repeats * 1e3);
  out << line;
  std::snprintf(line, sizeof line, "report_calls_per_run %lld  at %.1f ns observed vs %.1f ns unobserved: %.3f ms\n",
                static_cast<long long>(reportCalls), nsObserved, nsUnobserved, reportS * 1e3);
  out << line;
  std::snprintf(line, sizeof line, "cost_per_run_ms      %.3f  = %.4f %% of the full runs' mean %.3f s\n", costS * 1e3,
                100.0 * costS / meanFull, meanFull);
  out << line;
  std::snprintf(line, sizeof line, "terminal_bytes       %lld  (all runs)\n", static_cast<long long>(ttyBytes.load()));
  out << line;
  std::cout << out.str();
  std::ofstream(results) << out.str();
  fs::remove_all(work);
  return 0;
}
