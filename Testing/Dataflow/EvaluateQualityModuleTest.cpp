// Module-level test of EvaluateQuality: ReadMesh -> EvaluateQuality (-> optional reference label
// volume from ReadLabelVolume), executed by tetflow::Executor; checks the report figures, the
// output Report port and the quality fields on the output mesh.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "Algorithms/IO/MeshIO.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Dataflow/Executor.h"
#include "TestModules.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {

// Unit cube split into 5 tets: 4 corner tets (material 1, 2/3 mm^3) around the regular central
// tet (material 2, 1/3 mm^3).
TetMesh cubeFive() {
  TetMesh m;
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) m.points.push_back({double(i), double(j), double(k)});
  m.tets = {{1, 0, 3, 5}, {2, 0, 3, 6}, {4, 0, 5, 6}, {7, 3, 5, 6}, {0, 3, 5, 6}};
  m.materials = {1, 1, 1, 1, 2};
  for (size_t t = 0; t < m.numTets(); ++t)
    if (m.tetVolume(t) < 0) std::swap(m.tets[t][0], m.tets[t][1]);
  return m;
}

struct EvaluateQualityFixture : ::testing::Test {
  ModuleRegistry reg;
  test::TempDir dir;
  EvaluateQualityFixture() { test::registerTestModules(reg); }
};

TEST_F(EvaluateQualityFixture, IsRegisteredWithItsContract) {
  const ModuleInfo* info = reg.find("EvaluateQuality");
  ASSERT_NE(info, nullptr);
  ASSERT_EQ(info->inputs.size(), 2u);
  EXPECT_EQ(info->inputs[0].name, "mesh");
  EXPECT_EQ(info->inputs[0].type(), PortType::TetMesh);
  EXPECT_FALSE(info->inputs[0].optional);
  EXPECT_EQ(info->inputs[1].name, "reference");
  EXPECT_EQ(info->inputs[1].type(), PortType::LabelVolume);
  EXPECT_TRUE(info->inputs[1].optional);
  ASSERT_EQ(info->outputs.size(), 2u);
  EXPECT_EQ(info->outputs[0].type(), PortType::TetMesh);
  EXPECT_EQ(info->outputs[1].type(), PortType::Report);
  const ParamSpec* bin = info->param("bin_width");
  ASSERT_NE(bin, nullptr);
  EXPECT_EQ(std::get<double>(bin->defaultValue), 5.0);
  EXPECT_EQ(bin->max, 90.0);
  EXPECT_EQ(info->summaryKeys,
            (std::vector<std::string>{"tets", "min_dihedral_deg", "max_dihedral_deg", "valid", "cert_passed"}));
  Network net(reg);
  const auto id = net.addModule("EvaluateQuality");
  EXPECT_THROW(net.setParameterText(id, "bin_width", "0"), InputError);
  EXPECT_THROW(net.setParameterText(id, "bin_width", "91"), InputError);
  net.setParameterText(id, "bin_width", "90");
}

TEST_F(EvaluateQualityFixture, ReadMeshThenEvaluate) {
  const std::string meshFile = dir.file("cube5.vtu");
  writeMesh(meshFile, cubeFive());
  Network net(reg);
  const auto reader = net.addModule("ReadMesh");
  net.setParameterText(reader, "filename", meshFile);
  const auto eval = net.addModule("EvaluateQuality");
  net.connect(reader, 0, eval, 0);
  Executor exec;
  const auto sum = exec.execute(net);
  ASSERT_TRUE(sum.success) << exec.state(eval)->error;

  const Report& rep = exec.state(eval)->report;
  EXPECT_EQ(rep.number("tets"), 5);
  EXPECT_EQ(rep.number("vertices"), 8);
  EXPECT_EQ(std::get<bool>(*rep.find("valid")), true);
  EXPECT_EQ(std::get<bool>(*rep.find("boundary_closed")), true);
  EXPECT_EQ(rep.number("inverted"), 0);
  EXPECT_EQ(rep.number("zero_volume"), 0);
  EXPECT_EQ(rep.number("duplicate_tets"), 0);
  EXPECT_EQ(rep.number("nonmanifold_faces"), 0);
  EXPECT_EQ(rep.number("boundary_faces"), 12);
  EXPECT_EQ(rep.number("interior_faces"), 4);
  const double corner = std::acos(1.0 / std::sqrt(3.0)) * 180.0 / std::numbers::pi;
  EXPECT_NEAR(rep.number("min_dihedral_deg"), corner, 1e-9);
  EXPECT_NEAR(rep.number("max_dihedral_deg"), 90.0, 1e-9);
  EXPECT_EQ(rep.number("tets_below_15deg"), 0);
  EXPECT_NEAR(rep.number("volume_mm3"), 1.0, 1e-12);
  EXPECT_NEAR(rep.number("material_2_volume_mm3"), 1.0 / 3.0, 1e-12);
  EXPECT_FALSE(rep.has("material_1_reference_mm3"));
  EXPECT_NE(std::get<std::string>(*rep.find("min_dihedral_histogram")).find("50-55:4"),
            std::string::npos);

  // Output 1 carries the same figures; output 0 the mesh with the quality fields.
  const auto& outs = exec.state(eval)->outputs;
  ASSERT_EQ(outs.size(), 2u);
  const auto* repOut = dynamic_cast<const ReportData*>(outs[1].get());
  ASSERT_NE(repOut, nullptr);
  EXPECT_EQ(repOut->value.entries(), rep.entries());
  const auto* meshOut = dynamic_cast<const TetMeshData*>(outs[0].get());
  ASSERT_NE(meshOut, nullptr);
  const TetMesh& m = meshOut->value;
  EXPECT_EQ(m.numTets(), 5u);
  for (const char* f : {"min_dihedral", "max_dihedral", "aspect_ratio", "radius_ratio", "volume"}) {
    ASSERT_TRUE(m.cellFields.count(f)) << f;
    EXPECT_EQ(m.cellFields.at(f).values.size(), 5u) << f;
  }
  EXPECT_NEAR(m.cellFields.at("radius_ratio").values[4], 1.0, 1e-12);
  m.validateStructure("output"); // fields have the right sizes
  // The mesh with its fields can be written (and the fields read back).
  const std::string outFile = dir.file("quality.vtu");
  writeMesh(outFile, m);
  const TetMesh back = readMesh(outFile);
  EXPECT_EQ(back.cellFields.at("min_dihedral"), m.cellFields.at("min_dihedral"));

  // A changed bin width re-runs the module with the new histogram.
  net.setParameterText(eval, "bin_width", "10");
  ASSERT_TRUE(exec.execute(net).success);
  const auto& rep2 = exec.state(eval)->report;
  EXPECT_EQ(rep2.number("histogram_bin_deg"), 10.0);
  EXPECT_NE(std::get<std::string>(*rep2.find("min_dihedral_histogram")).find("50-60:4"),
            std::string::npos);
}

TEST_F(EvaluateQualityFixture, ReferenceLabelVolumeGivesPerMaterialErrors) {
  const std::string meshFile = dir.file("cube5.vtu");
  writeMesh(meshFile, cubeFive());
  // 4 x 1 x 1 voxels of 1 x 1 x (1/3) mm: label 0 (not in the mesh), 1, 1, 2
  // -> reference volumes 1: 2/3 mm^3, 2: 1/3 mm^3.
  LabelVolume ref;
  GridGeometry g;
  g.dims = {4, 1, 1};
  g.spacing = {1.0, 1.0, 1.0 / 3.0};
  ref.allocate(g, 0);
  ref.data = {0, 1, 1, 2};
  const std::string refFile = dir.file("ref.nrrd");
  writeVolume(refFile, fromLabelVolume(ref));

  Network net(reg);
  const auto reader = net.addModule("ReadMesh");
  net.setParameterText(reader, "filename", meshFile);
  const auto labels = net.addModule("ReadLabelVolume");
  net.setParameterText(labels, "filename", refFile);
  const auto eval = net.addModule("EvaluateQuality");
  net.connect(reader, 0, eval, 0);
  net.connect(labels, 0, eval, 1);
  Executor exec;
  ASSERT_TRUE(exec.execute(net).success) << exec.state(eval)->error;
  const Report& rep = exec.state(eval)->report;
  EXPECT_NEAR(rep.number("material_1_reference_mm3"), 2.0 / 3.0, 1e-6);
  EXPECT_NEAR(rep.number("material_2_reference_mm3"), 1.0 / 3.0, 1e-6);
  EXPECT_NEAR(rep.number("material_1_volume_rel_error"), 0.0, 1e-6);
  EXPECT_NEAR(rep.number("material_2_volume_rel_error"), 0.0, 1e-6);
  EXPECT_EQ(std::get<std::string>(*rep.find("reference_labels_missing")), "0");
}

TEST_F(EvaluateQualityFixture, BadMeshFailsWithTheModuleId) {
  TetMesh flat;
  flat.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const std::string meshFile = dir.file("empty.vtu");
  writeMesh(meshFile, flat);
  Network net(reg);
  const auto reader = net.addModule("ReadMesh");
  net.setParameterText(reader, "filename", meshFile);
  const auto eval = net.addModule("EvaluateQuality");
  net.connect(reader, 0, eval, 0);
  Executor exec;
  EXPECT_FALSE(exec.execute(net).success);
  EXPECT_EQ(exec.state(eval)->status, ModuleStatus::Error);
  EXPECT_EQ(exec.state(eval)->errorKind, "input");
  EXPECT_NE(exec.state(eval)->error.find(eval + ": "), std::string::npos);
  EXPECT_NE(exec.state(eval)->error.find("no tetrahedra"), std::string::npos);
}

} // namespace
