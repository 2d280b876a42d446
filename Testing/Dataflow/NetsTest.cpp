// The example networks in Nets/: each loads, validates and is in canonical form (loading and
// saving it gives back the same bytes, so opening and saving it unchanged never alters it).
// With TETFLOW_REWRITE_NETS=1 in the environment the test rewrites every net in canonical form
// first (after a module gains a parameter), so the comparison then holds.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "Algorithms/IO/FileUtil.h"
#include "Dataflow/Executor.h"
#include "Dataflow/NetworkFile.h"
#include "Modules/StandardModules.h"

using namespace tetflow;

TEST(Nets, EveryExampleNetworkIsCanonical) {
  ModuleRegistry reg;
  registerStandardModules(reg);
  int count = 0;
  for (const auto& e : std::filesystem::directory_iterator(std::string(TETFLOW_SOURCE_DIR) + "/Nets")) {
    if (e.path().extension() != ".srn") continue;
    ++count;
    const auto bytes = readFileBytes(e.path().string());
    const Network net = loadNetwork(e.path().string(), reg);
    if (std::getenv("TETFLOW_REWRITE_NETS")) {
      std::ofstream(e.path()) << saveNetworkToString(net);
      continue;
    }
    EXPECT_EQ(saveNetworkToString(net), std::string(bytes.begin(), bytes.end())) << e.path();
    // Every required input is connected.
    for (const auto& m : net.modules())
      for (size_t p = 0; p < m.info->inputs.size(); ++p)
        if (!m.info->inputs[p].optional) {
          EXPECT_NE(net.inputConnection(m.id, static_cast<int>(p)), nullptr) << e.path() << " " << m.id;
        }
  }
  EXPECT_GE(count, 3);
}

// The executor itself (what the GUI's Run calls) refuses a net that writes over its own input.
TEST(Nets, TheExecutorRefusesANetThatWritesOverItsOwnInput) {
  tetflow::ModuleRegistry reg;
  tetflow::registerStandardModules(reg);
  tetflow::Network net(reg);
  net.setBaseDir("/tmp/somewhere");
  net.addModule("ReadLabelVolume", "m1");
  net.addModule("WriteVolume", "m2");
  net.setParameterText("m1", "filename", "in/labels.nrrd");
  net.setParameterText("m2", "filename", "in/./labels.nrrd");
  net.connect("m1", 0, "m2", 0);
  tetflow::Executor exec;
  try {
    exec.execute(net);
    FAIL() << "executed";
  } catch (const tetflow::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("would lose data: module m2 parameter filename writes 'in/./labels.nrrd'"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(exec.state("m1"), nullptr) << "nothing ran";
}
