#include <gtest/gtest.h>

#include <future>

#include "Dataflow/Executor.h"
#include "Dataflow/RunReport.h"
#include "TestModules.h"
#include "TestUtil.h"

using namespace tetflow;
using test::counters;

namespace {
struct ExecFixture : ::testing::Test {
  ModuleRegistry reg;
  ExecFixture() {
    test::registerTestModules(reg);
    counters().clear();
  }
  static double value(const Executor& e, const std::string& id) {
    return e.state(id)->report.number("value");
  }
};
} // namespace

TEST_F(ExecFixture, RunsInDependencyOrderAndPassesData) {
  Network net(reg);
  // (m1=1) + (m2=2) -> m3(+10) -> m4(+100)
  for (int i = 0; i < 4; ++i) net.addModule("Number");
  net.setParameterText("m1", "value", "1");
  net.setParameterText("m2", "value", "2");
  net.setParameterText("m3", "value", "10");
  net.setParameterText("m4", "value", "100");
  net.connect("m1", 0, "m3", 0);
  net.connect("m2", 0, "m3", 1);
  net.connect("m3", 0, "m4", 0);
  Executor exec;
  const auto sum = exec.execute(net);
  EXPECT_TRUE(sum.success);
  EXPECT_EQ(sum.ran, 4);
  EXPECT_DOUBLE_EQ(value(exec, "m3"), 13.0);
  EXPECT_DOUBLE_EQ(value(exec, "m4"), 113.0);
  auto pos = [&](const std::string& id) {
    return std::find(sum.order.begin(), sum.order.end(), id) - sum.order.begin();
  };
  EXPECT_LT(pos("m1"), pos("m3"));
  EXPECT_LT(pos("m2"), pos("m3"));
  EXPECT_LT(pos("m3"), pos("m4"));
  EXPECT_EQ(exec.state("m4")->messages, (std::vector<std::string>{"computed 113"}));
}

TEST_F(ExecFixture, IndependentBranchesRunInParallelOnTwoThreads) {
  Network net(reg);
  for (int i = 0; i < 8; ++i) {
    const auto id = net.addModule("Number");
    net.setParameterText(id, "wait_for_peers", "2");
  }
  Executor exec;
  Executor::Options opt;
  opt.threads = 2;
  const auto sum = exec.execute(net, opt);
  EXPECT_TRUE(sum.success);
  EXPECT_EQ(counters().maxRunning.load(), 2); // two at once, never more than the cap
  counters().clear();
  for (const auto& m : net.modules()) net.setParameterText(m.id, "wait_for_peers", "0");
  opt.threads = 1;
  exec.execute(net, opt);
  EXPECT_EQ(counters().maxRunning.load(), 1);
}

TEST_F(ExecFixture, ReRunsOnlyWhatChangedAndItsDownstream) {
  Network net(reg);
  // m1 -> m2 -> m3, and m4 -> m5 independent.
  for (int i = 0; i < 5; ++i) net.addModule("Number");
  net.connect("m1", 0, "m2", 0);
  net.connect("m2", 0, "m3", 0);
  net.connect("m4", 0, "m5", 0);
  Executor exec;
  exec.execute(net);
  for (const char* id : {"m1", "m2", "m3", "m4", "m5"}) EXPECT_EQ(counters().count(id), 1) << id;

  auto sum = exec.execute(net); // nothing changed
  EXPECT_EQ(sum.ran, 0);
  EXPECT_EQ(sum.reused, 5);
  EXPECT_TRUE(exec.state("m3")->reused);

  net.setParameterText("m2", "value", "5");
  sum = exec.execute(net);
  EXPECT_EQ(sum.ran, 2);
  EXPECT_EQ(counters().count("m1"), 1);
  EXPECT_EQ(counters().count("m2"), 2);
  EXPECT_EQ(counters().count("m3"), 2);
  EXPECT_EQ(counters().count("m4"), 1);
  EXPECT_EQ(counters().count("m5"), 1);
  EXPECT_DOUBLE_EQ(value(exec, "m3"), 5.0);

  // Setting a parameter back to a value it had still counts as a change of the last run.
  net.setParameterText("m2", "value", "0");
  exec.execute(net);
  EXPECT_EQ(counters().count("m3"), 3);

  // "Execute this and downstream" re-runs the chosen module even when unchanged.
  Executor::Options only;
  only.only = {"m4"};
  sum = exec.execute(net, only);
  EXPECT_EQ(counters().count("m4"), 2);
  EXPECT_EQ(counters().count("m5"), 2);
  EXPECT_EQ(counters().count("m1"), 1);
  EXPECT_EQ(sum.ran, 2);

  // Rewiring changes the inputs: only the rewired module and its downstream re-run.
  net.disconnect(net.inputConnection("m5", 0)->id);
  net.connect("m1", 0, "m5", 0);
  sum = exec.execute(net);
  EXPECT_EQ(sum.ran, 1);
  EXPECT_EQ(counters().count("m5"), 3);
}

TEST_F(ExecFixture, UpToHereRunsTheModuleAndItsStaleUpstreamOnly) {
  Network net(reg);
  // m1 -> m2 -> m3 -> m4, and m5 -> m3.
  for (int i = 0; i < 5; ++i) net.addModule("Number");
  net.setParameterText("m1", "value", "1");
  net.setParameterText("m5", "value", "7");
  net.connect("m1", 0, "m2", 0);
  net.connect("m2", 0, "m3", 0);
  net.connect("m3", 0, "m4", 0);
  net.connect("m5", 0, "m3", 1);
  Executor exec;
  Executor::Options upTo;
  upTo.only = {"m2"};
  upTo.upstreamOnly = true;
  auto sum = exec.execute(net, upTo);
  EXPECT_TRUE(sum.success);
  EXPECT_EQ(sum.ran, 2);
  EXPECT_EQ(counters().count("m1"), 1);
  EXPECT_EQ(counters().count("m2"), 1);
  for (const char* id : {"m3", "m4", "m5"}) {
    EXPECT_EQ(counters().count(id), 0) << id;
    EXPECT_EQ(exec.state(id)->status, ModuleStatus::Idle) << id;
  }
  EXPECT_DOUBLE_EQ(value(exec, "m2"), 1.0);

  // Unchanged: the requested module is reused, not forced.
  sum = exec.execute(net, upTo);
  EXPECT_EQ(sum.ran, 0);
  EXPECT_EQ(sum.reused, 1);
  EXPECT_EQ(counters().count("m2"), 1);

  // An upstream change re-runs the changed module and the requested one, nothing below.
  net.setParameterText("m1", "value", "2");
  sum = exec.execute(net, upTo);
  EXPECT_EQ(sum.ran, 2);
  EXPECT_EQ(counters().count("m2"), 2);
  EXPECT_DOUBLE_EQ(value(exec, "m2"), 2.0);
  EXPECT_EQ(counters().count("m3"), 0);

  // Up to m3: its other branch (m5) runs, m1 and m2 are reused, m4 stays idle.
  upTo.only = {"m3"};
  sum = exec.execute(net, upTo);
  EXPECT_EQ(sum.ran, 2);
  EXPECT_EQ(counters().count("m5"), 1);
  EXPECT_DOUBLE_EQ(value(exec, "m3"), 9.0);
  EXPECT_EQ(counters().count("m4"), 0);
}

TEST_F(ExecFixture, FailureSkipsDownstreamButNotIndependentBranches) {
  Network net(reg);
  for (int i = 0; i < 5; ++i) net.addModule("Number");
  net.connect("m1", 0, "m2", 0);
  net.connect("m2", 0, "m3", 0);
  net.connect("m3", 0, "m4", 0);
  net.setParameterText("m2", "fail", "true");
  Executor exec;
  const auto sum = exec.execute(net);
  EXPECT_FALSE(sum.success);
  EXPECT_EQ(sum.failed, 1);
  EXPECT_EQ(sum.skipped, 2);
  EXPECT_EQ(sum.ran, 2); // m1 and m5
  EXPECT_EQ(exec.state("m2")->status, ModuleStatus::Error);
  EXPECT_EQ(exec.state("m2")->error, "m2: asked to fail");
  EXPECT_EQ(exec.state("m2")->errorKind, "input");
  EXPECT_EQ(exec.state("m3")->status, ModuleStatus::Skipped);
  EXPECT_EQ(exec.state("m4")->skippedBecause, "m2");
  EXPECT_EQ(counters().count("m3"), 0);
  EXPECT_EQ(counters().count("m5"), 1);

  // Fix it: the failed module and its downstream run; m1 is reused.
  net.setParameterText("m2", "fail", "false");
  const auto again = exec.execute(net);
  EXPECT_TRUE(again.success);
  EXPECT_EQ(again.ran, 3);
  EXPECT_EQ(counters().count("m1"), 1);
}

TEST_F(ExecFixture, UnconnectedRequiredInputIsAClearError) {
  Network net(reg);
  net.addModule("NeedsVolume");
  Executor exec;
  exec.execute(net);
  EXPECT_EQ(exec.state("m1")->status, ModuleStatus::Error);
  EXPECT_NE(exec.state("m1")->error.find("input port 0 (volume) is not connected"), std::string::npos);
}

TEST_F(ExecFixture, CancelStopsRunningModulesAndLeavesTheRestUnrun) {
  Network net(reg);
  for (int i = 0; i < 3; ++i) net.addModule("Number");
  net.connect("m1", 0, "m2", 0);
  net.setParameterText("m1", "wait_for_cancel", "true");
  net.setParameterText("m3", "wait_for_cancel", "true");
  Executor exec;
  Executor::Options opt;
  opt.threads = 2;
  auto fut = std::async(std::launch::async, [&] { return exec.execute(net, opt); });
  while (counters().running.load() < 2) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  const auto t0 = std::chrono::steady_clock::now();
  exec.cancel();
  const auto sum = fut.get();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5)); // not the 10 s loop
  EXPECT_FALSE(sum.success);
  EXPECT_EQ(exec.state("m1")->status, ModuleStatus::Cancelled);
  EXPECT_EQ(exec.state("m3")->status, ModuleStatus::Cancelled);
  EXPECT_EQ(exec.state("m2")->status, ModuleStatus::Cancelled);
  EXPECT_EQ(counters().count("m2"), 0);
  // A later run works again (cancellation is not sticky).
  net.setParameterText("m1", "wait_for_cancel", "false");
  net.setParameterText("m3", "wait_for_cancel", "false");
  EXPECT_TRUE(exec.execute(net).success);
}

TEST_F(ExecFixture, ObserverSeesEveryTransitionAndReportIsJson) {
  Network net(reg);
  net.addModule("Number");
  net.addModule("Number");
  net.connect("m1", 0, "m2", 0);
  net.setParameterText("m1", "fail", "true");
  std::mutex m;
  std::vector<std::string> seen;
  ExecutionObserver obs;
  obs.onStatus = [&](const std::string& id, ModuleStatus s) {
    std::lock_guard<std::mutex> l(m);
    seen.push_back(id + ":" + moduleStatusName(s));
  };
  Executor exec;
  const auto sum = exec.execute(net, Executor::Options{}, obs);
  EXPECT_EQ(seen, (std::vector<std::string>{"m1:waiting", "m2:waiting", "m1:running", "m1:error",
                                            "m2:skipped"}));
  const std::string json = executionReportJson("x.srn", net, exec, sum);
  EXPECT_NE(json.find("\"success\": false"), std::string::npos);
  EXPECT_NE(json.find("\"error\": \"m1: asked to fail\""), std::string::npos);
  EXPECT_NE(json.find("\"skipped_because\": \"m1\""), std::string::npos);
}

// releaseConsumed (the headless runner): an output goes as soon as the last module consuming it
// has finished, the data itself freed; outputs nothing consumes stay; what was released runs again
// next time, with the same results.
TEST_F(ExecFixture, ReleasedOutputsAreFreedAfterTheirLastConsumerAndRunAgainNextTime) {
  Network net(reg);
  // m1 -> m2 -> m4, m1 -> m3
  for (int i = 0; i < 4; ++i) net.addModule("Number");
  net.setParameterText("m1", "value", "1");
  net.setParameterText("m2", "value", "10");
  net.setParameterText("m3", "value", "100");
  net.setParameterText("m4", "value", "1000");
  net.connect("m1", 0, "m2", 0);
  net.connect("m1", 0, "m3", 0);
  net.connect("m2", 0, "m4", 0);
  Executor exec;
  Executor::Options opt;
  opt.releaseConsumed = true;
  std::weak_ptr<const DataObject> first;
  std::mutex m;
  ExecutionObserver obs;
  obs.onStatus = [&](const std::string& id, ModuleStatus st) {
    if (id != "m1" || st != ModuleStatus::Done) return;
    std::lock_guard<std::mutex> lock(m);
    first = exec.state("m1")->outputs.at(0);
  };
  auto sum = exec.execute(net, opt, obs);
  ASSERT_TRUE(sum.success);
  EXPECT_TRUE(first.expired()); // freed, not only forgotten
  for (const char* id : {"m1", "m2"}) {
    EXPECT_TRUE(exec.state(id)->released) << id;
    EXPECT_TRUE(exec.state(id)->outputs.empty()) << id;
    EXPECT_EQ(exec.state(id)->status, ModuleStatus::Done) << id;
  }
  for (const char* id : {"m3", "m4"}) {
    EXPECT_FALSE(exec.state(id)->released) << id;
    EXPECT_EQ(exec.state(id)->outputs.size(), 1u) << id;
  }
  EXPECT_DOUBLE_EQ(value(exec, "m3"), 101.0);
  EXPECT_DOUBLE_EQ(value(exec, "m4"), 1011.0);
  sum = exec.execute(net, opt, obs);
  EXPECT_EQ(sum.ran, 4); // m1, m2 had no result left; m3, m4 get new inputs
  EXPECT_DOUBLE_EQ(value(exec, "m4"), 1011.0);
  EXPECT_EQ(counters().count("m1"), 2);

  // Without it (the node editor) everything stays and nothing runs again.
  Executor keep;
  keep.execute(net);
  sum = keep.execute(net);
  EXPECT_EQ(sum.reused, 4);
  EXPECT_FALSE(keep.state("m1")->released);
}
