// `tetflow run`'s live progress (issue 29): the live lines on a terminal (driven under a
// pseudo-terminal), their absence in pipes and with --quiet, and the `--progress jsonl` stream.
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <vector>

#include "Algorithms/IO/FileUtil.h"
#include "TestUtil.h"

namespace {

using Result = tetflow::test::ShellResult;

// Runs the CLI with stdin, stdout and stderr on a pseudo-terminal of 120 x 40 (TERM=term);
// returns everything it wrote there. Killed after timeoutSeconds.
Result runUnderPty(const std::vector<std::string>& args, const char* term = "xterm", int timeoutSeconds = 600) {
  Result r;
  int master = -1, slave = -1;
  struct winsize ws{};
  ws.ws_row = 40;
  ws.ws_col = 120;
  if (openpty(&master, &slave, nullptr, nullptr, &ws) != 0) return r;
  std::vector<std::string> argv{TETFLOW_CLI};
  argv.insert(argv.end(), args.begin(), args.end());
  std::vector<char*> cargv;
  for (auto& a : argv) cargv.push_back(a.data());
  cargv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    setsid();
    ioctl(slave, TIOCSCTTY, 0);
    dup2(slave, 0);
    dup2(slave, 1);
    dup2(slave, 2);
    if (slave > 2) close(slave);
    close(master);
    setenv("TERM", term, 1);
    execv(cargv[0], cargv.data());
    _exit(127);
  }
  close(slave);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeoutSeconds);
  std::array<char, 4096> buf;
  for (;;) {
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid, SIGKILL);
      break;
    }
    pollfd p{master, POLLIN, 0};
    if (poll(&p, 1, 200) <= 0) continue;
    const ssize_t n = read(master, buf.data(), buf.size());
    if (n <= 0) break; // EIO once the child has closed the terminal
    r.out.append(buf.data(), size_t(n));
  }
  int status = 0;
  waitpid(pid, &status, 0);
  close(master);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// The CLI through the shell: args may carry redirections.
Result runCli(const std::string& args) { return tetflow::test::runShell(std::string(TETFLOW_CLI) + " " + args); }

// What a terminal shows after `text`: printable characters, CR, LF, and the escapes the live
// lines use (cursor up, clear to the end of the screen / line). Anything else fails the test.
std::vector<std::string> screen(const std::string& text) {
  std::vector<std::string> lines(1);
  size_t row = 0, col = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\r') col = 0;
    else if (c == '\n') {
      if (++row == lines.size()) lines.emplace_back();
      col = 0; // the terminal's output processing turns \n into \r\n anyway
    } else if (c == '\x1b') {
      EXPECT_LT(i + 1, text.size());
      EXPECT_EQ(text[i + 1], '[') << "unexpected escape at " << i;
      size_t j = i + 2;
      int n = 0;
      while (j < text.size() && std::isdigit(static_cast<unsigned char>(text[j]))) n = n * 10 + (text[j++] - '0');
      const char cmd = j < text.size() ? text[j] : '?';
      if (cmd == 'A') row = row >= size_t(std::max(n, 1)) ? row - size_t(std::max(n, 1)) : 0;
      else if (cmd == 'J') {
        lines[row].resize(std::min(lines[row].size(), col));
        lines.resize(row + 1);
      } else if (cmd == 'K') lines[row].resize(std::min(lines[row].size(), col));
      else ADD_FAILURE() << "unexpected escape ESC [" << n << cmd;
      i = j;
    } else {
      std::string& l = lines[row];
      if (l.size() < col) l.resize(col, ' ');
      if (col < l.size()) l[col] = c;
      else l.push_back(c);
      ++col;
    }
  }
  while (!lines.empty() && lines.back().empty()) lines.pop_back();
  return lines;
}

// Every live line drawn (the text between a redraw's clear and the next line end) that
// mentions `id` as a running module.
std::vector<std::string> liveLinesOf(const std::string& out, const std::string& id) {
  std::vector<std::string> found;
  std::istringstream in(out);
  std::string line;
  const std::string head = id + std::string(6 - std::min<size_t>(id.size(), 5), ' ');
  while (std::getline(in, line)) {
    const auto at = line.rfind("\x1b[J");
    std::string text = at == std::string::npos ? line : line.substr(at + 3);
    if (!text.empty() && text.back() == '\r') text.pop_back();
    if (text.rfind(head, 0) == 0 && text.find(" running ") != std::string::npos) found.push_back(text);
  }
  return found;
}

// The shipped default net, with its outputs under dir.
std::vector<std::string> defaultNetArgs(const std::string& dir) {
  return {"run", std::string(TETFLOW_SOURCE_DIR) + "/Nets/default.srn", "--output-dir", dir};
}

const char* kSmallNet = R"(<?xml version="1.0"?>
<network version="tetflow-1">
  <modules>
    <module id="m1" name="CreatePhantom">
      <var name="kind" val="{sphere}"/>
      <var name="radius" val="{10}"/>
      <var name="voxel_size" val="{1}"/>
    </module>
    <module id="m2" name="GenerateBackgroundMesh">
      <var name="cell_size" val="{3}"/>
    </module>
    <module id="m3" name="CleaveMesh"/>
    <module id="m4" name="EvaluateQuality"/>
  </modules>
  <connections>
    <connection id="c1" from="m1" fromport="0" to="m2" toport="0"/>
    <connection id="c2" from="m1" fromport="0" to="m3" toport="0"/>
    <connection id="c3" from="m2" fromport="0" to="m3" toport="1"/>
    <connection id="c4" from="m3" fromport="0" to="m4" toport="0"/>
  </connections>
</network>
)";

using tetflow::test::readText;

struct JsonEvent {
  std::string event, module, stage, status;
  double t = 0, fraction = -1;
};

// The flat objects the runner writes; fails the test on a line that is not one.
std::vector<JsonEvent> parseJsonl(const std::string& text) {
  std::vector<JsonEvent> events;
  std::istringstream in(text);
  std::string line;
  const std::regex object(R"(^\{("[a-z_]+": ("([^"\\]|\\.)*"|-?[0-9.]+|true|false)(, |\}$))+)");
  const std::regex str(R"re("([a-z_]+)": "((?:[^"\\]|\\.)*)")re"), num(R"re("([a-z_]+)": (-?[0-9.]+))re");
  while (std::getline(in, line)) {
    EXPECT_TRUE(std::regex_match(line, object)) << "not a flat JSON object: " << line;
    JsonEvent e;
    for (std::sregex_iterator it(line.begin(), line.end(), str), end; it != end; ++it) {
      const std::string k = (*it)[1], v = (*it)[2];
      if (k == "event") e.event = v;
      else if (k == "module") e.module = v;
      else if (k == "stage") e.stage = v;
      else if (k == "status") e.status = v;
    }
    for (std::sregex_iterator it(line.begin(), line.end(), num), end; it != end; ++it) {
      const std::string k = (*it)[1];
      if (k == "t") e.t = std::stod((*it)[2]);
      else if (k == "fraction") e.fraction = std::stod((*it)[2]);
    }
    events.push_back(e);
  }
  return events;
}

// The stream's promises: times in order; per module start, progress, end; within each stage
// (a run of one stage name from its 0) fractions that never decrease and end at 1; a finish.
void checkEvents(const std::vector<JsonEvent>& ev, const std::set<std::string>& modules) {
  ASSERT_FALSE(ev.empty());
  std::map<std::string, int> phase; // 0 none, 1 started, 2 ended
  std::map<std::string, std::pair<std::string, double>> stage; // module -> (stage, last fraction)
  std::map<std::string, int> stages;
  for (size_t i = 0; i < ev.size(); ++i) {
    const JsonEvent& e = ev[i];
    if (i > 0) {
      EXPECT_GE(e.t, ev[i - 1].t) << "event " << i;
    }
    if (e.event == "start") {
      EXPECT_EQ(phase[e.module], 0) << e.module;
      phase[e.module] = 1;
    } else if (e.event == "progress") {
      EXPECT_EQ(phase[e.module], 1) << e.module << " progress outside its run";
      auto& [name, last] = stage[e.module];
      EXPECT_GE(e.fraction, 0.0);
      EXPECT_LE(e.fraction, 1.0);
      if (e.fraction == 0.0) { // a stage begins; the one before ended at 1
        if (!name.empty()) {
          EXPECT_EQ(last, 1.0) << e.module << " stage " << name << " did not end at 1";
        }
        name = e.stage;
        ++stages[e.module];
      } else {
        EXPECT_EQ(e.stage, name) << e.module;
        EXPECT_GE(e.fraction, last) << e.module << " stage " << name;
      }
      last = e.fraction;
    } else if (e.event == "end") {
      EXPECT_EQ(phase[e.module], 1) << e.module;
      phase[e.module] = 2;
      EXPECT_EQ(e.status, "done") << e.module;
      if (!stage[e.module].first.empty()) {
        EXPECT_EQ(stage[e.module].second, 1.0) << e.module;
      }
    } else {
      EXPECT_EQ(e.event, "finish");
      EXPECT_EQ(i + 1, ev.size()) << "finish is the last event";
    }
  }
  EXPECT_EQ(ev.back().event, "finish");
  for (const auto& m : modules) EXPECT_EQ(phase[m], 2) << m << " has no start and end";
  EXPECT_GE(stages["m3"], 5) << "CleaveMesh's stages";
}

} // namespace

TEST(CliProgress, OnATerminalALiveLineFollowsTheRunningModuleAndGivesWayToItsSummary) {
  tetflow::test::TempDir tmp;
  const Result r = runUnderPty(defaultNetArgs(tmp.path().string()));
  ASSERT_EQ(r.code, 0) << r.out;
  // CleaveMesh runs for seconds: its live line is drawn again and again, and changes (the
  // elapsed time at least; the stage and its percent as it goes).
  const auto lines = liveLinesOf(r.out, "m3");
  ASSERT_GE(lines.size(), 3u) << r.out;
  std::set<std::string> distinct(lines.begin(), lines.end());
  EXPECT_GE(distinct.size(), 3u) << r.out;
  std::set<std::string> stagesSeen;
  const std::regex withStage(R"(running +[0-9.]+ s  ([a-z /]+[a-z]))");
  for (const auto& l : lines) {
    EXPECT_LE(l.size(), 119u) << "wider than the terminal: " << l;
    std::smatch m;
    if (std::regex_search(l, m, withStage)) stagesSeen.insert(m[1]);
  }
  EXPECT_GE(stagesSeen.size(), 1u) << r.out;
  // What stays on the screen is what a pipe gets: the summary lines, no live line left over.
  const auto shown = screen(r.out);
  std::string all;
  for (const auto& l : shown) {
    EXPECT_EQ(l.find(" running "), std::string::npos) << "live line left on screen: " << l;
    all += l + "\n";
  }
  for (const char* id : {"m1    CreatePhantom          done", "m2    GenerateBackgroundMesh done",
                         "m3    CleaveMesh             done", "m4    EvaluateQuality        done",
                         "m5    WriteMesh              done"})
    EXPECT_NE(all.find(id), std::string::npos) << id << "\n" << all;
  EXPECT_NE(all.find("5 ran, 0 reused, 0 failed"), std::string::npos) << all;
}

TEST(CliProgress, ModulesRunningAtOnceEachHaveALiveLine) {
  // Two background meshes of one phantom, side by side (two worker threads): a second or two each.
  tetflow::test::TempDir tmp;
  tetflow::test::writeBytes(tmp.file("two.srn"), R"(<?xml version="1.0"?>
<network version="tetflow-1">
  <modules>
    <module id="m1" name="CreatePhantom">
      <var name="kind" val="{head}"/>
      <var name="voxel_size" val="{2}"/>
    </module>
    <module id="m2" name="GenerateBackgroundMesh">
      <var name="cell_size" val="{4}"/>
    </module>
    <module id="m3" name="GenerateBackgroundMesh">
      <var name="cell_size" val="{5}"/>
    </module>
  </modules>
  <connections>
    <connection id="c1" from="m1" fromport="0" to="m2" toport="0"/>
    <connection id="c2" from="m1" fromport="0" to="m3" toport="0"/>
  </connections>
</network>
)");
  const Result r = runUnderPty({"run", tmp.file("two.srn"), "--threads", "2"});
  ASSERT_EQ(r.code, 0) << r.out;
  // Some redraw (the text after one clear of the screen's end, up to the next escape) holds both.
  bool both = false;
  for (size_t at = 0; !both && at != std::string::npos; at = r.out.find("\x1b[J", at + 1)) {
    const size_t from = at == 0 ? 0 : at + 3;
    const std::string frame = r.out.substr(from, r.out.find('\x1b', from) - from);
    both = frame.find("m2    GenerateBackgroundMesh running") != std::string::npos &&
           frame.find("m3    GenerateBackgroundMesh running") != std::string::npos;
  }
  EXPECT_TRUE(both) << r.out;
  std::string all;
  for (const auto& l : screen(r.out)) all += l + "\n";
  EXPECT_EQ(all.find(" running "), std::string::npos) << all;
  EXPECT_NE(all.find("m2    GenerateBackgroundMesh done"), std::string::npos) << all;
  EXPECT_NE(all.find("m3    GenerateBackgroundMesh done"), std::string::npos) << all;
}

TEST(CliProgress, PipesQuietAndProgressNoneGetNoLiveLines) {
  tetflow::test::TempDir tmp;
  const std::string net = tmp.file("n.srn");
  tetflow::test::writeBytes(net, kSmallNet);
  // A pipe: today's output, no escape codes.
  Result r = runCli("run " + net + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find(" running "), std::string::npos) << r.out;
  // A terminal with --quiet: silent.
  r = runUnderPty({"run", net, "--quiet"});
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out, "");
  // A terminal with --progress none: the summary lines alone.
  r = runUnderPty({"run", net, "--progress", "none"});
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("m3    CleaveMesh             done"), std::string::npos) << r.out;
  // A terminal that cannot move its cursor (TERM=dumb): the summary lines alone.
  r = runUnderPty({"run", net}, "dumb");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("m3    CleaveMesh             done"), std::string::npos) << r.out;
}

TEST(CliProgress, JsonlEventsComeInOrderWithEachStageRisingToOne) {
  tetflow::test::TempDir tmp;
  const std::string net = tmp.file("n.srn");
  tetflow::test::writeBytes(net, kSmallNet);
  // To stderr: stdout keeps its summary lines, stderr has the JSON lines only.
  const Result r = runCli("run " + net + " --progress jsonl 2>" + tmp.file("err.jsonl"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("m3    CleaveMesh             done"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("{\""), std::string::npos) << r.out;
  const auto events = parseJsonl(readText(tmp.file("err.jsonl")));
  checkEvents(events, {"m1", "m2", "m3", "m4"});
  EXPECT_NE(readText(tmp.file("err.jsonl")).find("\"success\": true"), std::string::npos);

  // To a file, under a terminal: the file gets the events, the terminal its live lines and
  // summaries but no JSON.
  const Result t = runUnderPty({"run", net, "--progress-file", tmp.file("p.jsonl")});
  ASSERT_EQ(t.code, 0) << t.out;
  EXPECT_EQ(t.out.find("{\""), std::string::npos) << t.out;
  checkEvents(parseJsonl(readText(tmp.file("p.jsonl"))), {"m1", "m2", "m3", "m4"});
}

TEST(CliProgress, JsonlEndsAFailedModuleAsAnErrorAndItsDownstreamAsSkipped) {
  tetflow::test::TempDir tmp;
  const std::string net = tmp.file("n.srn");
  // m1 reads a file that is not there; m2 and m3 hang on it; m4 stands alone.
  tetflow::test::writeBytes(net, R"(<?xml version="1.0"?>
<network version="tetflow-1">
  <modules>
    <module id="m1" name="ReadLabelVolume">
      <var name="filename" val="{missing.nrrd}"/>
    </module>
    <module id="m2" name="GenerateBackgroundMesh"/>
    <module id="m3" name="CleaveMesh"/>
    <module id="m4" name="CreatePhantom">
      <var name="kind" val="{sphere}"/>
      <var name="radius" val="{5}"/>
    </module>
  </modules>
  <connections>
    <connection id="c1" from="m1" fromport="0" to="m2" toport="0"/>
    <connection id="c2" from="m1" fromport="0" to="m3" toport="0"/>
    <connection id="c3" from="m2" fromport="0" to="m3" toport="1"/>
  </connections>
</network>
)");
  const Result r = runCli("run " + net + " --progress-file " + tmp.file("p.jsonl") + " 2>&1");
  EXPECT_EQ(r.code, 1) << r.out;
  const auto events = parseJsonl(readText(tmp.file("p.jsonl")));
  std::map<std::string, std::string> status;
  for (const auto& e : events)
    if (e.event == "end") status[e.module] = e.status;
  EXPECT_EQ(status["m1"], "error");
  EXPECT_EQ(status["m2"], "skipped");
  EXPECT_EQ(status["m3"], "skipped");
  EXPECT_EQ(status["m4"], "done");
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().event, "finish");
  EXPECT_NE(readText(tmp.file("p.jsonl")).find("\"success\": false"), std::string::npos);
}

TEST(CliProgress, TheMeshIsTheSameWithAndWithoutProgress) {
  tetflow::test::TempDir tmp;
  std::string text = kSmallNet;
  text.replace(text.find("  </modules>"), 0,
               "    <module id=\"m5\" name=\"WriteMesh\">\n      <var name=\"filename\" val=\"{m.vtu}\"/>\n    </module>\n");
  text.replace(text.find("  </connections>"), 0,
               "    <connection id=\"c5\" from=\"m3\" fromport=\"0\" to=\"m5\" toport=\"0\"/>\n");
  tetflow::test::writeBytes(tmp.file("n.srn"), text);
  const Result quiet = runCli("run " + tmp.file("n.srn") + " --progress none --output-dir " + tmp.file("a") + " 2>&1");
  ASSERT_EQ(quiet.code, 0) << quiet.out;
  const Result all = runUnderPty({"run", tmp.file("n.srn"), "--progress-file", tmp.file("p.jsonl"), "--output-dir",
                                  tmp.file("b")});
  ASSERT_EQ(all.code, 0) << all.out;
  EXPECT_NE(readText(tmp.file("p.jsonl")).find("\"module\": \"m5\""), std::string::npos);
  const std::string a = readText(tmp.file("a/m.vtu")), b = readText(tmp.file("b/m.vtu"));
  EXPECT_GT(a.size(), 1000u);
  EXPECT_TRUE(a == b) << "the meshes differ";
}

TEST(CliProgress, BadProgressOptionsAreRefusedAndNothingIsOverwritten) {
  tetflow::test::TempDir tmp;
  const std::string net = tmp.file("n.srn");
  tetflow::test::writeBytes(net, kSmallNet);
  Result r = runCli("run " + net + " --progress fancy 2>&1");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--progress 'fancy' must be auto, none or jsonl"), std::string::npos) << r.out;
  r = runCli("run " + net + " --progress-file " + tmp.file("no/such/dir/p.jsonl") + " 2>&1");
  EXPECT_EQ(r.code, 4);
  EXPECT_NE(r.out.find("--progress-file " + tmp.file("no/such/dir/p.jsonl") + ": cannot write it"), std::string::npos)
      << r.out;
  // The network file itself, or a file the net reads: refused before anything is written.
  r = runCli("run " + net + " --progress-file " + net + " 2>&1");
  EXPECT_EQ(r.code, 4);
  EXPECT_NE(r.out.find("is the network file itself"), std::string::npos) << r.out;
  EXPECT_EQ(readText(net), kSmallNet);
  const std::string reads = std::string(R"(<?xml version="1.0"?>
<network version="tetflow-1">
  <modules>
    <module id="m1" name="ReadLabelVolume">
      <var name="filename" val="{)") + tmp.file("in.nrrd") + R"(}"/>
    </module>
  </modules>
  <connections/>
</network>
)";
  tetflow::test::writeBytes(tmp.file("r.srn"), reads);
  tetflow::test::writeBytes(tmp.file("in.nrrd"), "precious");
  for (const char* opt : {"--progress-file", "--report"}) {
    r = runCli("run " + tmp.file("r.srn") + " " + opt + " " + tmp.file("in.nrrd") + " 2>&1");
    EXPECT_EQ(r.code, 4) << opt;
    EXPECT_NE(r.out.find("is the file module m1 reads through filename"), std::string::npos) << r.out;
    EXPECT_EQ(readText(tmp.file("in.nrrd")), "precious");
  }
}
