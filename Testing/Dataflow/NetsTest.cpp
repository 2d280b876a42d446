// The example networks in Nets/: each loads, validates and is in canonical form (loading and
// saving it gives back the same bytes, so opening and saving it unchanged never alters it).
#include <gtest/gtest.h>

#include <filesystem>

#include "Algorithms/IO/FileUtil.h"
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
