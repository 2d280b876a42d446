#include "ExecutionController.h"

#include <QCoreApplication>
#include <QDeadlineTimer>
#include <QMetaObject>
#include <QThread>

#include "GuiStyle.h"

namespace tetflow::gui {

ExecutionController::ExecutionController(QObject* parent) : QObject(parent) {}

ExecutionController::~ExecutionController() {
  if (worker_.joinable()) {
    exec_.cancel();
    worker_.join();
  }
}

bool ExecutionController::start(const Network& net, const std::vector<std::string>& only, int threads,
                                bool upstreamOnly) {
  if (running_) return false;
  if (worker_.joinable()) worker_.join();
  // Snapshot on the GUI thread: the executor copies this, never the live (editable) network.
  snapshot_ = std::make_shared<const Network>(net);
  running_ = true;
  error_.clear();
  summary_ = {};
  emit started();
  Executor::Options opt;
  opt.only = only;
  opt.threads = threads;
  opt.upstreamOnly = upstreamOnly;
  board_ = std::make_shared<RunProgress>();
  worker_ = std::thread([this, opt, snap = snapshot_, board = board_] {
    ExecutionObserver obs;
    obs.onStatus = [this, snap, board](const std::string& id, ModuleStatus st) {
      if (st == ModuleStatus::Running) {
        if (const ModuleNode* m = snap->module(id)) board->started(id, m->info->name);
      } else if (st != ModuleStatus::Waiting) {
        board->ended(id);
      }
      QMetaObject::invokeMethod(
          this, [this, id = qs(id), st] { emit moduleStatus(id, int(st)); }, Qt::QueuedConnection);
    };
    obs.onProgress = [this, board](const std::string& id, const std::string& stage, double f) {
      board->progress(id, stage, f);
      {
        std::lock_guard<std::mutex> lock(progressMutex_);
        progress_[id] = {stage, f};
      }
      if (!flushQueued_.exchange(true))
        QMetaObject::invokeMethod(this, [this] { flushProgress(); }, Qt::QueuedConnection);
    };
    Executor::Summary sum;
    QString err;
    try {
      sum = exec_.execute(*snap, opt, obs);
    } catch (const std::exception& e) {
      err = QString::fromStdString(e.what());
      sum.success = false;
    }
    QMetaObject::invokeMethod(
        this,
        [this, sum, err] {
          summary_ = sum;
          error_ = err;
          onFinished();
        },
        Qt::QueuedConnection);
  });
  return true;
}

void ExecutionController::flushProgress() {
  std::map<std::string, std::pair<std::string, double>> batch;
  {
    std::lock_guard<std::mutex> lock(progressMutex_);
    batch.swap(progress_);
    flushQueued_ = false;
  }
  for (const auto& [id, p] : batch) emit moduleProgress(qs(id), qs(p.first), p.second);
}

void ExecutionController::onFinished() {
  if (worker_.joinable()) worker_.join();
  flushProgress();
  running_ = false;
  snapshot_.reset();
  emit finished(summary_.success && error_.isEmpty());
}

std::optional<RunProgress::Entry> ExecutionController::liveProgress(const std::string& id) const {
  return board_->entry(id);
}

void ExecutionController::cancel() {
  if (running_) exec_.cancel();
}

bool ExecutionController::waitForFinished(int timeoutMs) {
  QDeadlineTimer deadline(timeoutMs);
  while (running_ && !deadline.hasExpired()) {
    QCoreApplication::processEvents(QEventLoop::AllEvents, 20);
    QThread::msleep(2);
  }
  return !running_;
}

void ExecutionController::reset() {
  if (running_) {
    exec_.cancel();
    waitForFinished();
  }
  exec_.reset();
}

} // namespace tetflow::gui
