// tetflow: the headless runner (no Qt). See docs/headless.md and DESIGN §5.
//
//   tetflow run NET.srn [--set m3.param=value]... [--report out.json] [--threads N] [--max-memory SIZE] [--quiet]
//                       [--progress auto|none|jsonl] [--progress-file FILE]
//   tetflow -E NET.srn ...          (SCIRun's spelling of `run`)
//   tetflow mesh LABELS [-o MESH] [--cell-size MM | --adaptive [--min-size MM] [--max-size MM]]
//                [--background regular|octree|particles] [--format F] [--certify] [--save-net NET.srn]
//   tetflow validate NET.srn [--set ...]
//   tetflow list-modules
//   tetflow describe MODULE
//   tetflow describe --markdown [FILE]   the module reference (docs/modules.md)
//   tetflow certify MESH [LABELS] [--max-volume-error PCT] [--small-component-allowance X] [--require-components]
//                   [--forbid-spurious-contacts] [--strict] [--output MESH] [--report out.json]
//
// Exit status: 0 all modules succeeded; 1 a module failed (downstream ones skipped); 2 bad
// command-line arguments; 3 the network file cannot be loaded or a --set is invalid for it;
// 4 the --report or --progress-file file cannot be written; 130 cancelled by Ctrl-C, 143 by SIGTERM.
#include <atomic>
#include <cmath>
#include <cerrno>
#include <cstring>
#include <memory>
#include <unistd.h>
#include <chrono>
#include <csignal>
#include <optional>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "Algorithms/Core/MemoryBudget.h"
#include "Algorithms/IO/FileUtil.h"
#include "Algorithms/FEM/Petsc/PetscLinearSolver.h"
#include "Dataflow/Executor.h"
#include "Dataflow/ModuleReference.h"
#include "Dataflow/NetworkFile.h"
#include "Dataflow/RunReport.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Modules/MeshLabelsNet.h"
#include "Modules/StandardModules.h"
#include "Dataflow/RunProgress.h"
#include "Interface/HugePages.h"
#include "Interface/TerminalProgress.h"

using namespace tetflow;

namespace {

constexpr int kExitModuleFailed = 1;
constexpr int kExitUsage = 2;
constexpr int kExitLoad = 3;
constexpr int kExitReport = 4;
constexpr int kExitCancelled = 130;  // SIGINT
constexpr int kExitTerminated = 143; // SIGTERM

// SIGINT (Ctrl-C) and SIGTERM cancel the run: modules stop at their next check, temp files
// go, no output is replaced; the exit status is 128 + the signal (130, 143).
// Written by the signal handler (on whichever thread takes the signal) and read by the watcher
// thread: a lock-free atomic, which is both signal-safe and free of data races (a volatile
// sig_atomic_t is only the former; ThreadSanitizer reported it).
std::atomic<int> g_interrupted{0};
static_assert(std::atomic<int>::is_always_lock_free);
extern "C" void onSigint(int sig) {
  g_interrupted = sig;
  std::signal(sig, SIG_DFL); // a second signal ends the process at once
}

const char* kUsage =
    "usage:\n"
    "  tetflow run NET.srn [options]     execute a network (also: tetflow -E NET.srn)\n"
    "  tetflow mesh LABELS [options]     mesh a label volume file (the network the shipped nets use)\n"
    "  tetflow validate NET.srn [--set]  load and check a network without running it\n"
    "  tetflow list-modules              list the available modules\n"
    "  tetflow describe MODULE           ports and parameters of a module\n"
    "  tetflow describe --markdown [FILE] every module as Markdown (docs/modules.md); stdout without FILE\n"
    "  tetflow certify MESH LABELS [opts] compare a mesh with its label volume (the certificate)\n"
    "  tetflow certify MESH              the quality of a mesh alone (any mesh format, e.g. Gmsh .msh)\n"
    "options for run:\n"
    "  --set ID.PARAM=VALUE   override a parameter (repeatable), e.g. --set m3.alpha_long=0.25\n"
    "  --report FILE.json     write every module's report, timings and errors as JSON\n"
    "  --output-dir DIR       write relative output files under DIR (created if missing)\n"
    "  --threads N            worker threads and threads per module (default: all cores)\n"
    "  --max-memory SIZE      memory budget, e.g. 8G or 512M (default: the machine's available\n"
    "                         memory); a module whose estimate exceeds it is refused before it\n"
    "                         allocates, naming the parameter and a value that fits\n"
    "  --quiet                print only errors (and no live progress lines)\n"
    "  --progress MODE        auto: on a terminal, a live line per running module (stage, percent,\n"
    "                         elapsed time) until its summary line replaces it; none: no live lines;\n"
    "                         jsonl: one JSON object per progress event on stderr instead\n"
    "  --progress-file FILE   write the JSON progress events to FILE as they happen\n"
    "options for mesh (also every option for run):\n"
    "  -o, --output MESH      the mesh file (default: the volume's name with .vtu, in the current folder)\n"
    "  --format F             vtu, vtk, msh, msh22, msh22_binary or tetgen (default: from MESH's extension)\n"
    "  --background B         regular (default), octree or particles; octree and particles follow a\n"
    "                         sizing field from the image's features\n"
    "  --adaptive             the same as --background octree\n"
    "  --cell-size MM         regular: the lattice's cell edge (default 4 x the voxel size; with the\n"
    "                         thin-layer refinement, the power of two times the voxel nearest to it)\n"
    "  --min-size MM, --max-size MM  octree, particles: the element sizes' range (default 4 x and\n"
    "                         16 x the voxel size; particles 2 x and 16 x)\n"
    "  --label-table FILE     tissue names for the labels (default: a table beside the volume)\n"
    "  --max-tets N           at most N tets: every size grows (the cell, the sizing field) until the\n"
    "                         mesh is predicted to fit; refused, naming the layer, when it cannot\n"
    "  --keep-exterior        keep label 0 outside the body (by default it is stripped when the box's\n"
    "                         faces carry it: the air around a head)\n"
    "  --certify              fail unless every label is within 1.5 %, every component is kept, no\n"
    "                         spurious contact appears and every tet is in [10, 160] deg\n"
    "  --save-net NET.srn     also write the network, to open in tetflow-gui or run again\n"
    "  --no-run               with --save-net: write the network, do not run it\n"
    "options for certify (also --report, --threads, --max-memory, --quiet):\n"
    "  --max-volume-error PCT fail when a label's |volume error| exceeds PCT percent and its\n"
    "                         allowance (h^3 for each component smaller than h^3, h the local element edge)\n"
    "  --small-component-allowance X  that allowance times X (default 1; 0 = percentages only)\n"
    "  --require-components   fail on a lost, split, merged or spurious component\n"
    "  --forbid-spurious-contacts  fail when labels touch in the mesh but not in the image\n"
    "  --strict               all three (volume error 3 % unless given)\n"
    "  --output MESH          write the mesh with the certificate_flags cell field\n"
    "exit status: 0 success, 1 module failed, 2 bad arguments, 3 network cannot be loaded,\n"
    "             4 report or progress file cannot be written, 130 cancelled (Ctrl-C), 143 terminated (SIGTERM)\n";

int usageError(const std::string& msg) {
  std::cerr << "tetflow: " << msg << "\n" << kUsage;
  return kExitUsage;
}

struct RunArgs {
  std::string net;
  std::vector<std::string> sets;
  std::string report;
  std::string outputDir;
  int threads = 0;
  bool quiet = false;
  std::string progress = "auto"; // auto, none, jsonl
  std::string progressFile;
};

// --max-memory SIZE: sets the process's memory budget; returns an error message or "".
std::string applyMaxMemory(const std::string& size) {
  try {
    setMemoryLimit(parseMemorySize(size, "--max-memory"));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// Parses options after the command; returns an error message or "".
std::string parseRunArgs(const std::vector<std::string>& a, size_t start, RunArgs& r, bool allowRunOptions) {
  for (size_t i = start; i < a.size(); ++i) {
    const std::string& s = a[i];
    auto value = [&](const std::string& opt) -> std::string {
      if (i + 1 >= a.size()) throw std::invalid_argument(opt + " needs a value");
      return a[++i];
    };
    try {
      if (s == "--set") r.sets.push_back(value(s));
      else if (s.rfind("--set=", 0) == 0) r.sets.push_back(s.substr(6));
      else if (allowRunOptions && s == "--report") r.report = value(s);
      else if (allowRunOptions && s == "--output-dir") r.outputDir = value(s);
      else if (allowRunOptions && s == "--threads") {
        const std::string v = value(s);
        size_t used = 0;
        int n = -1;
        try { n = std::stoi(v, &used); } catch (...) {}
        if (used != v.size() || n < 1 || n > 1024) return "--threads '" + v + "' must be a whole number from 1 to 1024";
        r.threads = n;
      } else if (allowRunOptions && s == "--max-memory") {
        if (auto err = applyMaxMemory(value(s)); !err.empty()) return err;
      } else if (allowRunOptions && s == "--quiet") r.quiet = true;
      else if (allowRunOptions && s == "--progress") {
        r.progress = value(s);
        if (r.progress != "auto" && r.progress != "none" && r.progress != "jsonl")
          return "--progress '" + r.progress + "' must be auto, none or jsonl";
      } else if (allowRunOptions && s == "--progress-file") r.progressFile = value(s);
      else if (!s.empty() && s[0] == '-') return "unknown option '" + s + "'";
      else if (r.net.empty()) r.net = s;
      else return "unexpected argument '" + s + "' (one network file at a time)";
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
  }
  if (r.net.empty()) return "no network file given";
  return "";
}

// Applies --set overrides; returns problems (empty when all applied). A relative file name given
// on the command line means what the shell means by it: relative to the current folder (an
// output's, with --output-dir, relative to that folder instead, as the net's own outputs).
std::vector<std::string> applySets(Network& net, const std::vector<std::string>& sets, bool outputDirGiven) {
  std::vector<std::string> problems;
  for (const auto& s : sets) {
    const auto eq = s.find('=');
    const auto dot = s.find('.');
    if (eq == std::string::npos || dot == std::string::npos || dot > eq || dot == 0 || dot + 1 == eq) {
      problems.push_back("--set '" + s + "': expected ID.PARAM=VALUE, e.g. m3.alpha_long=0.25");
      continue;
    }
    const std::string id = s.substr(0, dot), param = s.substr(dot + 1, eq - dot - 1);
    std::string val = s.substr(eq + 1);
    if (const ModuleNode* m = net.module(id))
      if (const ParamSpec* spec = m->info->param(param))
        if (spec->type == ParamType::String && (spec->isInputPath || (spec->isOutputPath && !outputDirGiven)) &&
            !val.empty() && std::filesystem::path(val).is_relative())
          val = std::filesystem::absolute(val).lexically_normal().string();
    try {
      net.setParameterText(id, param, val);
    } catch (const InputError& e) {
      problems.push_back("--set '" + s + "': " + e.what());
    }
  }
  return problems;
}

int loadForCli(const std::string& path, const ModuleRegistry& reg, const std::vector<std::string>& sets,
               std::unique_ptr<Network>& out, bool outputDirGiven = false) {
  try {
    out = std::make_unique<Network>(loadNetwork(path, reg));
  } catch (const InputError& e) {
    std::cerr << "tetflow: " << e.what() << "\n";
    return kExitLoad;
  }
  const auto problems = applySets(*out, sets, outputDirGiven);
  for (const auto& p : problems) std::cerr << "tetflow: " << p << "\n";
  return problems.empty() ? 0 : kExitLoad;
}

// Outputs that would overwrite an input of the net or another output: printed, true when any.
bool reportFileConflicts(const Network& net, const std::string& path) {
  const auto conflicts = net.fileConflicts();
  for (const auto& c : conflicts) std::cerr << "tetflow: " << path << ": " << c << "\n";
  return !conflicts.empty();
}

// A file the runner itself writes (--report, --progress-file) must not be the network file or a
// file one of its modules reads or writes: returns the message naming the clash, or "".
std::string runnerFileClash(const Network& net, const std::string& netPath, const std::string& opt,
                            const std::string& file) {
  namespace fs = std::filesystem;
  auto canon = [](const std::string& p) {
    std::error_code ec;
    const fs::path c = fs::weakly_canonical(fs::absolute(p), ec);
    return (ec ? fs::path(p).lexically_normal() : c).string();
  };
  const std::string f = canon(file);
  for (const auto& u : net.fileUses())
    if (u.resolved == f)
      return opt + " " + file + " is the file module " + u.module + " " + (u.output ? "writes" : "reads") +
             " through " + u.param + ": choose another file name";
  if (!netPath.empty() && f == canon(netPath)) return opt + " " + file + " is the network file itself: choose another file name";
  return "";
}

std::string summaryLine(const ModuleNode& m, const ModuleState& s) {
  char head[160];
  std::snprintf(head, sizeof head, "%-5s %-22s %-9s %8.3f s", m.id.c_str(), m.info->name.c_str(),
                s.reused ? "reused" : moduleStatusName(s.status), s.seconds);
  std::string line = head;
  if (s.status == ModuleStatus::Error) return line + "  " + s.error;
  if (s.status == ModuleStatus::Skipped) return line + "  (not run: upstream " + s.skippedBecause + " failed)";
  for (const auto& k : m.info->summaryKeys)
    if (const ReportValue* v = s.report.find(k)) line += "  " + k + "=" + formatReportValue(*v);
  return line;
}

// Runs a loaded network with the runner's printing, Ctrl-C handling, report and exit codes.
// `after` (optional) sees the executor once the run is over, before the report is written.
int runNetwork(Network* net, const RunArgs& args,
               const std::function<void(const Executor&)>& after = {}) {
  if (!args.outputDir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(args.outputDir, ec);
    if (ec) {
      std::cerr << "tetflow: --output-dir " << args.outputDir << ": cannot create it (" << ec.message() << ")\n";
      return kExitUsage;
    }
    net->setOutputDir(args.outputDir);
  }
  if (reportFileConflicts(*net, args.net)) return kExitLoad;
  for (const auto& [opt, file] : {std::pair<std::string, std::string>{"--report", args.report},
                                  {"--progress-file", args.progressFile}})
    if (!file.empty())
      if (const auto clash = runnerFileClash(*net, args.net, opt, file); !clash.empty()) {
        std::cerr << "tetflow: " << clash << "\n";
        return kExitReport;
      }
  // Check the report target before spending time on the run.
  if (!args.report.empty()) {
    try {
      AtomicOutputFile probe(args.report);
    } catch (const InputError& e) {
      std::cerr << "tetflow: --report: " << e.what() << "\n";
      return kExitReport;
    }
  }
  // Progress: the JSON events (to stderr or --progress-file, written as they happen: a log to
  // follow, not a result, so not written atomically) and the terminal's live lines.
  RunProgress board;
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> progressFile(nullptr, &std::fclose);
  std::optional<JsonlProgressWriter> jsonl;
  if (!args.progressFile.empty()) {
    progressFile.reset(std::fopen(args.progressFile.c_str(), "w"));
    if (!progressFile) {
      std::cerr << "tetflow: --progress-file " << args.progressFile << ": cannot write it (" << std::strerror(errno)
                << ")\n";
      return kExitReport;
    }
    jsonl.emplace(progressFile.get(), board);
  } else if (args.progress == "jsonl") {
    jsonl.emplace(stderr, board);
  }
  std::unique_ptr<TerminalProgress> live;
  if (!args.quiet && args.progress == "auto" && !(jsonl && !progressFile) && TerminalProgress::usable(STDERR_FILENO))
    live = std::make_unique<TerminalProgress>(board, STDERR_FILENO);
  Executor exec;
  Executor::Options opt;
  opt.threads = args.threads;
  opt.releaseConsumed = true; // one run, nothing reused after it: memory back as soon as it can go
  std::mutex printMutex;
  auto print = [&](const std::function<void()>& lines) {
    if (live) return live->above(lines);
    const std::lock_guard<std::mutex> lock(printMutex);
    lines();
  };
  ExecutionObserver obs;
  obs.onStatus = [&](const std::string& id, ModuleStatus st) {
    if (st == ModuleStatus::Waiting) return;
    const ModuleNode* m = net->module(id);
    if (!m) return;
    if (st == ModuleStatus::Running) {
      board.started(id, m->info->name);
      if (jsonl) jsonl->start(id, m->info->name);
      return;
    }
    board.ended(id);
    const ModuleState* s = exec.state(id);
    if (!s) return;
    if (jsonl) jsonl->end(id, m->info->name, s->reused ? "reused" : moduleStatusName(st), s->seconds);
    const bool bad = st == ModuleStatus::Error;
    if (args.quiet && !bad) return;
    print([&] {
      (bad ? std::cerr : std::cout) << summaryLine(*m, *s) << "\n";
      if (!args.quiet)
        for (const auto& msg : s->messages) std::cout << "      " << msg << "\n";
      (bad ? std::cerr : std::cout).flush();
    });
  };
  // Without live lines or JSON events nobody listens: the modules' reports then cost what they
  // cost before there was live progress (one virtual call that returns).
  if (live || jsonl)
    obs.onProgress = [&](const std::string& id, const std::string& stage, double fraction) {
      board.progress(id, stage, fraction);
      if (jsonl) jsonl->progress(id, stage, fraction);
    };

  g_interrupted = 0;
  std::signal(SIGINT, onSigint);
  std::signal(SIGTERM, onSigint);
  std::atomic<bool> done{false};
  std::thread watcher([&] {
    while (!done.load()) {
      if (g_interrupted) {
        exec.cancel();
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  });
  Executor::Summary sum;
  try {
    sum = exec.execute(*net, opt, obs);
  } catch (const std::exception& e) {
    done = true;
    watcher.join();
    if (live) live->stop();
    std::cerr << "tetflow: " << e.what() << "\n";
    return kExitModuleFailed;
  }
  done = true;
  watcher.join();
  if (live) live->stop();
  if (jsonl) jsonl->finish(sum);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  if (after) after(exec);

  if (!args.quiet) {
    std::printf("%s: %d ran, %d reused, %d failed, %d skipped, %d cancelled in %.3f s\n",
                args.net.c_str(), sum.ran, sum.reused, sum.failed, sum.skipped, sum.cancelled,
                sum.seconds);
  }
  if (!args.report.empty()) {
    try {
      AtomicOutputFile out(args.report);
      out.stream() << executionReportJson(args.net, *net, exec, sum);
      out.commit();
    } catch (const InputError& e) {
      std::cerr << "tetflow: --report: " << e.what() << "\n";
      return kExitReport;
    }
  }
  if (sum.cancelled > 0 || g_interrupted) {
    std::cerr << "tetflow: cancelled" << (g_interrupted == SIGTERM ? " (SIGTERM)" : "") << "\n";
    return g_interrupted == SIGTERM ? kExitTerminated : kExitCancelled;
  }
  return sum.success ? 0 : kExitModuleFailed;
}

int cmdRun(const RunArgs& args, const ModuleRegistry& reg) {
  std::unique_ptr<Network> net;
  if (int rc = loadForCli(args.net, reg, args.sets, net, !args.outputDir.empty())) return rc;
  return runNetwork(net.get(), args);
}

// tetflow certify MESH LABELS: ReadMesh + ReadLabelVolume -> EvaluateQuality (-> WriteMesh), run
// like a network, then the certificate's figures printed as a table. With MESH alone (a mesh from
// another tool, with no voxels to compare with): its quality figures and volumes per label.
int cmdCertify(const std::vector<std::string>& a, const ModuleRegistry& reg) {
  RunArgs r;
  std::vector<std::string> files;
  std::string output, maxErr = "0", allowance;
  bool requireComponents = false, forbidContacts = false;
  for (size_t i = 1; i < a.size(); ++i) {
    const std::string& s = a[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= a.size()) throw std::invalid_argument(s + " needs a value");
      return a[++i];
    };
    try {
      if (s == "--report") r.report = value();
      else if (s == "--output") output = value();
      else if (s == "--max-volume-error") maxErr = value();
      else if (s == "--small-component-allowance") allowance = value();
      else if (s == "--require-components") requireComponents = true;
      else if (s == "--forbid-spurious-contacts") forbidContacts = true;
      else if (s == "--strict") {
        requireComponents = forbidContacts = true;
        if (maxErr == "0") maxErr = "3";
      } else if (s == "--quiet") r.quiet = true;
      else if (s == "--max-memory") {
        if (auto err = applyMaxMemory(value()); !err.empty()) return usageError(err);
      } else if (s == "--threads") {
        const std::string v = value();
        size_t used = 0;
        int n = -1;
        try { n = std::stoi(v, &used); } catch (...) {}
        if (used != v.size() || n < 1 || n > 1024) return usageError("--threads '" + v + "' must be a whole number from 1 to 1024");
        r.threads = n;
      } else if (!s.empty() && s[0] == '-') return usageError("unknown option '" + s + "' for certify");
      else files.push_back(s);
    } catch (const std::invalid_argument& e) {
      return usageError(e.what());
    }
  }
  if (files.size() != 1 && files.size() != 2)
    return usageError("certify takes a mesh file and a label volume file (or a mesh file alone: its quality only)");
  const bool withLabels = files.size() == 2;
  if (!withLabels && (requireComponents || forbidContacts || maxErr != "0"))
    return usageError("--max-volume-error, --require-components, --forbid-spurious-contacts and --strict compare "
                      "the mesh with a label volume: give one after the mesh file");
  for (const auto& f : files)
    if (!std::filesystem::exists(f)) {
      std::cerr << "tetflow: " << f << ": file not found\n";
      return kExitLoad;
    }
  Network net(reg);
  const auto abs = [](const std::string& f) { return std::filesystem::absolute(f).string(); };
  try {
    net.addModule("ReadMesh", "mesh");
    net.setParameterText("mesh", "filename", abs(files[0]));
    net.addModule("EvaluateQuality", "certificate");
    net.setParameterText("certificate", "max_volume_error", maxErr);
    if (!allowance.empty()) net.setParameterText("certificate", "small_component_allowance", allowance);
    net.setParameterText("certificate", "require_components", requireComponents ? "true" : "false");
    net.setParameterText("certificate", "forbid_spurious_contacts", forbidContacts ? "true" : "false");
    net.connect("mesh", 0, "certificate", 0);
    if (withLabels) {
      net.addModule("ReadLabelVolume", "labels");
      net.setParameterText("labels", "filename", abs(files[1]));
      net.connect("labels", 0, "certificate", 1);
    }
    if (!output.empty()) {
      net.addModule("WriteMesh", "output");
      net.setParameterText("output", "filename", abs(output));
      net.connect("certificate", 0, "output", 0);
    }
  } catch (const InputError& e) {
    std::cerr << "tetflow: " << e.what() << "\n";
    return kExitUsage;
  }
  r.net = "certify";
  return runNetwork(&net, r, [&](const Executor& exec) {
    const ModuleState* s = exec.state("certificate");
    if (!s || r.quiet || !s->report.has("tets")) return;
    const Report& rep = s->report;
    auto text = [&](const std::string& k) {
      const ReportValue* v = rep.find(k);
      return v ? formatReportValue(*v) : std::string("-");
    };
    if (!rep.has("cert_rule")) { // a mesh alone: its quality
      std::printf("quality: %s tets, %s vertices; valid %s; inverted %s, zero volume %s, duplicate %s; "
                  "boundary closed %s, non-manifold faces %s; dihedral angles [%.2f, %.2f] deg\n",
                  text("tets").c_str(), text("vertices").c_str(), text("valid").c_str(), text("inverted").c_str(),
                  text("zero_volume").c_str(), text("duplicate_tets").c_str(), text("boundary_closed").c_str(),
                  text("nonmanifold_faces").c_str(), rep.number("min_dihedral_deg"), rep.number("max_dihedral_deg"));
      std::printf("%8s %14s  %s\n", "label", "mesh mm^3", "name");
      for (const auto& [k, v] : rep.entries()) {
        const std::string pre = "material_", suf = "_volume_mm3";
        if (k.rfind(pre, 0) != 0 || k.size() <= pre.size() + suf.size() ||
            k.compare(k.size() - suf.size(), suf.size(), suf) != 0)
          continue;
        const std::string L = k.substr(pre.size(), k.size() - pre.size() - suf.size());
        if (L.find_first_not_of("-0123456789") != std::string::npos) continue;
        const std::string nameKey = pre + L + "_name";
        std::printf("%8s %14.6g  %s\n", L.c_str(), rep.number(k), rep.has(nameKey) ? text(nameKey).c_str() : "");
      }
      return;
    }
    std::printf("certificate: %s\n", text("cert_rule").c_str());
    std::printf("%8s %14s %14s %9s %12s %7s %7s %7s %9s  %s\n", "label", "voxels mm^3", "mesh mm^3", "error %",
                "allow mm^3", "image", "robust", "mesh", "agree %", "name");
    for (const auto& [k, v] : rep.entries()) {
      const std::string pre = "cert_label_", suf = "_voxel_volume_mm3";
      if (k.rfind(pre, 0) != 0 || k.size() <= suf.size() || k.compare(k.size() - suf.size(), suf.size(), suf) != 0)
        continue;
      const std::string L = k.substr(pre.size(), k.size() - pre.size() - suf.size());
      const std::string b = pre + L + "_";
      std::printf("%8s %14.6g %14.6g %+9.2f %12.4g %7s %7s %7s %9.2f  %s\n", L.c_str(),
                  rep.number(b + "voxel_volume_mm3"), rep.number(b + "mesh_volume_mm3"),
                  100.0 * rep.number(b + "volume_rel_error"), rep.number(b + "volume_allowance_mm3"),
                  text(b + "image_components").c_str(), text(b + "robust_components").c_str(),
                  text(b + "mesh_components").c_str(), 100.0 * rep.number(b + "voxel_agreement"),
                  rep.has(b + "name") ? text(b + "name").c_str() : "");
    }
    std::printf("excluded labels: %s; components lost %s, lost_small %s, split %s, merged %s, spurious %s; "
                "spurious contacts %s (%s mm^2), missing %s; non-manifold edges %s, vertices %s\n",
                text("cert_excluded_labels").c_str(), text("cert_components_lost").c_str(),
                text("cert_components_lost_small").c_str(), text("cert_components_split").c_str(),
                text("cert_components_merged").c_str(), text("cert_components_spurious").c_str(),
                text("cert_spurious_contacts").c_str(), text("cert_spurious_contact_area_mm2").c_str(),
                text("cert_missing_contacts").c_str(), text("cert_nonmanifold_edges").c_str(),
                text("cert_nonmanifold_vertices").c_str());
    auto listed = [](const std::string& k) {
      auto numbered = [&](const std::string& pre) {
        return k.rfind(pre, 0) == 0 && k.size() > pre.size() &&
               k.find_first_not_of("0123456789", pre.size()) == std::string::npos;
      };
      return numbered("cert_issue_") || numbered("cert_spurious_contact_") || numbered("cert_missing_contact_");
    };
    for (const auto& [k, v] : rep.entries())
      if (listed(k)) std::printf("  %s\n", formatReportValue(v).c_str());
  });
}

// tetflow mesh LABELS: the network of Modules/MeshLabelsNet.h for the file, its sizes chosen from
// the voxels (printed), run as `tetflow run` runs a net; --save-net writes it as a .srn.
int cmdMesh(const std::vector<std::string>& a, const ModuleRegistry& reg) {
  namespace fs = std::filesystem;
  MeshLabelsOptions o;
  std::string saveNet, background;
  bool adaptive = false, noRun = false, sizeGiven = false, rangeGiven = false, keepExterior = false;
  std::vector<std::string> rest{"mesh"}; // the options `run` has, parsed below
  for (size_t i = 1; i < a.size(); ++i) {
    const std::string& s = a[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= a.size()) throw std::invalid_argument(s + " needs a value");
      return a[++i];
    };
    auto size = [&]() {
      const std::string v = value();
      size_t used = 0;
      double d = -1;
      try { d = std::stod(v, &used); } catch (...) {}
      if (used != v.size() || !(d > 0) || !std::isfinite(d))
        throw std::invalid_argument(s + " '" + v + "' must be a size in mm above 0");
      return d;
    };
    try {
      if (s == "-o" || s == "--output") o.output = value();
      else if (s == "--format") o.format = value();
      else if (s == "--background") background = value();
      else if (s == "--adaptive") adaptive = true;
      else if (s == "--cell-size") o.cellSize = size(), sizeGiven = true;
      else if (s == "--min-size") o.minSize = size(), rangeGiven = true;
      else if (s == "--max-size") o.maxSize = size(), rangeGiven = true;
      else if (s == "--label-table") o.labelTable = value();
      else if (s == "--certify") o.certify = true;
      else if (s == "--keep-exterior") keepExterior = true;
      else if (s == "--max-tets") {
        const std::string v = value();
        size_t used = 0;
        long long n = -1;
        try { n = std::stoll(v, &used); } catch (...) {}
        if (used != v.size() || n < 1 || n > 2147483647LL)
          throw std::invalid_argument("--max-tets '" + v + "' must be a whole number of tets from 1 to 2147483647");
        o.maxTets = n;
      }
      else if (s == "--save-net") saveNet = value();
      else if (s == "--no-run") noRun = true;
      else rest.push_back(s);
    } catch (const std::invalid_argument& e) {
      return usageError(e.what());
    }
  }
  RunArgs r;
  if (auto err = parseRunArgs(rest, 1, r, true); !err.empty())
    return usageError(err == "no network file given" ? "mesh needs a label volume file" : err);
  o.labels = r.net;
  if (!background.empty()) {
    const auto b = meshBackgroundFromName(background);
    if (!b) return usageError("--background '" + background + "' must be regular, octree or particles");
    o.background = *b;
  }
  if (adaptive && o.background == MeshBackground::Regular) {
    if (!background.empty()) return usageError("--adaptive and --background regular contradict each other");
    o.background = MeshBackground::Octree;
  }
  if (sizeGiven && o.background != MeshBackground::Regular)
    return usageError("--cell-size is the regular lattice's; the " + std::string(meshBackgroundName(o.background)) +
                      " background takes --min-size and --max-size");
  if (rangeGiven && o.background == MeshBackground::Regular)
    return usageError("--min-size and --max-size are for --adaptive (or --background octree or particles); the "
                      "regular lattice takes --cell-size");
  if (o.minSize > 0 && o.maxSize > 0 && o.minSize > o.maxSize) return usageError("--min-size exceeds --max-size");
  if (noRun && saveNet.empty()) return usageError("--no-run needs --save-net (there would be nothing to do)");
  const std::string fmt = o.format;
  if (fmt != "auto" && fmt != "vtu" && fmt != "vtk" && fmt != "msh" && fmt != "msh22" && fmt != "msh22_binary" &&
      fmt != "tetgen")
    return usageError("--format '" + fmt + "' must be vtu, vtk, msh, msh22, msh22_binary or tetgen");

  // The volume, for its voxel size (it is read again by the network's ReadLabelVolume).
  GridGeometry grid;
  {
    LabelVolume v;
    try {
      v = readLabelVolume(o.labels);
    } catch (const InputError& e) {
      std::cerr << "tetflow: " << e.what() << "\n";
      return kExitLoad;
    }
    grid = v.grid;
    if (!keepExterior) o.exterior = exteriorLabelOf(v);
    if (!r.quiet) {
      std::printf("mesh: %s: %lld x %lld x %lld voxels of %s x %s x %s mm\n", o.labels.c_str(),
                  static_cast<long long>(grid.dims[0]), static_cast<long long>(grid.dims[1]),
                  static_cast<long long>(grid.dims[2]), formatDouble(grid.spacing[0]).c_str(),
                  formatDouble(grid.spacing[1]).c_str(), formatDouble(grid.spacing[2]).c_str());
    }
  }
  if (o.output.empty()) o.output = defaultMeshFileName(o.labels, fmt); // in the current folder
  const auto lines = chooseMeshSizes(o, grid);
  if (!r.quiet) {
    std::printf("mesh: %s background; %s\n", meshBackgroundName(o.background),
                o.certify ? "the run fails unless the mesh passes the certificate (--certify)"
                          : "the certificate is reported (--certify to fail on it)");
    for (const auto& l : lines) std::printf("mesh: %s\n", l.c_str());
    if (o.maxTets > 0)
      std::printf("mesh: at most %lld tets (--max-tets): the sizes grow until the mesh is predicted to fit\n",
                  static_cast<long long>(o.maxTets));
    std::printf("mesh: %s\n", o.exterior ? ("label " + std::to_string(*o.exterior) +
                                              " outside the body is stripped (--keep-exterior keeps it)").c_str()
                                           : "nothing is stripped (no label 0 on the box's faces)");
    std::printf("mesh: writing %s\n", o.output.c_str());
    std::fflush(stdout);
  }

  // Run with absolute paths; save with paths relative to the saved network's folder.
  auto absolute = [](const std::string& f) { return f.empty() ? f : fs::absolute(f).lexically_normal().string(); };
  MeshLabelsOptions run = o;
  run.labels = absolute(o.labels);
  if (r.outputDir.empty()) run.output = absolute(o.output); // else a relative -o goes under --output-dir
  run.labelTable = absolute(o.labelTable);
  std::unique_ptr<Network> net;
  try {
    net = std::make_unique<Network>(buildMeshLabelsNetwork(reg, run));
  } catch (const InputError& e) {
    std::cerr << "tetflow: " << e.what() << "\n";
    return kExitUsage;
  }
  if (!saveNet.empty()) {
    const fs::path dir = fs::absolute(saveNet).parent_path();
    auto relative = [&](const std::string& f) {
      if (f.empty()) return f;
      std::error_code ec;
      const fs::path rel = fs::relative(f, dir, ec);
      return ec || rel.empty() ? f : rel.generic_string();
    };
    MeshLabelsOptions saved = run;
    saved.labels = relative(run.labels);
    saved.output = relative(run.output);
    saved.labelTable = relative(run.labelTable);
    if (const auto clash = runnerFileClash(*net, "", "--save-net", saveNet); !clash.empty()) {
      std::cerr << "tetflow: " << clash << "\n";
      return kExitReport;
    }
    try {
      saveNetwork(saveNet, buildMeshLabelsNetwork(reg, saved));
    } catch (const InputError& e) {
      std::cerr << "tetflow: --save-net: " << e.what() << "\n";
      return kExitReport;
    }
    if (!r.quiet) std::printf("mesh: network saved to %s (tetflow-gui %s opens it)\n", saveNet.c_str(), saveNet.c_str());
    if (noRun) return 0;
  }
  if (const auto problems = applySets(*net, r.sets, !r.outputDir.empty()); !problems.empty()) {
    for (const auto& p : problems) std::cerr << "tetflow: " << p << "\n";
    return kExitLoad;
  }
  if (run.maxTets <= 0) return runNetwork(net.get(), r);
  // With a budget: the prediction is measured to overestimate a little; should the mesh still
  // come out above it, the run is made once more with the budget cut by the excess.
  int64_t tets = 0;
  auto count = [&](const Executor& e) {
    tets = 0;
    if (const auto* st = e.state("m3"); st && st->report.has("tets")) tets = int64_t(st->report.number("tets"));
  };
  int rc = runNetwork(net.get(), r, count);
  if (rc != 0 || tets <= run.maxTets) return rc;
  const int64_t tighter = std::max<int64_t>(1, int64_t(double(run.maxTets) * double(run.maxTets) / double(tets) * 0.98));
  if (!r.quiet)
    std::printf("mesh: %lld tets, above --max-tets %lld: meshing again within %lld predicted tets\n",
                static_cast<long long>(tets), static_cast<long long>(run.maxTets), static_cast<long long>(tighter));
  net->setParameterText("m2", "max_tets", std::to_string(tighter));
  rc = runNetwork(net.get(), r, count);
  if (rc == 0 && tets > run.maxTets) {
    std::cerr << "tetflow: the mesh has " << tets << " tets, above --max-tets " << run.maxTets
              << " (the prediction missed by " << formatDouble(100.0 * (double(tets) / double(tighter) - 1.0))
              << " %); give a smaller --max-tets\n";
    return kExitModuleFailed;
  }
  return rc;
}

int cmdValidate(const RunArgs& args, const ModuleRegistry& reg) {
  std::unique_ptr<Network> net;
  if (int rc = loadForCli(args.net, reg, args.sets, net)) return rc;
  // Also report required inputs left unconnected: the run would fail there.
  int missing = 0;
  for (const auto& m : net->modules())
    for (size_t p = 0; p < m.info->inputs.size(); ++p)
      if (!m.info->inputs[p].optional && !net->inputConnection(m.id, static_cast<int>(p))) {
        std::cerr << "tetflow: " << args.net << ": module " << m.id << " (" << m.info->name
                  << "): required input port " << p << " (" << m.info->inputs[p].name
                  << ") is not connected\n";
        ++missing;
      }
  if (reportFileConflicts(*net, args.net)) ++missing;
  if (missing) return kExitLoad;
  std::printf("%s: valid (%zu modules, %zu connections)\n", args.net.c_str(), net->modules().size(),
              net->connections().size());
  return 0;
}

int cmdList(const ModuleRegistry& reg) {
  std::string cat;
  for (const ModuleInfo* m : reg.all()) {
    if (m->category != cat) {
      cat = m->category;
      std::printf("%s\n", cat.c_str());
    }
    std::string desc = m->description;
    if (auto dot = desc.find(". "); dot != std::string::npos) desc = desc.substr(0, dot + 1);
    std::printf("  %-24s %s\n", m->name.c_str(), desc.c_str());
  }
  return 0;
}

int cmdDescribe(const std::string& name, const ModuleRegistry& reg) {
  const ModuleInfo* m = reg.find(name);
  if (!m) {
    std::cerr << "tetflow: unknown module '" << name << "'; `tetflow list-modules` lists them\n";
    return kExitUsage;
  }
  std::printf("%s (%s / %s)\n  %s\n", m->name.c_str(), m->package.c_str(), m->category.c_str(),
              m->description.c_str());
  auto ports = [](const char* title, const std::vector<PortSpec>& ps) {
    std::printf("%s:%s\n", title, ps.empty() ? " none" : "");
    for (size_t i = 0; i < ps.size(); ++i) {
      std::string types;
      for (PortType t : ps[i].accepts) types += (types.empty() ? "" : " or ") + std::string(portTypeName(t));
      std::printf("  %zu %-12s %-28s %s%s\n", i, ps[i].name.c_str(), types.c_str(),
                  ps[i].description.c_str(), ps[i].optional ? " (optional)" : "");
    }
  };
  ports("inputs", m->inputs);
  ports("outputs", m->outputs);
  std::printf("parameters:%s\n", m->params.empty() ? " none" : "");
  for (const auto& p : m->params) {
    std::string def = formatParam(p, p.defaultValue);
    def.insert(def.begin(), '\'');
    def.push_back('\'');
    std::printf("  %-18s = %-14s %s; %s\n", p.name.c_str(), def.c_str(), describeAllowed(p).c_str(),
                p.description.c_str());
  }
  return 0;
}

} // namespace

int main(int argc, char** argv) {
  tetflow::useTransparentHugePages(argv); // first: it may exec the program again
  // A write past the file-size limit (ulimit -f) fails with EFBIG and a clear error, instead of
  // SIGXFSZ killing the process with a temp file left behind.
  std::signal(SIGXFSZ, SIG_IGN);
  std::vector<std::string> a(argv + 1, argv + argc);
  // Under mpirun: rank 0 runs the command, the other ranks serve its PETSc solves
  // (Algorithms/FEM/Petsc/PetscLinearSolver.h). Without mpirun nothing starts here.
  std::optional<tetflow::ParallelSession> mpi;
  try {
    mpi.emplace();
  } catch (const std::exception& e) {
    std::cerr << "tetflow: " << e.what() << "\n";
    return kExitUsage;
  }
  if (mpi->worker()) return mpi->runWorker();
  if (a.empty()) return usageError("no command given");
  ModuleRegistry reg;
  registerStandardModules(reg);
  const std::string cmd = a[0];
  try {
    if (cmd == "--help" || cmd == "-h" || cmd == "help") {
      std::cout << kUsage;
      return 0;
    }
    if (cmd == "--version") {
      std::cout << "tetflow 0.1.0\n";
      return 0;
    }
    if (cmd == "run" || cmd == "-E") {
      RunArgs r;
      if (auto err = parseRunArgs(a, 1, r, true); !err.empty()) return usageError(err);
      return cmdRun(r, reg);
    }
    if (cmd == "certify") return cmdCertify(a, reg);
    if (cmd == "mesh") return cmdMesh(a, reg);
    if (cmd == "validate") {
      RunArgs r;
      if (auto err = parseRunArgs(a, 1, r, false); !err.empty()) return usageError(err);
      return cmdValidate(r, reg);
    }
    if (cmd == "list-modules") {
      if (a.size() != 1) return usageError("list-modules takes no arguments");
      return cmdList(reg);
    }
    if (cmd == "describe" && a.size() >= 2 && a[1] == "--markdown") {
      if (a.size() > 3) return usageError("describe --markdown takes at most one output file");
      const std::string page = moduleReferenceMarkdown(reg);
      if (a.size() == 2) {
        std::cout << page;
        return 0;
      }
      AtomicOutputFile out(a[2], false);
      out.stream() << page;
      out.commit();
      std::printf("%s: %zu modules\n", a[2].c_str(), reg.all().size());
      return 0;
    }
    if (cmd == "describe") {
      if (a.size() != 2) return usageError("describe takes one module name (or --markdown [FILE])");
      return cmdDescribe(a[1], reg);
    }
    return usageError("unknown command '" + cmd + "'");
  } catch (const std::exception& e) {
    std::cerr << "tetflow: internal error: " << e.what() << "\n";
    return kExitModuleFailed;
  }
}
