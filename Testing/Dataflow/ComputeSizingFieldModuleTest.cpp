// ComputeSizingField as a module: CreatePhantom / ReadIndicatorFunctions -> ComputeSizingField ->
// WriteVolume, executed by tetflow::Executor.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "Algorithms/IO/VolumeIO.h"
#include "Dataflow/Executor.h"
#include "Modules/StandardModules.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {
struct SizingPipeline {
  ModuleRegistry reg;
  Network net{reg};
  Executor exec;
  test::TempDir dir;
  explicit SizingPipeline(bool indicators = false) {
    registerStandardModules(reg);
    if (indicators) {
      net.addModule("ReadIndicatorFunctions", "in");
      std::string files;
      for (int i = 1; i <= 4; ++i) {
        if (i > 1) files += ';';
        files += std::string(TETFLOW_TEST_DATA) + "/spheres" + std::to_string(i) + ".nrrd";
      }
      net.setParameterText("in", "filenames", files);
    } else {
      net.addModule("CreatePhantom", "in");
      net.setParameterText("in", "kind", "sphere");
      net.setParameterText("in", "radius", "8");
      net.setParameterText("in", "voxel_size", "1");
    }
    net.addModule("ComputeSizingField", "sf");
    net.addModule("WriteVolume", "w");
    net.setParameterText("w", "filename", dir.file("sizing.nrrd"));
    net.connect("in", 0, "sf", 0);
    net.connect("sf", 0, "w", 0);
  }
  const Report& report(const std::string& id) { return exec.state(id)->report; }
  const ScalarVolume& field() {
    return dynamic_cast<const ScalarVolumeData&>(*exec.state("sf")->outputs.at(0)).value;
  }
};
} // namespace

TEST(ComputeSizingFieldModule, IsRegisteredWithItsContract) {
  ModuleRegistry reg;
  registerStandardModules(reg);
  const ModuleInfo* info = reg.find("ComputeSizingField");
  ASSERT_NE(info, nullptr);
  ASSERT_EQ(info->inputs.size(), 1u);
  EXPECT_EQ(info->inputs[0].name, "volume");
  EXPECT_TRUE(info->inputs[0].accepts_(PortType::LabelVolume));
  EXPECT_TRUE(info->inputs[0].accepts_(PortType::Materials));
  ASSERT_EQ(info->outputs.size(), 1u);
  EXPECT_EQ(info->outputs[0].name, "sizing");
  EXPECT_EQ(info->outputs[0].type(), PortType::ScalarVolume);
  std::vector<std::string> names;
  for (const auto& p : info->params) names.push_back(p.name);
  EXPECT_EQ(names, (std::vector<std::string>{"sampling_rate", "lipschitz", "feature_scaling", "padding",
                                             "min_size", "max_size", "blend_sigma"}));
  EXPECT_EQ(std::get<double>(info->param("sampling_rate")->defaultValue), 1.0);
  EXPECT_EQ(std::get<double>(info->param("lipschitz")->defaultValue), 0.2);
  EXPECT_EQ(std::get<double>(info->param("feature_scaling")->defaultValue), 1.0);
  EXPECT_EQ(info->param("padding")->type, ParamType::Int);
  EXPECT_EQ(std::get<int64_t>(info->param("padding")->defaultValue), 0);
  EXPECT_EQ(std::get<double>(info->param("min_size")->defaultValue), 0.0);
  EXPECT_EQ(std::get<double>(info->param("max_size")->defaultValue), 0.0);
  EXPECT_EQ(info->summaryKeys, (std::vector<std::string>{"dims", "min_size_mm", "max_size_mm"}));
}

TEST(ComputeSizingFieldModule, PhantomSizingFieldIsReportedAndWritten) {
  SizingPipeline p;
  p.net.setParameterText("sf", "padding", "2");
  p.net.setParameterText("sf", "max_size", "11");
  const auto sum = p.exec.execute(p.net);
  ASSERT_TRUE(sum.success) << p.exec.state("sf")->error << p.exec.state("w")->error;
  const Report& r = p.report("sf");
  // Sphere of radius 8 mm in a 25^3 volume of 1 mm voxels, 2 samples of padding.
  EXPECT_EQ(std::get<std::string>(*r.find("dims")), "29 x 29 x 29");
  EXPECT_NEAR(r.number("min_feature_size_mm"), 8.0, 2.0);
  EXPECT_NEAR(r.number("min_size_mm"), 8.0, 2.0);
  EXPECT_EQ(r.number("max_size_mm"), 11.0);
  EXPECT_EQ(r.number("unbounded_size_mm"), 11.0);
  EXPECT_GT(r.number("interface_samples"), 0);
  EXPECT_GT(r.number("medial_samples"), 0);
  std::vector<std::string> stages;
  for (const auto& s : p.exec.state("sf")->stages) stages.push_back(s.name);
  EXPECT_EQ(stages, (std::vector<std::string>{"sample", "interfaces", "distance", "medial", "feature size",
                                              "lipschitz"}));
  // WriteVolume takes the ScalarVolume; the file reads back with the same grid and values.
  const ScalarVolume& f = p.field();
  const ScalarVolume back = readScalarVolume(p.dir.file("sizing.nrrd"));
  EXPECT_EQ(back.grid.dims, f.grid.dims);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(back.grid.spacing[a], f.grid.spacing[a], 1e-9);
    EXPECT_NEAR(back.grid.origin[a], f.grid.origin[a], 1e-9);
  }
  EXPECT_EQ(back.data, f.data);
}

TEST(ComputeSizingFieldModule, IndicatorFunctionsAndSamplingRate) {
  SizingPipeline p(true);
  p.net.setParameterText("sf", "sampling_rate", "0.5");
  ASSERT_TRUE(p.exec.execute(p.net).success) << p.exec.state("sf")->error;
  EXPECT_EQ(std::get<std::string>(*p.report("sf").find("dims")), "14 x 14 x 14"); // 28^3 input
  EXPECT_EQ(p.report("sf").number("materials_present"), 4);
  const ScalarVolume& f = p.field();
  for (float s : f.data) ASSERT_TRUE(std::isfinite(s) && s > 0.0f);
}

TEST(ComputeSizingFieldModule, BadParametersAreInputErrorsNamingThem) {
  SizingPipeline p;
  // Out of the declared range: refused when set.
  EXPECT_THROW(p.net.setParameterText("sf", "lipschitz", "-1"), InputError);
  EXPECT_THROW(p.net.setParameterText("sf", "padding", "-2"), InputError);
  EXPECT_THROW(p.net.setParameterText("sf", "sampling_rate", "0"), InputError);
  // Each value in range, but min_size > max_size: the algorithm's input error, downstream skipped.
  p.net.setParameterText("sf", "min_size", "9");
  p.net.setParameterText("sf", "max_size", "2");
  EXPECT_FALSE(p.exec.execute(p.net).success);
  const auto* st = p.exec.state("sf");
  EXPECT_EQ(st->status, ModuleStatus::Error);
  EXPECT_EQ(st->errorKind, "input");
  EXPECT_NE(st->error.find("min_size"), std::string::npos) << st->error;
  EXPECT_NE(st->error.find("max_size"), std::string::npos) << st->error;
  EXPECT_EQ(p.exec.state("w")->status, ModuleStatus::Skipped);
  // Fixing it runs.
  p.net.setParameterText("sf", "max_size", "0");
  EXPECT_TRUE(p.exec.execute(p.net).success) << p.exec.state("sf")->error;
  EXPECT_EQ(p.report("sf").number("min_size_mm"), 9.0); // above the sphere's 8 mm
}
