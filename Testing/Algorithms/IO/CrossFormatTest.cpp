// One segmentation saved in every volume format reads back with the same dims, spacing, origin
// and per-label voxel counts (the foundation issue's acceptance, at test size).
#include <gtest/gtest.h>

#include "Algorithms/IO/VolumeIO.h"
#include "Fixtures/SyntheticSegmentation.h"
#include "TestUtil.h"

using namespace tetflow;

TEST(CrossFormat, SameSegmentationInEveryFormatReadsIdentically) {
  test::TempDir tmp;
  const LabelVolume seg = test::syntheticSegmentation(61, 53, 23);
  const auto counts = labelCounts(seg);
  ASSERT_EQ(counts.size(), 5u);
  for (int32_t l : {0, 84, 85, 127, 255}) EXPECT_GT(counts.count(l), 0u) << l;
  const RawVolume raw = fromLabelVolume(seg);
  ASSERT_EQ(raw.type, VoxelType::UInt8);
  for (const char* name : {"s.inr.gz", "s.inr", "s.nrrd", "s.nhdr", "s.nii.gz", "s.nii", "s.mha",
                           "s.mhd", "s.vti"}) {
    const std::string f = tmp.file(name);
    writeVolume(f, raw);
    const LabelVolume back = readLabelVolume(f);
    SCOPED_TRACE(name);
    EXPECT_EQ(back.grid.dims, seg.grid.dims);
    for (int a = 0; a < 3; ++a) {
      // NIfTI stores float32 geometry: compare to its precision.
      EXPECT_NEAR(back.grid.spacing[a], seg.grid.spacing[a], 1e-5);
      EXPECT_NEAR(back.grid.origin[a], seg.grid.origin[a], 1e-4);
    }
    EXPECT_TRUE(back.grid.isAxisAligned());
    EXPECT_EQ(labelCounts(back), counts);
    EXPECT_EQ(back.data, seg.data);
  }
}
