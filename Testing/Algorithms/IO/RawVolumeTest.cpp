#include <gtest/gtest.h>

#include <cstring>
#include <limits>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/IO/FileUtil.h"
#include "Algorithms/IO/RawVolume.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {
template <class T>
RawVolume rawOf(VoxelType t, const std::vector<T>& vals) {
  RawVolume r;
  r.grid.dims = {static_cast<int64_t>(vals.size()), 1, 1};
  r.type = t;
  r.bytes.resize(vals.size() * sizeof(T));
  std::memcpy(r.bytes.data(), vals.data(), r.bytes.size());
  return r;
}
} // namespace

TEST(RawVolume, LabelConversionKeepsAnyIntegerValues) {
  const auto l = toLabelVolume(rawOf<uint8_t>(VoxelType::UInt8, {0, 84, 85, 127, 255}), "f");
  EXPECT_EQ(l.data, (std::vector<int32_t>{0, 84, 85, 127, 255}));
  const auto d = toLabelVolume(rawOf<double>(VoxelType::Float64, {-1.0, 2.0, 1e6}), "f");
  EXPECT_EQ(d.data, (std::vector<int32_t>{-1, 2, 1000000}));
  const auto u = toLabelVolume(rawOf<uint16_t>(VoxelType::UInt16, {65535}), "f");
  EXPECT_EQ(u.data[0], 65535);
}

TEST(RawVolume, LabelConversionRefusesValuesOutsideInt32OrFractions) {
  EXPECT_THROW_MSG(toLabelVolume(rawOf<uint32_t>(VoxelType::UInt32, {1, 3000000000u}), "big.nrrd"),
                   InputError, "big.nrrd", "(1, 0, 0)", "not a label");
  EXPECT_THROW_MSG(toLabelVolume(rawOf<int64_t>(VoxelType::Int64, {-5000000000LL}), "f"),
                   InputError, "(0, 0, 0)");
  EXPECT_THROW_MSG(toLabelVolume(rawOf<float>(VoxelType::Float32, {1.0f, 2.5f}), "f"), InputError,
                   "2.5");
}

TEST(RawVolume, ScalarConversionRefusesNonFinite) {
  const auto s = toScalarVolume(rawOf<int16_t>(VoxelType::Int16, {-3, 7}), "f");
  EXPECT_EQ(s.data, (std::vector<float>{-3.0f, 7.0f}));
  EXPECT_THROW_MSG(
      toScalarVolume(rawOf<double>(VoxelType::Float64, {1.0, std::numeric_limits<double>::infinity()}), "inf.nrrd"),
      InputError, "inf.nrrd", "(1, 0, 0)");
}

TEST(RawVolume, SizeMismatchIsAnError) {
  RawVolume r = rawOf<uint8_t>(VoxelType::UInt8, {1, 2, 3});
  r.grid.dims = {4, 1, 1};
  EXPECT_THROW_MSG(toLabelVolume(r, "f"), InputError, "3 bytes", "expected 4");
}

TEST(RawVolume, FromLabelVolumePicksTheSmallestType) {
  LabelVolume l;
  GridGeometry g;
  g.dims = {3, 1, 1};
  l.allocate(g);
  l.data = {0, 255, 7};
  EXPECT_EQ(fromLabelVolume(l).type, VoxelType::UInt8);
  l.data = {-1, 100, 7};
  EXPECT_EQ(fromLabelVolume(l).type, VoxelType::Int8);
  l.data = {0, 1000, 7};
  EXPECT_EQ(fromLabelVolume(l).type, VoxelType::UInt16);
  l.data = {-1000, 1000, 7};
  EXPECT_EQ(fromLabelVolume(l).type, VoxelType::Int16);
  l.data = {0, 100000, 7};
  EXPECT_EQ(fromLabelVolume(l).type, VoxelType::Int32);
  EXPECT_EQ(toLabelVolume(fromLabelVolume(l), "x").data, l.data);
}

TEST(FileUtil, ExtensionsAndGzip) {
  EXPECT_EQ(fileExtension("a/b.NII.gz"), ".nii.gz");
  EXPECT_EQ(fileExtension("x.nrrd"), ".nrrd");
  EXPECT_EQ(fileExtension("dir.v2/file"), "");
  std::string text(100000, 'a');
  for (size_t i = 0; i < text.size(); i += 7) text[i] = static_cast<char>('a' + i % 26);
  const std::string z = gzipCompress(text.data(), text.size());
  EXPECT_TRUE(looksGzipped(z.data(), z.size()));
  const auto back = gunzip(z.data(), z.size(), static_cast<int64_t>(text.size()), "t");
  EXPECT_EQ(std::string(back.begin(), back.end()), text);
  EXPECT_THROW_MSG(gunzip(z.data(), z.size() / 2, static_cast<int64_t>(text.size()), "half.gz"),
                   InputError, "half.gz", "truncated");
  EXPECT_THROW_MSG(gunzip(z.data(), z.size(), int64_t(1) << 40, "lie.gz"), InputError, "lie.gz",
                   "cannot hold");
  std::string bad = z;
  bad[20] ^= 0x55;
  bad[21] ^= 0x55;
  EXPECT_THROW(gunzip(bad.data(), bad.size(), static_cast<int64_t>(text.size()), "bad.gz"),
               InputError);
}

TEST(FileUtil, AtomicOutputFileCommitsOrLeavesNothing) {
  test::TempDir tmp;
  const std::string target = tmp.file("out.txt");
  {
    AtomicOutputFile f(target);
    f.stream() << "hello";
    EXPECT_FALSE(std::filesystem::exists(target));
    f.commit();
  }
  EXPECT_EQ(std::string(readFileBytes(target).data(), 5), "hello");
  {
    AtomicOutputFile f(target);
    f.stream() << "partial";
    // destroyed without commit: target unchanged, temp removed
  }
  EXPECT_EQ(std::string(readFileBytes(target).data(), 5), "hello");
  size_t files = 0;
  for (auto& e : std::filesystem::directory_iterator(tmp.path())) { (void)e; ++files; }
  EXPECT_EQ(files, 1u);
  EXPECT_THROW_MSG(AtomicOutputFile(tmp.file("no/such/dir/x")), InputError, "does not exist");
  EXPECT_THROW_MSG(readFileBytes(tmp.file("nope")), InputError, "nope", "not found");
}
