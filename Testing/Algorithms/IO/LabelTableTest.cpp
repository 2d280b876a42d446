// Tests for Algorithms/IO/LabelTable: ITK-SNAP, FreeSurfer and CSV/TSV label tables, their error
// messages, and the side-file conventions of labelTableBeside.
#include "Algorithms/IO/LabelTable.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "Algorithms/Core/Errors.h"
#include "TestUtil.h"

namespace tetflow {
namespace {

using test::TempDir;

LabelTable tableOf(const TempDir& dir, const std::string& name, const std::string& text) {
  test::writeBytes(dir.file(name), text);
  return readLabelTable(dir.file(name));
}

TEST(LabelTable, ItkSnapLabelDescription) {
  TempDir dir;
  // As ITK-SNAP 3.x/4.x exports it (Segmentation > Export Label Descriptions).
  const LabelTable t = tableOf(dir, "l.txt", R"(################################################
# ITK-SnAP Label Description File
# File format:
# IDX   -R-  -G-  -B-  -A--  VIS MSH  LABEL
# Fields:
#    IDX:   Zero-based index
#    -R-:   Red color component (0..255)
#    LABEL: Label description
################################################
    0     0    0    0        0  0  0    "Clear Label"
    1   255    0    0        1  1  1    "grey matter"
    2     0  255    0      0.5  1  1    "CSF"
   17     0    0  255        1  1  0    "Left-Hippocampus"
)");
  EXPECT_EQ(t.format, "ITK-SNAP");
  EXPECT_EQ(t.names, (std::map<int32_t, std::string>{
                         {0, "Clear Label"}, {1, "grey matter"}, {2, "CSF"}, {17, "Left-Hippocampus"}}));
  EXPECT_TRUE(t.conductivities.empty());
}

TEST(LabelTable, FreeSurferColourTableWithTabsAndSpaces) {
  TempDir dir;
  const LabelTable t = tableOf(dir, "final_tissues_LUT.txt",
                               "#No. Label Name:                            R   G   B   A\n"
                               "\n"
                               "0   Unknown                                 0   0   0   0\n"
                               "1\tWhite-Matter\t245\t245\t245\t255\n"
                               "2   Gray-Matter                             196 58  250 255\r\n"
                               "3   CSF   120 18 134 0\n");
  EXPECT_EQ(t.format, "FreeSurfer");
  EXPECT_EQ(t.names, (std::map<int32_t, std::string>{{0, "Unknown"}, {1, "White-Matter"}, {2, "Gray-Matter"}, {3, "CSF"}}));
}

TEST(LabelTable, CsvAndTsvWithConductivities) {
  TempDir dir;
  LabelTable t = tableOf(dir, "a.csv", "label,name,conductivity\n1,scalp,0.465\n2,\"bone, compact\",0.008\n4,brain,\n");
  EXPECT_EQ(t.format, "CSV");
  EXPECT_EQ(t.names, (std::map<int32_t, std::string>{{1, "scalp"}, {2, "bone, compact"}, {4, "brain"}}));
  EXPECT_EQ(t.conductivities, (std::map<int32_t, double>{{1, 0.465}, {2, 0.008}}));
  t = tableOf(dir, "b.tsv", "1\tgrey matter\t0.275\n-3\tair\n");
  EXPECT_EQ(t.format, "TSV");
  EXPECT_EQ(t.names, (std::map<int32_t, std::string>{{-3, "air"}, {1, "grey matter"}}));
  EXPECT_EQ(t.conductivities, (std::map<int32_t, double>{{1, 0.275}}));
  t = tableOf(dir, "c.csv", "# semicolons, as spreadsheets with a decimal comma write them\n5;eyes\n");
  EXPECT_EQ(t.names, (std::map<int32_t, std::string>{{5, "eyes"}}));
}

TEST(LabelTable, BadTablesNameTheLine) {
  TempDir dir;
  auto refused = [&](const std::string& text, std::initializer_list<std::string> fragments) {
    test::writeBytes(dir.file("bad.txt"), text);
    try {
      readLabelTable(dir.file("bad.txt"));
      ADD_FAILURE() << "accepted: " << text;
    } catch (const InputError& e) {
      for (const std::string& f : fragments)
        EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << e.what() << " lacks " << f;
    }
  };
  refused("1,scalp\n1,skin\n", {"bad.txt, line 2", "label 1 is listed twice"});
  refused("1,scalp\nx1,skin\n", {"line 2", "'x1' is not a 32-bit integer"});
  refused("1,scalp,-2\n", {"line 1", "conductivity of label 1 ('-2') is not a positive number"});
  refused("1,scalp,0.4,extra\n", {"found 4 fields"});
  refused("hello world\n", {"line 1", "not a label table line", "ITK-SNAP"});
  refused("# nothing\n\n", {"bad.txt", "has no entry"});
  refused("1 255 0 0 1 1 1 \"a\"\n2 WM 1 2 3 4\n", {"line 2", "not an ITK-SNAP label line"});
  refused("3,\n", {"label 3 has an empty name"});
  EXPECT_THROW(readLabelTable(dir.file("missing.txt")), InputError);
}

TEST(LabelTable, FoundBesideTheVolumeByConvention) {
  TempDir dir;
  EXPECT_EQ(labelTableBeside(dir.file("seg.nii.gz")), "");
  test::writeBytes(dir.file("seg.csv"), "1,a\n");
  EXPECT_EQ(labelTableBeside(dir.file("seg.nii.gz")), dir.file("seg.csv"));
  test::writeBytes(dir.file("seg.txt"), "1,a\n");
  EXPECT_EQ(labelTableBeside(dir.file("seg.nii.gz")), dir.file("seg.txt"));
  test::writeBytes(dir.file("seg_LUT.txt"), "1 a 0 0 0 0\n");
  EXPECT_EQ(labelTableBeside(dir.file("seg.nii.gz")), dir.file("seg_LUT.txt")); // SimNIBS charm first
  EXPECT_EQ(labelTableBeside(dir.file("seg.nrrd")), dir.file("seg_LUT.txt"));
  // 3D Slicer's segmentation files: NAME.seg.nrrd beside NAME.ctbl.
  test::writeBytes(dir.file("head.ctbl"), "1 a 0 0 0 0\n");
  EXPECT_EQ(labelTableBeside(dir.file("head.seg.nrrd")), dir.file("head.ctbl"));
}

} // namespace
} // namespace tetflow
