// Tests for Algorithms/Core/MemoryBudget and the stages that use it: sizes parse, the budget
// follows the limit and the resident set, and a refusal's advice is a value that then fits (regular
// lattice, sizing field), on random boxes and limits.
#include "Algorithms/Core/MemoryBudget.h"

#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <cstdlib>
#include <string>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/Cleaving/Materials.h"
#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Progress.h"
#include "Algorithms/SizingField/SizingField.h"
#include "TestUtil.h"

namespace tetflow {
namespace {

// Sets a limit for one test and clears it after.
struct LimitGuard {
  explicit LimitGuard(int64_t bytes) { setMemoryLimit(bytes); }
  ~LimitGuard() { setMemoryLimit(0); }
};

constexpr int64_t MB = 1024 * 1024;

TEST(MemoryBudget, SizesParseAndPrint) {
  EXPECT_EQ(parseMemorySize("512M", "x"), 512 * MB);
  EXPECT_EQ(parseMemorySize("8G", "x"), 8 * 1024 * MB);
  EXPECT_EQ(parseMemorySize("1.5 GB", "x"), 1536 * MB);
  EXPECT_EQ(parseMemorySize("64 mib", "x"), 64 * MB);
  EXPECT_EQ(parseMemorySize("2048", "x"), 2048);
  EXPECT_EQ(parseMemorySize("3k", "x"), 3072);
  for (const char* bad : {"", "G", "-1G", "0", "12 parsecs", "1e30T", "nan", "8G8"})
    EXPECT_THROW_MSG(parseMemorySize(bad, "--max-memory"), InputError, "--max-memory", "512M");
  EXPECT_EQ(formatBytes(512), "512 bytes");
  EXPECT_EQ(formatBytes(1536), "1.5 KB");
  EXPECT_EQ(formatBytes(2.5 * 1024 * 1024 * 1024), "2.5 GB");
  EXPECT_EQ(formatBytes(180.0 * 1024 * 1024 * 1024), "180 GB");
  EXPECT_DOUBLE_EQ(roundUpForAdvice(0.5312), 0.54);
  EXPECT_DOUBLE_EQ(roundUpForAdvice(6.9), 6.9);
  EXPECT_DOUBLE_EQ(roundDownForAdvice(1.2789), 1.2);
}

TEST(MemoryBudget, TheLimitLessTheResidentSetIsTheBudget) {
  const int64_t machine = memoryAvailable();
  EXPECT_GT(machine, 0);
  {
    LimitGuard g(residentBytes() + 64 * MB);
    EXPECT_LE(memoryAvailable(), 64 * MB + 4 * MB); // the resident set may have moved a little
    EXPECT_GE(memoryAvailable(), 32 * MB);
    EXPECT_NO_THROW(requireMemory(8.0 * MB, "a small thing", nullptr));
    EXPECT_THROW_MSG(requireMemory(4096.0 * MB, "a big thing", [](double) { return std::string("use less"); }),
                     InputError, "a big thing would need ~4.0 GB", "available (limit", "--max-memory", "; use less");
  }
  {
    LimitGuard g(residentBytes() / 2); // already over: nothing is available
    EXPECT_EQ(memoryAvailable(), 0);
  }
  EXPECT_EQ(memoryLimit(), 0);
}

double adviceValue(const std::string& msg, const std::string& prefix) {
  const size_t at = msg.find(prefix + " ");
  if (at == std::string::npos) {
    ADD_FAILURE() << "no '" << prefix << "' in: " << msg;
    return 0.0;
  }
  return std::strtod(msg.c_str() + at + prefix.size() + 1, nullptr);
}

TEST(MemoryBudget, ARegularLatticeThatDoesNotFitIsRefusedAndTheAdvisedCellSizeFits) {
  std::mt19937 rng(7);
  NullProgress np;
  for (int trial = 0; trial < 8; ++trial) {
    GridGeometry g;
    g.dims = {int64_t(20 + rng() % 80), int64_t(20 + rng() % 80), int64_t(10 + rng() % 60)};
    g.spacing = {0.5 + 0.1 * (rng() % 10), 0.5 + 0.1 * (rng() % 10), 1.0 + 0.2 * (rng() % 5)};
    const int64_t budget = (8 + int64_t(rng() % 24)) * MB;
    LimitGuard guard(residentBytes() + budget);
    // A cell size that needs about 20 times the budget.
    double box = 1.0;
    for (int a = 0; a < 3; ++a) box *= double(g.dims[a]) * g.spacing[a];
    const double cell = std::cbrt(box * 12.0 * kBccBytesPerTet / (20.0 * double(budget)));
    std::string msg;
    try {
      generateRegularBcc(g, BccParams{cell, 0.0}, np);
      ADD_FAILURE() << "cell " << cell << " fitted in " << budget;
    } catch (const InputError& e) {
      msg = e.what();
    }
    EXPECT_NE(msg.find("cell_size " ), std::string::npos) << msg;
    EXPECT_NE(msg.find("would need ~"), std::string::npos) << msg;
    const double advised = adviceValue(msg, "use cell_size >=");
    EXPECT_GT(advised, cell) << msg;
    EXPECT_LT(advised, cell * 4.0) << msg; // 20x the memory is ~2.7x the cell size
    const BackgroundMesh bg = generateRegularBcc(g, BccParams{advised, 0.0}, np);
    EXPECT_LE(kBccBytesPerTet * double(bg.mesh.numTets()), double(budget)) << msg;
  }
}

TEST(MemoryBudget, ASizingFieldThatDoesNotFitIsRefusedAndTheAdvisedRateFits) {
  auto vol = std::make_shared<LabelVolume>();
  vol->grid.dims = {40, 36, 30};
  vol->grid.spacing = {1, 1, 1};
  vol->data.assign(size_t(40 * 36 * 30), 1);
  for (size_t i = 0; i < vol->data.size(); i += 7) vol->data[i] = 2;
  LabelMaterials mats(vol, 0.5);
  NullProgress np;
  LimitGuard guard(residentBytes() + 24 * MB);
  SizingFieldParams p;
  p.sampling_rate = 8.0; // 320 x 288 x 240 samples, ~1 GB
  std::string msg;
  try {
    computeSizingField(mats, p, np);
    ADD_FAILURE() << "a sizing field of 22 M samples fitted in 24 MB";
  } catch (const InputError& e) {
    msg = e.what();
  }
  EXPECT_NE(msg.find("sampling_rate 8 ("), std::string::npos) << msg;
  const double advised = adviceValue(msg, "use sampling_rate <=");
  EXPECT_GT(advised, 0.5) << msg;
  EXPECT_LT(advised, 8.0) << msg;
  p.sampling_rate = advised;
  const GridGeometry sg = sizingGrid(vol->grid, advised, 0);
  EXPECT_LE(48.0 * double(sg.voxelCount()), 24.0 * MB) << msg;
}

} // namespace
} // namespace tetflow
