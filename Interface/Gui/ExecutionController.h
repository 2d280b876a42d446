#pragma once
// Runs tetflow::Executor off the GUI thread.
//
// start() takes a snapshot copy of the network *on the GUI thread* (so no edit can race the
// executor's own copy), then runs Executor::execute on a worker std::thread. Observer callbacks
// arrive on executor threads and are marshalled to the GUI thread with queued
// QMetaObject::invokeMethod calls: status changes one by one (few), progress coalesced (the
// latest fraction per module, at most one queued flush at a time). The Executor object lives as
// long as the controller, so a second run re-uses unchanged results (Executor's re-run rules).
// States (reports, outputs, messages) may be read only while no run is in flight.
#include <QObject>
#include <QString>

#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "Dataflow/Executor.h"
#include "Dataflow/RunProgress.h"

namespace tetflow::gui {

class ExecutionController : public QObject {
  Q_OBJECT
public:
  explicit ExecutionController(QObject* parent = nullptr);
  ~ExecutionController() override;

  // false when a run is already in flight.
  // upstreamOnly: `only` and whatever upstream of them is stale, nothing downstream
  // (Executor::Options::upstreamOnly).
  bool start(const Network& net, const std::vector<std::string>& only = {}, int threads = 0,
             bool upstreamOnly = false);
  void cancel();
  bool isRunning() const { return running_; }
  // Blocks (processing queued events) until the run finished; false on timeout. Tests use it.
  bool waitForFinished(int timeoutMs = 60000);
  // Forget results (a different network was opened).
  void reset();

  const Executor& executor() const { return exec_; }
  const ModuleState* state(const std::string& id) const { return running_ ? nullptr : exec_.state(id); }
  const Executor::Summary& lastSummary() const { return summary_; }
  // A running module's stage, fraction, elapsed time and estimate (the headless runner's live
  // line shows the same); nullopt when it is not running. Thread-safe.
  std::optional<RunProgress::Entry> liveProgress(const std::string& id) const;
  const QString& lastError() const { return error_; }

signals:
  void started();
  void moduleStatus(const QString& id, int status);
  void moduleProgress(const QString& id, const QString& stage, double fraction);
  void finished(bool success);

private:
  void flushProgress();
  void onFinished();

  Executor exec_;
  std::thread worker_;
  bool running_ = false;
  std::shared_ptr<const Network> snapshot_;
  Executor::Summary summary_;
  QString error_;
  std::mutex progressMutex_;
  std::map<std::string, std::pair<std::string, double>> progress_;
  std::atomic<bool> flushQueued_{false};
  std::shared_ptr<RunProgress> board_ = std::make_shared<RunProgress>(); // replaced per run
};

} // namespace tetflow::gui
