// CleaveMesh and GenerateBackgroundMesh as modules: phantom -> background -> cleave -> quality.
#include <gtest/gtest.h>

#include "Dataflow/Executor.h"
#include "Modules/StandardModules.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {
struct Pipeline {
  ModuleRegistry reg;
  Network net{reg};
  Executor exec;
  Pipeline(const std::string& kind, double cell) {
    registerStandardModules(reg);
    net.addModule("CreatePhantom", "p");
    net.setParameterText("p", "kind", kind);
    net.setParameterText("p", "radius", "8");
    net.setParameterText("p", "voxel_size", "1");
    net.addModule("GenerateBackgroundMesh", "bg");
    net.setParameterText("bg", "cell_size", std::to_string(cell));
    net.addModule("CleaveMesh", "cl");
    net.addModule("EvaluateQuality", "q");
    net.connect("p", 0, "bg", 0);
    net.connect("p", 0, "cl", 0);
    net.connect("bg", 0, "cl", 1);
    net.connect("cl", 0, "q", 0);
    net.connect("p", 0, "q", 1);
  }
  const Report& report(const std::string& id) { return exec.state(id)->report; }
};
} // namespace

TEST(CleaveMeshModule, PhantomPipelineGivesAValidMeshAndReports) {
  Pipeline p("two_spheres", 1.5);
  const auto sum = p.exec.execute(p.net);
  ASSERT_TRUE(sum.success) << p.exec.state("cl")->error;
  EXPECT_EQ(std::get<bool>(*p.report("q").find("valid")), true);
  EXPECT_EQ(std::get<std::string>(*p.report("cl").find("materials_lost")), "none");
  EXPECT_EQ(std::get<std::string>(*p.report("cl").find("background")), "bcc_lattice");
  EXPECT_GT(p.report("cl").number("tets"), 1000);
  // Stages are named and timed.
  std::vector<std::string> stages;
  for (const auto& s : p.exec.state("cl")->stages) stages.push_back(s.name);
  for (const char* s : {"sample", "interfaces", "snap/warp vertices", "generalize", "stencil"})
    EXPECT_NE(std::find(stages.begin(), stages.end(), s), stages.end()) << s;
  // Per-material volume against the label volume (EvaluateQuality's reference input).
  EXPECT_LT(std::abs(p.report("q").number("material_1_volume_rel_error")), 0.1);
}

TEST(CleaveMeshModule, LostMaterialIsLoggedAndStripExteriorWorks) {
  Pipeline p("blob", 6.0);
  p.net.setParameterText("p", "radius", "6");
  p.net.setParameterText("cl", "strip_exterior", "0");
  ASSERT_TRUE(p.exec.execute(p.net).success);
  EXPECT_EQ(std::get<std::string>(*p.report("cl").find("materials_lost")), "2");
  const auto& msgs = p.exec.state("cl")->messages;
  ASSERT_EQ(msgs.size(), 1u);
  EXPECT_NE(msgs[0].find("material 2 (7 mm^3 in the input)"), std::string::npos) << msgs[0];
  EXPECT_GT(p.report("cl").number("stripped_tets"), 0);
  // Bad strip_exterior value: an input error naming the parameter.
  p.net.setParameterText("cl", "strip_exterior", "outside");
  p.exec.execute(p.net);
  EXPECT_EQ(p.exec.state("cl")->status, ModuleStatus::Error);
  EXPECT_NE(p.exec.state("cl")->error.find("strip_exterior"), std::string::npos);
  EXPECT_EQ(p.exec.state("q")->status, ModuleStatus::Skipped);
}

TEST(CleaveMeshModule, OctreeBackgroundFromASizingField) {
  Pipeline p("two_spheres", 1.5);
  p.net.addModule("ComputeSizingField", "sf");
  p.net.setParameterText("sf", "min_size", "1");
  p.net.connect("p", 0, "sf", 0);
  // octree_bcc without its sizing field: an input error naming the port and the fix.
  p.net.setParameterText("bg", "kind", "octree_bcc");
  auto sum = p.exec.execute(p.net);
  ASSERT_FALSE(sum.success);
  EXPECT_NE(p.exec.state("bg")->error.find("input port 1 'sizing'"), std::string::npos) << p.exec.state("bg")->error;
  EXPECT_NE(p.exec.state("bg")->error.find("ComputeSizingField"), std::string::npos);
  // Connected: a graded lattice, cleaved into a valid mesh.
  p.net.connect("sf", 0, "bg", 1);
  sum = p.exec.execute(p.net);
  ASSERT_TRUE(sum.success) << p.exec.state("bg")->error << p.exec.state("cl")->error;
  EXPECT_GE(p.report("bg").number("levels"), 2);
  EXPECT_GT(p.report("bg").number("transition_tets"), 0);
  EXPECT_EQ(std::get<bool>(*p.report("q").find("valid")), true);
  EXPECT_EQ(std::get<std::string>(*p.report("cl").find("materials_lost")), "none");
  EXPECT_EQ(std::get<std::string>(*p.report("cl").find("background")), "bcc_lattice");
  // A regular lattice ignores a connected sizing field, and says so.
  p.net.setParameterText("bg", "kind", "regular_bcc");
  ASSERT_TRUE(p.exec.execute(p.net).success);
  const auto& msgs = p.exec.state("bg")->messages;
  ASSERT_EQ(msgs.size(), 1u);
  EXPECT_NE(msgs[0].find("ignores the sizing field"), std::string::npos) << msgs[0];
}

TEST(CleaveMeshModule, CertificateListsTheLostBlobAndItsThresholdsFailTheModule) {
  test::TempDir dir;
  Pipeline p("blob", 6.0);
  p.net.setParameterText("p", "radius", "6");
  p.net.setParameterText("cl", "strip_exterior", "0");
  p.net.addModule("WriteMesh", "w");
  p.net.setParameterText("w", "filename", dir.file("blob.vtu"));
  p.net.connect("q", 0, "w", 0);
  ASSERT_TRUE(p.exec.execute(p.net).success) << p.exec.state("q")->error;
  const Report& rep = p.report("q");
  EXPECT_EQ(std::get<std::string>(*rep.find("cert_excluded_labels")), "0");
  EXPECT_EQ(rep.number("cert_components_lost"), 1);
  EXPECT_TRUE(std::get<bool>(*rep.find("cert_passed"))); // no threshold set
  EXPECT_NE(std::get<std::string>(*rep.find("cert_issue_1")).find("lost: label 2, image component of 7 voxels"),
            std::string::npos);
  const auto* mesh = dynamic_cast<const TetMeshData*>(p.exec.state("q")->outputs.at(0).get());
  ASSERT_NE(mesh, nullptr);
  ASSERT_TRUE(mesh->value.cellFields.count("certificate_flags"));
  const auto& flags = mesh->value.cellFields.at("certificate_flags").values;
  EXPECT_GT(std::count_if(flags.begin(), flags.end(), [](double f) { return int(f) & 8; }), 0);

  // require_components: the module fails naming the lost component; the writer is skipped.
  p.net.setParameterText("q", "require_components", "true");
  EXPECT_FALSE(p.exec.execute(p.net).success);
  EXPECT_EQ(p.exec.state("q")->status, ModuleStatus::Error);
  const std::string err = p.exec.state("q")->error;
  EXPECT_NE(err.find("the mesh fails its certificate: require_components: 1 lost"), std::string::npos) << err;
  EXPECT_NE(err.find("label 2, image component of 7 voxels"), std::string::npos) << err;
  EXPECT_EQ(p.exec.state("w")->status, ModuleStatus::Skipped);
  EXPECT_FALSE(std::get<bool>(*p.report("q").find("cert_passed"))); // the report survives the failure

  // Thresholds without the label volume: an input error saying what to connect.
  for (const auto& c : std::vector<Connection>(p.net.connections()))
    if (c.to == "q" && c.toPort == 1) p.net.disconnect(c.id);
  p.exec.execute(p.net);
  EXPECT_EQ(p.exec.state("q")->status, ModuleStatus::Error);
  EXPECT_NE(p.exec.state("q")->error.find("label volume on input port 1"), std::string::npos)
      << p.exec.state("q")->error;
}
