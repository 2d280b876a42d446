// Live progress (issue 29): the executor's throttled, monotone progress events, the progress
// board's estimates, the terminal's live line and the JSON lines of `--progress jsonl`.
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <mutex>
#include <vector>

#include "Dataflow/Executor.h"
#include "Dataflow/RunProgress.h"
#include "TestModules.h"

using namespace tetflow;

namespace {
using Clock = RunProgress::Clock;
Clock::time_point at(Clock::time_point t0, double s) {
  return t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}
} // namespace

TEST(RunProgressEvents, AreThrottledNeverDecreaseWithinAStageAndEndEachStageAtOne) {
  ModuleRegistry reg;
  test::registerTestModules(reg);
  Network net(reg);
  const auto a = net.addModule("Staged");
  net.setParameterText(a, "stages", "3");
  net.setParameterText(a, "stage_seconds", "0.5");
  struct Event {
    std::string stage;
    double fraction;
  };
  std::mutex m;
  std::vector<Event> events;
  ExecutionObserver obs;
  obs.onProgress = [&](const std::string& id, const std::string& stage, double f) {
    EXPECT_EQ(id, a);
    const std::lock_guard<std::mutex> lock(m);
    events.push_back({stage, f});
  };
  test::reportCalls() = 0;
  Executor exec;
  ASSERT_TRUE(exec.execute(net, {}, obs).success);
  // Each stage: 0 first, then rising (the out-of-order reports of the lagging thread never show),
  // then 1; at most one event per 0.1 s in between.
  std::map<std::string, std::vector<double>> byStage;
  std::vector<std::string> order;
  for (const auto& e : events) {
    if (byStage[e.stage].empty()) order.push_back(e.stage);
    byStage[e.stage].push_back(e.fraction);
  }
  ASSERT_EQ(order, (std::vector<std::string>{"stage 1", "stage 2", "stage 3"}));
  for (const auto& [stage, fs] : byStage) {
    ASSERT_GE(fs.size(), 3u) << stage; // 0, at least one report, 1
    EXPECT_EQ(fs.front(), 0.0) << stage;
    EXPECT_EQ(fs.back(), 1.0) << stage;
    for (size_t i = 1; i < fs.size(); ++i) EXPECT_GT(fs[i], fs[i - 1]) << stage << " event " << i;
    EXPECT_LE(fs.size(), 2u + 6u) << stage; // 0.5 s at one event per 0.1 s, give or take a tick
  }
  // The module reported far more often than the observer heard.
  EXPECT_GT(test::reportCalls().load(), 1000);
  // Stage order in the events follows the events' own order: stage 1's last event precedes
  // stage 2's first.
  size_t last1 = 0, first2 = events.size();
  for (size_t i = 0; i < events.size(); ++i) {
    if (events[i].stage == "stage 1") last1 = i;
    if (events[i].stage == "stage 2") first2 = std::min(first2, i);
  }
  EXPECT_LT(last1, first2);
}

TEST(RunProgressBoard, EstimatesWhatIsLeftOfAStageFromItsRateSoFar) {
  const auto t0 = Clock::now();
  RunProgress board(t0);
  board.started("m3", "CleaveMesh", at(t0, 1.0));
  EXPECT_TRUE(board.entry("m3", at(t0, 1.0)));
  EXPECT_FALSE(board.entry("m4", at(t0, 1.0)));
  board.progress("m3", "stencil", 0.0, at(t0, 2.0));
  auto e = *board.entry("m3", at(t0, 2.5));
  EXPECT_EQ(e.name, "CleaveMesh");
  EXPECT_EQ(e.stage, "stencil");
  EXPECT_FALSE(e.fractionKnown);
  EXPECT_DOUBLE_EQ(e.seconds, 1.5);
  EXPECT_DOUBLE_EQ(e.stageSeconds, 0.5);
  EXPECT_LT(e.secondsLeft, 0); // no fraction: no estimate
  // A quarter in 2 s: 6 s more at that rate, 1 s of which has passed at t = 5.
  board.progress("m3", "stencil", 0.25, at(t0, 4.0));
  e = *board.entry("m3", at(t0, 5.0));
  EXPECT_TRUE(e.fractionKnown);
  EXPECT_NEAR(e.secondsLeft, 5.0, 1e-9);
  EXPECT_NEAR(e.stageSeconds, 3.0, 1e-9);
  // Too little to go by: under 1 % done, or under half a second of the stage.
  board.progress("m3", "interfaces", 0.0, at(t0, 6.0));
  board.progress("m3", "interfaces", 0.5, at(t0, 6.2));
  EXPECT_LT(board.entry("m3", at(t0, 6.3))->secondsLeft, 0);
  EXPECT_NEAR(board.entry("m3", at(t0, 6.3))->stageSeconds, 0.3, 1e-9);
  // The same stage name again (a second "repair check") starts the stage clock again.
  board.progress("m3", "interfaces", 1.0, at(t0, 7.0));
  board.progress("m3", "interfaces", 0.0, at(t0, 8.0));
  EXPECT_NEAR(board.entry("m3", at(t0, 9.0))->stageSeconds, 1.0, 1e-9);
  // Modules are listed in the order they started; an ended one goes.
  board.started("m1", "CreatePhantom", at(t0, 9.0));
  auto running = board.running(at(t0, 9.5));
  ASSERT_EQ(running.size(), 2u);
  EXPECT_EQ(running[0].id, "m3");
  EXPECT_EQ(running[1].id, "m1");
  board.ended("m3");
  running = board.running(at(t0, 9.5));
  ASSERT_EQ(running.size(), 1u);
  EXPECT_EQ(running[0].id, "m1");
  // Progress of a module that is not running is ignored.
  board.progress("m9", "x", 0.5, at(t0, 9.5));
  EXPECT_FALSE(board.entry("m9", at(t0, 9.5)));
}

TEST(RunProgressLine, ShowsStagePercentAndEstimateAndFitsTheWidth) {
  RunProgress::Entry e;
  e.id = "m3";
  e.name = "CleaveMesh";
  e.seconds = 12.34;
  EXPECT_EQ(liveProgressLine(e), "m3    CleaveMesh             running    12.3 s");
  e.stage = "stencil";
  EXPECT_EQ(liveProgressLine(e), "m3    CleaveMesh             running    12.3 s  stencil");
  e.fraction = 0.456;
  e.fractionKnown = true;
  e.secondsLeft = 14.6;
  EXPECT_EQ(liveProgressLine(e), "m3    CleaveMesh             running    12.3 s  stencil 45 % (~15 s left)");
  EXPECT_EQ(liveStageText(e), "stencil 45 % (~15 s left)");
  e.secondsLeft = 600;
  EXPECT_EQ(liveStageText(e), "stencil 45 % (~10 min left)");
  e.fraction = 0.999;
  e.secondsLeft = -1;
  EXPECT_EQ(liveStageText(e), "stencil 99 %"); // 100 % only when it is done
  // Cut to the width, never inside a UTF-8 character.
  EXPECT_EQ(liveProgressLine(e, 20), "m3    CleaveMesh    ");
  e.stage = "\xC3\xA9tape"; // "étape"
  const std::string full = liveProgressLine(e);
  const size_t at = full.find('\xC3');
  EXPECT_EQ(liveProgressLine(e, at + 1), full.substr(0, at));
  EXPECT_EQ(liveProgressLine(e, at + 2), full.substr(0, at + 2));
}

TEST(RunProgressJsonl, WritesOneObjectPerEventWithTheDocumentedFields) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  RunProgress board;
  JsonlProgressWriter w(f, board);
  board.started("m2", "Cleave\"Mesh");
  w.start("m2", "Cleave\"Mesh");
  board.progress("m2", "snap", 0.5);
  w.progress("m2", "snap", 0.5);
  w.end("m2", "Cleave\"Mesh", "done", 1.25);
  Executor::Summary sum;
  sum.ran = 1;
  sum.seconds = 1.5;
  w.finish(sum);
  std::rewind(f);
  std::vector<std::string> lines;
  char buf[1024];
  while (std::fgets(buf, sizeof buf, f)) lines.emplace_back(buf);
  std::fclose(f);
  ASSERT_EQ(lines.size(), 4u);
  for (const auto& l : lines) {
    EXPECT_EQ(l.front(), '{');
    EXPECT_EQ(l.substr(l.size() - 2), "}\n");
    EXPECT_NE(l.find("\"t\": "), std::string::npos) << l;
  }
  EXPECT_NE(lines[0].find("\"event\": \"start\""), std::string::npos);
  EXPECT_NE(lines[0].find("\"name\": \"Cleave\\\"Mesh\""), std::string::npos) << lines[0];
  EXPECT_NE(lines[1].find("\"event\": \"progress\", "), std::string::npos);
  EXPECT_NE(lines[1].find("\"module\": \"m2\""), std::string::npos);
  EXPECT_NE(lines[1].find("\"stage\": \"snap\", \"fraction\": 0.5000, \"elapsed\": "), std::string::npos) << lines[1];
  EXPECT_NE(lines[1].find("\"stage_elapsed\": "), std::string::npos);
  EXPECT_NE(lines[2].find("\"event\": \"end\""), std::string::npos);
  EXPECT_NE(lines[2].find("\"status\": \"done\", \"elapsed\": 1.250}"), std::string::npos) << lines[2];
  EXPECT_NE(lines[3].find("\"event\": \"finish\""), std::string::npos);
  EXPECT_NE(lines[3].find("\"success\": true, \"ran\": 1, \"reused\": 0"), std::string::npos) << lines[3];
}
