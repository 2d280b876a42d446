#include "Executor.h"

#include <omp.h>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <new>
#include <set>
#include <sstream>
#include <thread>
#ifdef __GLIBC__
#include <malloc.h> // malloc_trim
#endif

namespace tetflow {

const char* moduleStatusName(ModuleStatus s) {
  switch (s) {
    case ModuleStatus::Idle: return "idle";
    case ModuleStatus::Waiting: return "waiting";
    case ModuleStatus::Running: return "running";
    case ModuleStatus::Done: return "done";
    case ModuleStatus::Error: return "error";
    case ModuleStatus::Skipped: return "skipped";
    case ModuleStatus::Cancelled: return "cancelled";
  }
  return "?";
}

namespace {

int64_t steadyNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Progress sink of one running module: forwards to the observer, throttled (ExecutionObserver).
// report() may come from many worker threads at any rate; the observer sees the stage's highest
// fraction so far at most once per kReportIntervalNs, so a chatty loop costs one clock read and
// a few relaxed atomics per call, and the observer's own work (a lock, a line of JSON) stays
// a few events per second.
class ModuleProgress : public Progress {
public:
  static constexpr int64_t kReportIntervalNs = 100'000'000; // 0.1 s
  ModuleProgress(std::string id, const ExecutionObserver& obs) : id_(std::move(id)), obs_(obs) {}
  std::string stage;

protected:
  void onStage(const std::string& name) override {
    stage = name;
    best_.store(0.0, std::memory_order_relaxed);
    sent_.store(0.0, std::memory_order_relaxed);
    next_.store(steadyNowNs() + kReportIntervalNs, std::memory_order_relaxed);
    if (obs_.onProgress) obs_.onProgress(id_, name, 0.0);
  }
  void onReport(double f) override {
    if (!obs_.onProgress) return;
    calls_.fetch_add(1, std::memory_order_relaxed);
    if (!(f > 0.0)) return; // also drops NaN
    f = std::min(f, 1.0);
    double b = best_.load(std::memory_order_relaxed);
    while (f > b && !best_.compare_exchange_weak(b, f, std::memory_order_relaxed)) {}
    const int64_t now = steadyNowNs();
    int64_t next = next_.load(std::memory_order_relaxed);
    if (now < next || !next_.compare_exchange_strong(next, now + kReportIntervalNs)) return;
    const double best = best_.load(std::memory_order_relaxed);
    if (best <= sent_.load(std::memory_order_relaxed)) return; // nothing new to say
    sent_.store(best, std::memory_order_relaxed);
    obs_.onProgress(id_, stage, best);
  }
  void onStageEnd(const std::string& name, double) override {
    if (obs_.onProgress && sent_.load(std::memory_order_relaxed) < 1.0) obs_.onProgress(id_, name, 1.0);
    sent_.store(1.0, std::memory_order_relaxed);
  }

private:
  std::string id_;
  const ExecutionObserver& obs_;
  std::atomic<double> best_{0.0}, sent_{0.0}; // the stage's highest fraction reported / forwarded
  std::atomic<int64_t> next_{0};             // steady ns before which reports are not forwarded
  std::atomic<int64_t> calls_{0};            // report() calls

public:
  int64_t reportCalls() const { return calls_.load(); }
};

// Parameters as text, plus size and time of input files: what a result depends on besides data.
std::string signatureOf(const ModuleNode& m, const std::string& baseDir) {
  std::ostringstream s;
  auto stamp = [&](const std::string& what, const std::filesystem::path& p) { // size and time, 0 0 if absent
    std::error_code ec;
    const auto size = std::filesystem::file_size(p, ec);
    const auto time = std::filesystem::last_write_time(p, ec);
    s << what << ' ' << p.string() << ' ' << (ec ? 0 : size) << ' ' << (ec ? 0 : time.time_since_epoch().count())
      << '\n';
  };
  s << m.info->name << '\n';
  for (const auto& spec : m.info->params) {
    auto it = m.params.find(spec.name);
    if (it == m.params.end()) continue;
    s << spec.name << '=' << formatParam(spec, it->second) << '\n';
    if (spec.isInputPath) {
      std::vector<std::string> files;
      if (const auto* str = std::get_if<std::string>(&it->second)) files.push_back(*str);
      if (const auto* list = std::get_if<std::vector<std::string>>(&it->second)) files = *list;
      for (const auto& f : files) {
        std::filesystem::path p(f);
        if (p.is_relative() && !baseDir.empty()) p = std::filesystem::path(baseDir) / p;
        stamp("  file", p);
      }
    }
  }
  if (m.info->sideFiles)
    for (const std::string& f : m.info->sideFiles(m.params, baseDir)) stamp("side file", f);
  return s.str();
}

} // namespace

const ModuleState* Executor::state(const std::string& id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = states_.find(id);
  return it == states_.end() ? nullptr : &it->second;
}

void Executor::reset() {
  std::lock_guard<std::mutex> lock(mutex_);
  states_.clear();
}

void Executor::cancel() {
  cancel_.store(true);
  std::lock_guard<std::mutex> lock(mutex_);
  for (Progress* p : active_) p->requestCancel();
}

Executor::Summary Executor::execute(const Network& netIn, const Options& opt,
                                    const ExecutionObserver& obs) {
  if (running_.exchange(true)) throw ProcessingError("the network is already executing");
  struct RunningGuard {
    std::atomic<bool>& r;
    ~RunningGuard() { r.store(false); }
  } guard{running_};
  cancel_.store(false);
  const auto t0 = std::chrono::steady_clock::now();
  // Outputs that would overwrite one of the net's inputs or each other: refused before anything
  // runs (the GUI's Run; the command line checks first and exits 3).
  if (const auto conflicts = netIn.fileConflicts(); !conflicts.empty()) {
    std::string m = "the network would lose data: ";
    for (size_t i = 0; i < conflicts.size(); ++i) m += (i ? "; " : "") + conflicts[i];
    throw InputError(m);
  }

  // Snapshot of the network.
  const std::vector<ModuleNode> nodes = netIn.modules();
  const std::vector<Connection> conns = netIn.connections();
  const std::string baseDir = netIn.baseDir();
  const std::string outputDir = netIn.outputDir();
  std::map<std::string, const ModuleNode*> byId;
  for (const auto& n : nodes) byId[n.id] = &n;
  for (const auto& id : opt.only) netIn.requireModule(id);

  {
    std::lock_guard<std::mutex> lock(mutex_);
    // Drop states of modules that are gone or changed type.
    for (auto it = states_.begin(); it != states_.end();) {
      auto n = byId.find(it->first);
      if (n == byId.end() || n->second->info->name != it->second.moduleName) it = states_.erase(it);
      else ++it;
    }
    for (const auto& n : nodes) states_[n.id].moduleName = n.info->name;
  }

  // Scope: requested modules + downstream, plus upstream modules without a current result.
  std::set<std::string> scope;
  if (opt.only.empty()) {
    for (const auto& n : nodes) scope.insert(n.id);
  } else {
    if (opt.upstreamOnly) { // run or reused as their signatures and inputs decide
      scope.insert(opt.only.begin(), opt.only.end());
    } else {
      for (const auto& id : netIn.downstreamClosure(opt.only)) scope.insert(id);
    }
    std::deque<std::string> q(scope.begin(), scope.end());
    while (!q.empty()) {
      const std::string cur = q.front();
      q.pop_front();
      for (const auto& up : netIn.upstream(cur)) {
        if (scope.count(up)) continue;
        bool current;
        {
          std::lock_guard<std::mutex> lock(mutex_);
          const ModuleState& s = states_[up];
          current = s.valid && s.signature == signatureOf(*byId[up], baseDir);
        }
        if (!current) {
          scope.insert(up);
          q.push_back(up);
        }
      }
    }
  }
  const std::set<std::string> forced =
      opt.upstreamOnly ? std::set<std::string>{} : std::set<std::string>(opt.only.begin(), opt.only.end());

  // Dependency counts within scope.
  std::map<std::string, int> pending;
  std::map<std::string, std::vector<std::string>> down, upstream;
  std::map<std::string, int> consumersLeft; // releaseConsumed: modules downstream still to finish
  for (const auto& id : scope) pending[id] = 0;
  {
    std::set<std::pair<std::string, std::string>> edges;
    for (const auto& c : conns)
      if (scope.count(c.from) && scope.count(c.to) && edges.insert({c.from, c.to}).second) {
        ++pending[c.to];
        down[c.from].push_back(c.to);
        upstream[c.to].push_back(c.from);
        ++consumersLeft[c.from];
      }
  }

  std::mutex qm;
  std::condition_variable cv;
  std::deque<std::string> ready;
  size_t finished = 0;
  std::map<std::string, std::string> blockedBy; // module -> failed upstream id
  Summary sum;

  auto setStatus = [&](const std::string& id, ModuleStatus st) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      states_[id].status = st;
    }
    if (obs.onStatus) obs.onStatus(id, st);
  };

  for (const auto& n : nodes)
    if (scope.count(n.id)) setStatus(n.id, ModuleStatus::Waiting);
  for (const auto& n : nodes) // insertion order among ready modules
    if (scope.count(n.id) && pending[n.id] == 0) ready.push_back(n.id);

  // Called with qm held after `id` reached a final state.
  // Set on the worker thread whose module was the last consumer of something released: that
  // worker hands the freed memory back once the module's run (which holds its inputs) is over.
  static thread_local bool releasedHere = false; // the workers are new threads each run
  std::function<void(const std::string&, bool)> complete = [&](const std::string& id, bool ok) {
    ++finished;
    sum.order.push_back(id);
    if (opt.releaseConsumed)
      for (const auto& u : upstream[id])
        if (--consumersLeft[u] == 0) { // the consumer still holds its inputs until it returns
          std::lock_guard<std::mutex> lock(mutex_);
          ModuleState& s = states_[u];
          if (!s.outputs.empty()) {
            s.outputs.clear();
            s.valid = false;
            s.released = true;
            releasedHere = true;
          }
        }
    for (const auto& d : down[id]) {
      if (!ok && !blockedBy.count(d)) blockedBy[d] = blockedBy.count(id) ? blockedBy[id] : id;
      if (--pending[d] == 0) ready.push_back(d);
    }
    cv.notify_all();
  };

  auto runOne = [&](const std::string& id) {
    const ModuleNode& node = *byId.at(id);
    // Gather inputs.
    std::vector<DataPtr> inputs(node.info->inputs.size());
    std::vector<uint64_t> inputIds(node.info->inputs.size(), 0);
    std::string missing;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (const auto& c : conns) {
        if (c.to != id) continue;
        const ModuleState& up = states_[c.from];
        if ((up.valid || up.passedOn) && c.fromPort < static_cast<int>(up.outputs.size())) {
          inputs[c.toPort] = up.outputs[c.fromPort];
          inputIds[c.toPort] = inputs[c.toPort] ? inputs[c.toPort]->id() : 0;
        }
      }
    }
    const std::string sig = signatureOf(node, baseDir);
    bool reuse = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const ModuleState& s = states_[id];
      reuse = !opt.force && !forced.count(id) && s.valid && s.signature == sig &&
              s.inputIds == inputIds;
    }
    if (reuse) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        states_[id].reused = true;
      }
      setStatus(id, ModuleStatus::Done);
      std::lock_guard<std::mutex> lk(qm);
      ++sum.reused;
      complete(id, true);
      return;
    }

    ModuleProgress progress(id, obs);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ModuleState& s = states_[id];
      s.valid = false;
      s.reused = false;
      s.released = false;
      s.outputs.clear();
      s.report = Report{};
      s.messages.clear();
      s.stages.clear();
      s.error.clear();
      s.errorKind.clear();
      s.skippedBecause.clear();
      s.passedOn = false;
      s.progress = 0;
      active_.push_back(&progress);
      if (cancel_.load()) progress.requestCancel();
    }
    setStatus(id, ModuleStatus::Running);
    const auto m0 = std::chrono::steady_clock::now();
    ModuleStatus final = ModuleStatus::Done;
    std::string err, kind;
    ExecutionContext ctx(*node.info, id, node.params, inputs, baseDir, progress, outputDir);
    try {
      // Required inputs first: a clear message instead of a module-specific failure.
      for (size_t p = 0; p < node.info->inputs.size(); ++p)
        if (!node.info->inputs[p].optional && !inputs[p])
          throw InputError("input port " + std::to_string(p) + " (" + node.info->inputs[p].name +
                           ") is not connected; connect a " +
                           portTypeName(node.info->inputs[p].type()) + " to it");
      progress.checkCancel();
      auto module = node.info->factory();
      const ScopedCurrentProgress current(&progress);
      module->execute(ctx);
      progress.endStage();
    } catch (const Cancelled&) {
      final = ModuleStatus::Cancelled;
    } catch (const GateFailure& e) {
      final = ModuleStatus::Error;
      err = e.what();
      kind = "gate";
    } catch (const InputError& e) {
      final = ModuleStatus::Error;
      err = e.what();
      kind = "input";
    } catch (const ProcessingError& e) {
      final = ModuleStatus::Error;
      err = e.what();
      kind = "processing";
    } catch (const std::bad_alloc&) {
      final = ModuleStatus::Error;
      err = "out of memory";
      kind = "processing";
    } catch (const std::exception& e) {
      final = ModuleStatus::Error;
      err = std::string("internal error: ") + e.what();
      kind = "internal";
    } catch (...) {
      final = ModuleStatus::Error;
      err = "internal error (unknown exception)";
      kind = "internal";
    }
    progress.endStage();
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - m0).count();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      active_.erase(std::find(active_.begin(), active_.end(), &progress));
      ModuleState& s = states_[id];
      s.seconds = secs;
      s.report = ctx.report();
      s.messages = ctx.messages();
      s.stages = progress.stageTimes();
      s.progressReports = progress.reportCalls();
      if (final == ModuleStatus::Done) {
        s.outputs = ctx.outputs();
        s.valid = true;
        s.signature = sig;
        s.inputIds = inputIds;
        s.progress = 1.0;
      } else if (final == ModuleStatus::Error) {
        const std::string prefix = id + ": ";
        s.error = err.rfind(prefix, 0) == 0 ? err : prefix + err;
        s.errorKind = kind;
        if (kind == "gate") { // the outputs stand: downstream runs on them
          s.outputs = ctx.outputs();
          s.passedOn = true;
        }
      }
    }
    setStatus(id, final);
    std::lock_guard<std::mutex> lk(qm);
    if (final == ModuleStatus::Done) ++sum.ran;
    else if (final == ModuleStatus::Error) ++sum.failed;
    else ++sum.cancelled;
    complete(id, final == ModuleStatus::Done || kind == "gate");
  };

  int nThreads = opt.threads > 0 ? opt.threads : static_cast<int>(std::thread::hardware_concurrency());
  nThreads = std::max(1, std::min<int>(nThreads, std::max<size_t>(1, scope.size())));
  const int ompThreads = opt.threads > 0 ? opt.threads : omp_get_max_threads();

  auto worker = [&]() {
    omp_set_num_threads(ompThreads);
    while (true) {
      std::string id;
      {
        std::unique_lock<std::mutex> lk(qm);
        cv.wait(lk, [&] { return !ready.empty() || finished == scope.size(); });
        if (ready.empty()) return;
        id = ready.front();
        ready.pop_front();
        if (cancel_.load()) {
          ++sum.cancelled;
          lk.unlock();
          setStatus(id, ModuleStatus::Cancelled);
          lk.lock();
          complete(id, false);
          continue;
        }
        if (blockedBy.count(id)) {
          {
            std::lock_guard<std::mutex> lock(mutex_);
            ModuleState& s = states_[id];
            s.valid = false;
            s.outputs.clear();
            s.skippedBecause = blockedBy[id];
          }
          ++sum.skipped;
          lk.unlock();
          setStatus(id, ModuleStatus::Skipped);
          lk.lock();
          complete(id, false);
          continue;
        }
      }
      runOne(id); // its inputs are let go here: what it was the last to consume is freed now
#ifdef __GLIBC__
      if (releasedHere) malloc_trim(0); // glibc keeps freed heap memory otherwise
#endif
      releasedHere = false;
    }
  };

  std::vector<std::thread> pool;
  for (int i = 0; i < nThreads; ++i) pool.emplace_back(worker);
  for (auto& t : pool) t.join();

  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  sum.success = sum.failed == 0 && sum.skipped == 0 && sum.cancelled == 0;
  return sum;
}

} // namespace tetflow
