// Tissues by name end to end: a segmentation file with the label table that comes with it (found
// beside it by convention, or given), ReadLabelVolume -> GenerateBackgroundMesh -> CleaveMesh ->
// WriteMesh (Gmsh MSH 2.2 and .vtu) and AssembleFEMPoisson with conductivities given by name,
// taken from the label table or from the literature by name.
#include <gtest/gtest.h>

#include <filesystem>

#include "Algorithms/Core/Phantom.h"
#include "Algorithms/IO/MeshIO.h"
#include "Algorithms/IO/RawVolume.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Dataflow/Executor.h"
#include "TestModules.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {

struct NamedPipeline {
  ModuleRegistry reg;
  Network net{reg};
  Executor exec;
  explicit NamedPipeline(const std::string& volume) {
    test::registerTestModules(reg);
    net.addModule("ReadLabelVolume", "read");
    net.setParameterText("read", "filename", volume);
    net.addModule("GenerateBackgroundMesh", "bg");
    net.setParameterText("bg", "cell_size", "4");
    net.addModule("CleaveMesh", "cleave");
    net.setParameterText("cleave", "strip_exterior", "0"); // as the shipped nets: the air goes
    net.addModule("AssembleFEMPoisson", "fem");
    net.setParameterText("fem", "boundary_condition", "dipole");
    net.setParameterText("fem", "dipole_position", "0 0 4");
    net.setParameterText("fem", "estimate_condition", "false");
    net.connect("read", 0, "bg", 0);
    net.connect("read", 0, "cleave", 0);
    net.connect("bg", 0, "cleave", 1);
    net.connect("cleave", 0, "fem", 0);
  }
  const Report& report(const std::string& id) const { return exec.state(id)->report; }
  std::string text(const std::string& id, const std::string& key) const {
    const ReportValue* v = report(id).find(key);
    return v ? formatReportValue(*v) : std::string("(missing)");
  }
  void run() {
    const auto sum = exec.execute(net);
    std::string errors;
    for (const char* id : {"read", "bg", "cleave", "fem"})
      if (exec.state(id) && !exec.state(id)->error.empty()) errors += std::string(id) + ": " + exec.state(id)->error + "\n";
    ASSERT_TRUE(sum.success) << errors;
  }
};

// The four-layer head phantom (1 scalp, 2 skull, 3 CSF, 4 brain), small, written as NIfTI.
std::string writeHead(const test::TempDir& dir, const std::string& name) {
  PhantomParams p;
  p.kind = PhantomKind::Head;
  p.voxel_size = 2;
  p.radius = 24;
  p.skull_radius = 20;
  p.csf_radius = 16;
  p.brain_radius = 14;
  const Phantom ph = makePhantom(p);
  writeVolume(dir.file(name), fromLabelVolume(ph.volume));
  return dir.file(name);
}

TEST(TissueNamesPipeline, AnItkSnapTableBesideTheSegmentationNamesEverything) {
  test::TempDir dir;
  const std::string volume = writeHead(dir, "head.nii.gz");
  test::writeBytes(dir.file("head.txt"), "# ITK-SnAP Label Description File\n"
                                         "    0     0    0    0        0  0  0    \"Clear Label\"\n"
                                         "    1   255  200  180        1  1  1    \"Skin\"\n"
                                         "    2   255  255  255        1  1  1    \"Skull\"\n"
                                         "    3     0    0  255        1  1  1    \"CSF\"\n"
                                         "    4   200  100  100        1  1  1    \"Gray-Matter\"\n");
  NamedPipeline p(volume);
  p.net.setParameterText("fem", "conductivities", "CSF:1.79");
  p.net.addModule("WriteMesh", "msh");
  p.net.setParameterText("msh", "filename", dir.file("head.msh"));
  p.net.setParameterText("msh", "format", "msh22");
  p.net.connect("cleave", 0, "msh", 0);
  p.run();

  EXPECT_EQ(p.text("read", "label_table"), dir.file("head.txt"));
  EXPECT_EQ(p.text("read", "label_table_format"), "ITK-SNAP");
  EXPECT_EQ(p.text("read", "label_names"), "0 Clear Label; 1 Skin; 2 Skull; 3 CSF; 4 Gray-Matter");
  // Conductivities: CSF by name from the parameter, the others from the literature by name.
  EXPECT_EQ(p.text("fem", "material_3_conductivity_source"), "parameter");
  EXPECT_EQ(p.report("fem").number("material_3_conductivity"), 1.79);
  EXPECT_EQ(p.text("fem", "material_1_name"), "Skin");
  EXPECT_EQ(p.text("fem", "material_1_conductivity_source"), "literature");
  EXPECT_EQ(p.report("fem").number("material_1_conductivity"), 0.465);
  EXPECT_EQ(p.report("fem").number("material_2_conductivity"), 0.010);
  EXPECT_EQ(p.report("fem").number("material_4_conductivity"), 0.275);
  EXPECT_EQ(std::get<bool>(*p.report("fem").find("converged")), true);
  // The mesh (the exterior stripped: no air) keeps the names of the labels it holds.
  const TetMesh m = readMesh(dir.file("head.msh"));
  EXPECT_EQ(m.materialNames, (std::map<int32_t, std::string>{{1, "Skin"}, {2, "Skull"}, {3, "CSF"}, {4, "Gray-Matter"}}));
}

TEST(TissueNamesPipeline, ACsvTableGivesConductivitiesAndAFreeSurferTableIsFoundByItsConvention) {
  test::TempDir dir;
  const std::string volume = writeHead(dir, "seg.nrrd");
  test::writeBytes(dir.file("tissues.csv"), "label,name,conductivity\n1,scalp,0.43\n2,skull,0.0042\n3,CSF,1.79\n4,brain,0.33\n");
  {
    NamedPipeline p(volume);
    p.net.setParameterText("read", "label_table", dir.file("tissues.csv"));
    p.net.setParameterText("fem", "default_conductivity", "0.5");
    p.run();
    EXPECT_EQ(p.text("read", "label_table_format"), "CSV");
    for (int L = 1; L <= 4; ++L)
      EXPECT_EQ(p.text("fem", "material_" + std::to_string(L) + "_conductivity_source"), "label table") << L;
    EXPECT_EQ(p.report("fem").number("material_2_conductivity"), 0.0042);
    // The same numbers as the labels given in the parameter.
    NamedPipeline q(volume);
    q.net.setParameterText("read", "find_label_table", "false");
    q.net.setParameterText("fem", "conductivities", "1:0.43; 2:0.0042; 3:1.79; 4:0.33");
    q.run();
    EXPECT_FALSE(q.report("read").has("label_table"));
    EXPECT_EQ(q.report("fem").number("iterations"), p.report("fem").number("iterations"));
    EXPECT_EQ(q.report("fem").number("potential_max"), p.report("fem").number("potential_max"));
  }
  test::writeBytes(dir.file("seg_LUT.txt"), "0 Unknown 0 0 0 0\n1 Scalp 1 1 1 0\n2 Bone 2 2 2 0\n3 CSF 3 3 3 0\n4 brain 4 4 4 0\n");
  NamedPipeline p(volume);
  p.run();
  EXPECT_EQ(p.text("read", "label_table"), dir.file("seg_LUT.txt"));
  EXPECT_EQ(p.text("read", "label_table_format"), "FreeSurfer");
  EXPECT_EQ(p.text("fem", "material_4_conductivity_source"), "default"); // "brain" is not in the literature table
  EXPECT_EQ(p.report("fem").number("material_4_conductivity"), 1.0);
  EXPECT_EQ(p.report("fem").number("material_3_conductivity"), 1.654);
  // A name the mesh does not have is an error naming the tissues it has.
  NamedPipeline bad(volume);
  bad.net.setParameterText("fem", "conductivities", "grey matter:0.3");
  bad.exec.execute(bad.net);
  EXPECT_NE(bad.exec.state("fem")->error.find("no tissue called 'grey matter'; its tissues are Scalp (1), Bone (2), CSF (3), brain (4)"),
            std::string::npos)
      << bad.exec.state("fem")->error;
}

// The label table found beside a volume is part of ReadLabelVolume's cached result: adding,
// editing or removing it runs the module again; nothing changed, the result is reused.
TEST(TissueNamesPipeline, ATableAddedEditedOrRemovedBesideACachedVolumeIsReadAgain) {
  test::TempDir dir;
  const std::string volume = writeHead(dir, "seg.nii.gz");
  ModuleRegistry reg;
  test::registerTestModules(reg);
  Network net(reg);
  net.addModule("ReadLabelVolume", "read");
  net.setParameterText("read", "filename", volume);
  Executor exec;
  auto names = [&] {
    EXPECT_TRUE(exec.execute(net).success) << exec.state("read")->error;
    const ReportValue* v = exec.state("read")->report.find("label_names");
    return v ? formatReportValue(*v) : std::string("(none)");
  };
  const std::string none = names();
  EXPECT_EQ(none.find("Scalp"), std::string::npos);
  EXPECT_EQ(names(), none);
  EXPECT_TRUE(exec.state("read")->reused);
  test::writeBytes(dir.file("seg.lut"), "0 Unknown 0 0 0 0\n1 Scalp 1 1 1 0\n2 Bone 2 2 2 0\n");
  EXPECT_EQ(names(), "0 Unknown; 1 Scalp; 2 Bone");
  EXPECT_FALSE(exec.state("read")->reused);
  test::writeBytes(dir.file("seg.lut"), "0 Unknown 0 0 0 0\n1 Skin 1 1 1 0\n2 Bone 2 2 2 0\n3 CSF 3 3 3 0\n");
  EXPECT_EQ(names(), "0 Unknown; 1 Skin; 2 Bone; 3 CSF");
  std::filesystem::remove(dir.file("seg.lut"));
  EXPECT_EQ(names(), none);
  EXPECT_FALSE(exec.state("read")->reused);
}

// A 3D Slicer segmentation (.seg.nrrd) names its segments in its header (SegmentN_Name,
// SegmentN_LabelValue, SegmentN_Layer): those of layer 0 name their labels; a table overrides.
TEST(TissueNamesPipeline, ASlicerSegmentationNamesItsLabels) {
  test::TempDir dir;
  test::writeBytes(dir.file("head.seg.nrrd"), "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: ascii\n"
                                              "Segment0_Name:=White matter\nSegment0_LabelValue:=1\nSegment0_Layer:=0\n"
                                              "Segment1_Name:=Skull\nSegment1_LabelValue:=2\n"
                                              "Segment2_Name:=Overlapping\nSegment2_LabelValue:=1\nSegment2_Layer:=1\n"
                                              "\n0 1 2 1 0 1 2 2\n");
  ModuleRegistry reg;
  test::registerTestModules(reg);
  Network net(reg);
  net.addModule("ReadLabelVolume", "read");
  net.setParameterText("read", "filename", dir.file("head.seg.nrrd"));
  Executor exec;
  ASSERT_TRUE(exec.execute(net).success) << exec.state("read")->error;
  EXPECT_EQ(formatReportValue(*exec.state("read")->report.find("label_names")), "1 White matter; 2 Skull");
  EXPECT_EQ(formatReportValue(*exec.state("read")->report.find("label_names_from")), "file header");
  test::writeBytes(dir.file("names.csv"), "label,name\n1,WM\n2,bone\n");
  net.setParameterText("read", "label_table", dir.file("names.csv"));
  ASSERT_TRUE(exec.execute(net).success) << exec.state("read")->error;
  EXPECT_EQ(formatReportValue(*exec.state("read")->report.find("label_names")), "1 WM; 2 bone");
  EXPECT_EQ(formatReportValue(*exec.state("read")->report.find("label_names_from")), "label table");
}

} // namespace
