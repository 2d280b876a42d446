// The mesh-a-label-volume network (issue 30): what it is built of, the sizes it chooses, and that
// the shipped Nets/mesh_labels*.srn are exactly what it builds for the bundled head.
#include <gtest/gtest.h>

#include <regex>

#include "Algorithms/IO/FileUtil.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Dataflow/NetworkFile.h"
#include "Modules/MeshLabelsNet.h"
#include "Modules/StandardModules.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {
std::string withoutNote(const std::string& xml) { return std::regex_replace(xml, std::regex("<note>\\{[^}]*\\}</note>"), ""); }
using tetflow::test::readText;
} // namespace

TEST(MeshLabelsNet, TheShippedNetsAreWhatTetflowMeshBuildsForTheBundledHead) {
  ModuleRegistry reg;
  registerStandardModules(reg);
  const LabelVolume head = readLabelVolume(std::string(TETFLOW_TEST_DATA) + "/layered_head_4mm.nii.gz");
  const GridGeometry grid = head.grid;
  for (const auto& [file, background, output] :
       {std::tuple{"mesh_labels.srn", MeshBackground::Regular, "layered_head.vtu"},
        std::tuple{"mesh_labels_adaptive.srn", MeshBackground::Octree, "layered_head_adaptive.vtu"}}) {
    MeshLabelsOptions o;
    o.labels = "../Testing/Data/layered_head_4mm.nii.gz";
    o.output = output;
    o.background = background;
    o.exterior = exteriorLabelOf(head); // 0: the air around the head
    EXPECT_EQ(o.exterior, std::optional<int32_t>(0));
    chooseMeshSizes(o, grid);
    const std::string built = saveNetworkToString(buildMeshLabelsNetwork(reg, o));
    const std::string shipped = readText(std::string(TETFLOW_SOURCE_DIR) + "/Nets/" + file);
    EXPECT_EQ(withoutNote(built), withoutNote(shipped)) << file;
    EXPECT_NE(shipped.find("tetflow mesh YOUR.nii.gz"), std::string::npos) << file;
  }
}

TEST(MeshLabelsNet, SizesScaleWithTheLongestVoxelSideAndGivenSizesStay) {
  GridGeometry g;
  g.dims = {10, 10, 10};
  g.spacing = {0.5, 0.5, 1.5};
  MeshLabelsOptions o;
  auto lines = chooseMeshSizes(o, g);
  EXPECT_DOUBLE_EQ(o.cellSize, 6.0);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0], "cell size 6 mm (4 x the 1.5 mm voxels; --cell-size to change)");
  // The octree's smallest size is 4 x too (its thin layers are refined below it); the particles' 2 x.
  o = {};
  o.background = MeshBackground::Octree;
  lines = chooseMeshSizes(o, g);
  EXPECT_DOUBLE_EQ(o.minSize, 6.0);
  EXPECT_DOUBLE_EQ(o.maxSize, 24.0);
  o = {};
  o.background = MeshBackground::Particles;
  o.maxSize = 10;
  lines = chooseMeshSizes(o, g);
  EXPECT_DOUBLE_EQ(o.minSize, 3.0);
  EXPECT_DOUBLE_EQ(o.maxSize, 10.0);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0], "smallest element size 3 mm (2 x the 1.5 mm voxels; --min-size to change)");
  EXPECT_EQ(lines[1], "largest element size 10 mm (--max-size)");
  EXPECT_EQ(meshBackgroundFromName("octree"), MeshBackground::Octree);
  EXPECT_FALSE(meshBackgroundFromName("tetgen"));
}

TEST(MeshLabelsNet, EachBackgroundIsTheShapeOfTheShippedNets) {
  ModuleRegistry reg;
  registerStandardModules(reg);
  MeshLabelsOptions o;
  o.labels = "head.nii.gz";
  o.output = "head.msh";
  o.format = "msh22";
  o.cellSize = 3;
  o.certify = true;
  Network regular = buildMeshLabelsNetwork(reg, o);
  EXPECT_EQ(regular.modules().size(), 5u);
  EXPECT_EQ(regular.module("m2")->info->name, "GenerateBackgroundMesh");
  EXPECT_EQ(formatParam(*regular.module("m2")->info->param("cell_size"), regular.module("m2")->params.at("cell_size")), "3");
  EXPECT_EQ(formatParam(*regular.module("m4")->info->param("max_volume_error"),
                        regular.module("m4")->params.at("max_volume_error")),
            "1.5");
  EXPECT_TRUE(regular.inputConnection("m4", 1)); // the certificate's reference volume
  o.background = MeshBackground::Particles;
  o.minSize = 2;
  o.maxSize = 20;
  Network particles = buildMeshLabelsNetwork(reg, o);
  EXPECT_EQ(particles.modules().size(), 6u);
  EXPECT_EQ(particles.module("m6")->info->name, "ComputeSizingField");
  EXPECT_TRUE(particles.inputConnection("m2", 1)); // the sizing field
  EXPECT_EQ(formatParam(*particles.module("m2")->info->param("kind"), particles.module("m2")->params.at("kind")),
            "particles");
  // A value a module refuses is refused as the module refuses it.
  o.format = "obj";
  EXPECT_THROW_MSG(buildMeshLabelsNetwork(reg, o), InputError, "m5", "format");
}
