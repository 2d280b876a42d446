// NRRD reader / writer: round trips of every voxel type and encoding, hand-written files in both
// byte orders (attached, detached, ascii, gzip, skips, dimension 2 and 4), and a corpus of broken
// files whose messages must name the file, the header line and the problem.
#include <gtest/gtest.h>

#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/IO/FileUtil.h"
#include "Algorithms/IO/NrrdIO.h"
#include "Fixtures/RawVolumeBytes.h"
#include "TestUtil.h"

namespace fs = std::filesystem;

namespace tetflow {
namespace {

using test::TempDir;
using test::writeBytes;

using test::kAllTypes;
using test::bytesOf;
using test::valuesOf;
const NrrdEncoding kAllEncodings[] = {NrrdEncoding::Raw, NrrdEncoding::Gzip, NrrdEncoding::Ascii};

const char* encodingName(NrrdEncoding e) {
  return e == NrrdEncoding::Raw ? "raw" : e == NrrdEncoding::Gzip ? "gzip" : "ascii";
}



template <class T>
void fillRandom(RawVolume& v, std::mt19937_64& rng) {
  const size_t n = static_cast<size_t>(v.grid.voxelCount());
  std::vector<T> vals(n);
  if constexpr (std::is_floating_point_v<T>) {
    std::uniform_real_distribution<T> d(T(-1000), T(1000));
    for (auto& x : vals) x = d(rng);
    if (n > 2) {
      vals[0] = T(0.1);                               // not exactly representable
      vals[1] = std::numeric_limits<T>::denorm_min(); // extremes survive ascii
      vals[2] = std::numeric_limits<T>::max();
    }
  } else {
    // Full range, including the extremes.
    for (auto& x : vals) x = static_cast<T>(rng());
    if (n > 2) {
      vals[0] = std::numeric_limits<T>::min();
      vals[1] = std::numeric_limits<T>::max();
      vals[2] = 0;
    }
  }
  v.bytes.resize(n * sizeof(T));
  std::memcpy(v.bytes.data(), vals.data(), v.bytes.size());
}

RawVolume randomVolume(VoxelType t, const GridGeometry& g, uint64_t seed) {
  RawVolume v;
  v.grid = g;
  v.type = t;
  std::mt19937_64 rng(seed);
  switch (t) {
    case VoxelType::Int8: fillRandom<int8_t>(v, rng); break;
    case VoxelType::UInt8: fillRandom<uint8_t>(v, rng); break;
    case VoxelType::Int16: fillRandom<int16_t>(v, rng); break;
    case VoxelType::UInt16: fillRandom<uint16_t>(v, rng); break;
    case VoxelType::Int32: fillRandom<int32_t>(v, rng); break;
    case VoxelType::UInt32: fillRandom<uint32_t>(v, rng); break;
    case VoxelType::Int64: fillRandom<int64_t>(v, rng); break;
    case VoxelType::UInt64: fillRandom<uint64_t>(v, rng); break;
    case VoxelType::Float32: fillRandom<float>(v, rng); break;
    case VoxelType::Float64: fillRandom<double>(v, rng); break;
  }
  return v;
}

Mat3 rotation(Vec3 axis, double angle) {
  const double n = norm(axis);
  axis = (1.0 / n) * axis;
  const double c = std::cos(angle), s = std::sin(angle), t = 1 - c;
  const double x = axis[0], y = axis[1], z = axis[2];
  return {{{t * x * x + c, t * x * y - s * z, t * x * z + s * y},
           {t * x * y + s * z, t * y * y + c, t * y * z - s * x},
           {t * x * z - s * y, t * y * z + s * x, t * z * z + c}}};
}

struct NamedGrid {
  const char* name;
  GridGeometry grid;
  bool exact; // axis aligned or flipped: geometry must come back bit for bit
};

std::vector<NamedGrid> testGrids() {
  std::vector<NamedGrid> out;
  GridGeometry a;
  a.dims = {5, 4, 3};
  a.spacing = {0.3, 1.25, 2.0};
  a.origin = {-12.5, 3.25, 100.1};
  out.push_back({"axis-aligned", a, true});

  GridGeometry r = a;
  r.dims = {3, 6, 2};
  r.spacing = {0.7, 0.11, 3.3};
  r.origin = {1.0 / 3.0, -2.0 / 7.0, 1e-3};
  r.direction = rotation({1, 2, 3}, 0.7);
  out.push_back({"rotated", r, false});

  GridGeometry f = a;
  f.dims = {2, 2, 7};
  f.direction = {{{-1, 0, 0}, {0, 1, 0}, {0, 0, -1}}};
  out.push_back({"flipped", f, true});

  GridGeometry s = a;
  s.dims = {1, 1, 1};
  out.push_back({"single-voxel", s, true});
  return out;
}

void expectSameGrid(const GridGeometry& want, const GridGeometry& got, bool exact) {
  EXPECT_EQ(want.dims, got.dims);
  for (int i = 0; i < 3; ++i) {
    if (exact) {
      EXPECT_EQ(want.spacing[i], got.spacing[i]) << "axis " << i;
      EXPECT_EQ(want.origin[i], got.origin[i]) << "axis " << i;
    } else {
      EXPECT_NEAR(want.spacing[i], got.spacing[i], 1e-14 * want.spacing[i]) << "axis " << i;
      EXPECT_EQ(want.origin[i], got.origin[i]) << "axis " << i;
    }
    for (int j = 0; j < 3; ++j) {
      if (exact)
        EXPECT_EQ(want.direction[i][j], got.direction[i][j]) << i << "," << j;
      else
        EXPECT_NEAR(want.direction[i][j], got.direction[i][j], 1e-14) << i << "," << j;
    }
  }
}

void expectSameVolume(const RawVolume& want, const RawVolume& got, bool exactGeometry) {
  EXPECT_EQ(want.type, got.type);
  expectSameGrid(want.grid, got.grid, exactGeometry);
  ASSERT_EQ(want.bytes.size(), got.bytes.size());
  EXPECT_TRUE(want.bytes == got.bytes) << "voxel values differ";
}

using tetflow::test::readText;

// ------------------------------------------------------------------------------------------------
// Round trips

TEST(NrrdIO, RoundTripEveryTypeEncodingAndGeometryAttached) {
  TempDir dir;
  uint64_t seed = 1;
  for (const auto& g : testGrids()) {
    for (VoxelType t : kAllTypes) {
      for (NrrdEncoding e : kAllEncodings) {
        SCOPED_TRACE(std::string(g.name) + " " + voxelTypeName(t) + " " + encodingName(e));
        const RawVolume v = randomVolume(t, g.grid, seed++);
        const std::string path = dir.file("vol.nrrd");
        writeNrrd(path, v, e);
        expectSameVolume(v, readNrrd(path), g.exact);
      }
    }
  }
}

TEST(NrrdIO, RoundTripEveryTypeEncodingAndGeometryDetached) {
  TempDir dir;
  uint64_t seed = 1000;
  for (const auto& g : testGrids()) {
    for (VoxelType t : kAllTypes) {
      for (NrrdEncoding e : kAllEncodings) {
        SCOPED_TRACE(std::string(g.name) + " " + voxelTypeName(t) + " " + encodingName(e));
        const RawVolume v = randomVolume(t, g.grid, seed++);
        const std::string path = dir.file("vol.nhdr");
        writeNrrd(path, v, e);
        expectSameVolume(v, readNrrd(path), g.exact);
      }
    }
  }
  // One data file per encoding, named after the header.
  EXPECT_TRUE(fs::exists(dir.file("vol.raw")));
  EXPECT_TRUE(fs::exists(dir.file("vol.raw.gz")));
  EXPECT_TRUE(fs::exists(dir.file("vol.txt")));
}

TEST(NrrdIO, WrittenHeaderFollowsTheSpec) {
  TempDir dir;
  GridGeometry g;
  g.dims = {2, 3, 4};
  g.spacing = {0.5, 0.25, 2};
  g.origin = {1, 2, 3};
  const RawVolume v = randomVolume(VoxelType::Int16, g, 7);
  writeNrrd(dir.file("h.nhdr"), v, NrrdEncoding::Gzip);
  const std::string h = readText(dir.file("h.nhdr"));
  for (const char* frag :
       {"NRRD0004\n", "type: short\n", "dimension: 3\n", "space: left-posterior-superior\n", "sizes: 2 3 4\n",
        "space directions: (0.5,0,0) (0,0.25,0) (0,0,2)\n", "kinds: domain domain domain\n",
        "endian: little\n", "encoding: gzip\n", "space origin: (1,2,3)\n", "data file: h.raw.gz\n"})
    EXPECT_NE(h.find(frag), std::string::npos) << "header lacks " << frag << ":\n" << h;
  // The data file really is little-endian gzip of the values.
  const std::string packed = readText(dir.file("h.raw.gz"));
  const auto plain = gunzip(packed.data(), packed.size(), -1, "h.raw.gz");
  const std::string le = bytesOf(valuesOf<int16_t>(v), false);
  EXPECT_EQ(std::string(plain.begin(), plain.end()), le);
}

TEST(NrrdIO, WriterKeepsDoublesExact) {
  TempDir dir;
  GridGeometry g;
  g.dims = {2, 2, 2};
  g.spacing = {0.1, 1.0 / 3.0, std::nextafter(1.0, 2.0)};
  g.origin = {-0.1, 1e-300, 123456789.123456789};
  RawVolume v = randomVolume(VoxelType::Float64, g, 3);
  writeNrrd(dir.file("d.nrrd"), v, NrrdEncoding::Raw);
  expectSameVolume(v, readNrrd(dir.file("d.nrrd")), true);
}

TEST(NrrdIO, FailedWriteLeavesNothingBehind) {
  TempDir dir;
  GridGeometry g;
  g.dims = {2, 2, 2};
  const RawVolume v = randomVolume(VoxelType::UInt8, g, 5);
  const std::string missing = (dir.path() / "no_such_folder" / "out.nrrd").string();
  EXPECT_THROW_MSG(writeNrrd(missing, v), InputError, "no_such_folder", "does not exist");
  const std::string missingDetached = (dir.path() / "no_such_folder" / "out.nhdr").string();
  EXPECT_THROW_MSG(writeNrrd(missingDetached, v, NrrdEncoding::Raw), InputError, "no_such_folder");
  EXPECT_FALSE(fs::exists(dir.path() / "no_such_folder"));

  // An invalid volume does not touch an existing target.
  writeBytes(dir.file("keep.nrrd"), "old contents");
  writeBytes(dir.file("keep.raw"), "old data");
  RawVolume bad = v;
  bad.bytes.pop_back();
  EXPECT_THROW_MSG(writeNrrd(dir.file("keep.nrrd"), bad), InputError, "keep.nrrd", "expected 8");
  EXPECT_THROW_MSG(writeNrrd(dir.file("keep.nhdr"), bad, NrrdEncoding::Raw), InputError,
                   "keep.nhdr");
  RawVolume badGrid = v;
  badGrid.grid.spacing[1] = 0;
  EXPECT_THROW_MSG(writeNrrd(dir.file("keep.nrrd"), badGrid), InputError, "keep.nrrd", "spacing");
  EXPECT_EQ(readText(dir.file("keep.nrrd")), "old contents");
  EXPECT_EQ(readText(dir.file("keep.raw")), "old data");
  // No temporaries are left over.
  int entries = 0;
  for (const auto& e : fs::directory_iterator(dir.path())) {
    (void)e;
    ++entries;
  }
  EXPECT_EQ(entries, 2);

  // Writing over an existing file replaces it.
  writeNrrd(dir.file("keep.nrrd"), v, NrrdEncoding::Raw);
  expectSameVolume(v, readNrrd(dir.file("keep.nrrd")), true);
}

// ------------------------------------------------------------------------------------------------
// Hand-written files

const std::vector<uint16_t> kU16 = {0, 1, 258, 1000, 40000, 65535, 7, 12345};

TEST(NrrdIO, ReadsLittleAndBigEndianRaw) {
  TempDir dir;
  for (bool big : {false, true}) {
    SCOPED_TRACE(big ? "big" : "little");
    const std::string header = std::string("NRRD0004\n# a comment\ntype: unsigned short\n") +
                               "dimension: 3\nsizes: 2 2 2\nendian: " + (big ? "big" : "little") +
                               "\nencoding: raw\nspacings: 0.5 1 2\n\n";
    writeBytes(dir.file("u16.nrrd"), header + bytesOf(kU16, big));
    const RawVolume v = readNrrd(dir.file("u16.nrrd"));
    EXPECT_EQ(v.type, VoxelType::UInt16);
    EXPECT_EQ(v.grid.dims, (std::array<int64_t, 3>{2, 2, 2}));
    EXPECT_EQ(v.grid.spacing, (Vec3{0.5, 1, 2}));
    EXPECT_EQ(v.grid.origin, (Vec3{0, 0, 0}));
    EXPECT_TRUE(v.grid.isAxisAligned());
    EXPECT_EQ(valuesOf<uint16_t>(v), kU16);
  }
}

TEST(NrrdIO, ReadsBigEndianFloatsWithSpaceDirections) {
  TempDir dir;
  const std::vector<double> vals = {-1.5, 0.1, 1e300, -0.0, 3.25, 42, 1.0 / 3.0, -7e-300};
  const std::string header =
      "NRRD0005\ntype: double\ndimension: 3\nspace: left-posterior-superior\nsizes: 2 2 2\n"
      "space directions: (0,0,-3) (2,0,0) (0, 0.5 ,0)\nkinds: domain domain domain\n"
      "endian: big\nencoding: raw\nspace origin: (10,-20,30.5)\n\n";
  writeBytes(dir.file("f64.nrrd"), header + bytesOf(vals, true));
  const RawVolume v = readNrrd(dir.file("f64.nrrd"));
  EXPECT_EQ(v.type, VoxelType::Float64);
  EXPECT_EQ(valuesOf<double>(v), vals);
  EXPECT_EQ(v.grid.spacing, (Vec3{3, 2, 0.5}));
  // Columns are the normalised space directions; LPS coordinates are kept as given.
  const Mat3 want = {{{0, 1, 0}, {0, 0, 1}, {-1, 0, 0}}};
  EXPECT_EQ(v.grid.direction, want);
  EXPECT_EQ(v.grid.origin, (Vec3{10, -20, 30.5}));
  const Vec3 p = v.grid.indexToPhysical(1, 1, 1);
  EXPECT_EQ(p, (Vec3{12, -19.5, 27.5}));

  const std::vector<float> fv = {1.5f, -2.25f, 3e38f, 0.1f};
  writeBytes(dir.file("f32.nrrd"), "NRRD0004\ntype: float\ndimension: 3\nsizes: 1 2 2\n"
                                   "endian: big\nencoding: raw\n\n" +
                                       bytesOf(fv, true));
  EXPECT_EQ(valuesOf<float>(readNrrd(dir.file("f32.nrrd"))), fv);
}

TEST(NrrdIO, ReadsDetachedDataRelativeToTheHeader) {
  TempDir dir;
  fs::create_directories(dir.path() / "hdr" / "data");
  writeBytes((dir.path() / "hdr" / "data" / "vol.bin").string(), bytesOf(kU16, true));
  writeBytes((dir.path() / "hdr" / "vol.nhdr").string(),
             "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 2 2 2\nendian: big\n"
             "encoding: raw\ndata file: data/vol.bin\n");
  EXPECT_EQ(valuesOf<uint16_t>(readNrrd((dir.path() / "hdr" / "vol.nhdr").string())), kU16);

  // Absolute data file path; header may end with a blank line and trailing text.
  const std::string abs = (dir.path() / "hdr" / "data" / "vol.bin").string();
  writeBytes(dir.file("abs.nhdr"), "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 2 2 2\n"
                                   "endian: big\nencoding: raw\ndatafile: " +
                                       abs + "\n\nignored text");
  EXPECT_EQ(valuesOf<uint16_t>(readNrrd(dir.file("abs.nhdr"))), kU16);
}

TEST(NrrdIO, ReadsGzipInBothByteOrders) {
  TempDir dir;
  const std::vector<int32_t> vals = {-2147483647 - 1, 2147483647, 0, -1, 1, 65536, -65536, 99};
  for (bool big : {false, true}) {
    SCOPED_TRACE(big ? "big" : "little");
    const std::string data = bytesOf(vals, big);
    writeBytes(dir.file("i32.nrrd"), std::string("NRRD0004\ntype: int32_t\ndimension: 3\n") +
                                         "sizes: 2 2 2\nendian: " + (big ? "big" : "little") +
                                         "\nencoding: gz\n\n" +
                                         gzipCompress(data.data(), data.size()));
    EXPECT_EQ(valuesOf<int32_t>(readNrrd(dir.file("i32.nrrd"))), vals);
  }
  // Detached gzip with a byte skip applied to the inflated data.
  const std::string data = std::string(5, 'x') + bytesOf(vals, false);
  writeBytes(dir.file("i32.raw.gz"), gzipCompress(data.data(), data.size()));
  writeBytes(dir.file("i32.nhdr"), "NRRD0004\ntype: int\ndimension: 3\nsizes: 2 2 2\n"
                                   "endian: little\nencoding: gzip\nbyte skip: 5\n"
                                   "data file: i32.raw.gz\n");
  EXPECT_EQ(valuesOf<int32_t>(readNrrd(dir.file("i32.nhdr"))), vals);
  // gzip data that inflate to more than sizes x type: refused, and inflating stops right there
  // (a 64 MiB stream of zeros is not expanded to find out).
  const std::string big(64 << 20, '\0');
  writeBytes(dir.file("bomb.nrrd"), "NRRD0004\ntype: int32_t\ndimension: 3\nsizes: 2 2 2\nendian: little\n"
                                    "encoding: gzip\n\n" + gzipCompress(big.data(), big.size()));
  EXPECT_THROW_MSG(readNrrd(dir.file("bomb.nrrd")), InputError, "bomb.nrrd", "more than the 32 bytes",
                   "sizes or the type");
}

TEST(NrrdIO, ReadsAsciiValues) {
  TempDir dir;
  writeBytes(dir.file("a.nrrd"), "NRRD0004\r\ntype: short\r\ndimension: 3\r\nsizes: 2 2 2\r\n"
                                 "encoding: text\r\n\r\n-32768, 32767\t0\r\n+5 -5\n  1e2 7.0 -0\n");
  EXPECT_EQ(valuesOf<int16_t>(readNrrd(dir.file("a.nrrd"))),
            (std::vector<int16_t>{-32768, 32767, 0, 5, -5, 100, 7, 0}));
  writeBytes(dir.file("f.nrrd"), "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 1 2\n"
                                 "encoding: txt\n\n0.1 -2.5e-3\n1e38 nan\n");
  const auto f = valuesOf<float>(readNrrd(dir.file("f.nrrd")));
  ASSERT_EQ(f.size(), 4u);
  EXPECT_EQ(f[0], 0.1f);
  EXPECT_EQ(f[1], -2.5e-3f);
  EXPECT_EQ(f[2], 1e38f);
  EXPECT_TRUE(std::isnan(f[3]));
  // Detached ascii with a line skip.
  writeBytes(dir.file("vals.txt"), "first line\nsecond line\n1 2 3 4\n5 6 7 8\n");
  writeBytes(dir.file("a.nhdr"), "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\n"
                                 "encoding: ascii\nline skip: 2\ndata file: vals.txt\n");
  EXPECT_EQ(valuesOf<uint8_t>(readNrrd(dir.file("a.nhdr"))),
            (std::vector<uint8_t>{1, 2, 3, 4, 5, 6, 7, 8}));
}

TEST(NrrdIO, LineSkipAndByteSkip) {
  TempDir dir;
  // Detached raw data behind two text lines and 3 more bytes.
  writeBytes(dir.file("d.raw"), "junk line one\njunk line two\nabc" + bytesOf(kU16, false));
  writeBytes(dir.file("d.nhdr"), "NRRD0004\ntype: ushort\ndimension: 3\nsizes: 2 2 2\n"
                                 "endian: little\nencoding: raw\nline skip: 2\nbyte skip: 3\n"
                                 "data file: d.raw\n");
  EXPECT_EQ(valuesOf<uint16_t>(readNrrd(dir.file("d.nhdr"))), kU16);

  // byte skip -1: the data are the last bytes of the file, whatever precedes them.
  writeBytes(dir.file("tail.raw"), std::string(1000, '\x7f') + bytesOf(kU16, true));
  writeBytes(dir.file("tail.nhdr"), "NRRD0004\ntype: unsigned short int\ndimension: 3\n"
                                    "sizes: 2 2 2\nendian: big\nencoding: raw\nbyte skip: -1\n"
                                    "data file: tail.raw\n");
  EXPECT_EQ(valuesOf<uint16_t>(readNrrd(dir.file("tail.nhdr"))), kU16);

  // Attached, with a line skip and byte skip -1 in the same file.
  writeBytes(dir.file("att.nrrd"), "NRRD0004\ntype: uint16_t\ndimension: 3\nsizes: 2 2 2\n"
                                   "endian: little\nencoding: raw\nbyteskip: -1\n\nextra\n" +
                                       bytesOf(kU16, false));
  EXPECT_EQ(valuesOf<uint16_t>(readNrrd(dir.file("att.nrrd"))), kU16);
  writeBytes(dir.file("att2.nrrd"), "NRRD0004\ntype: uint16_t\ndimension: 3\nsizes: 2 2 2\n"
                                    "endian: little\nencoding: raw\nline skip: 1\n\nextra\n" +
                                        bytesOf(kU16, false));
  EXPECT_EQ(valuesOf<uint16_t>(readNrrd(dir.file("att2.nrrd"))), kU16);
  // More bytes than sizes x type: the header is wrong (e.g. uint16 data declared uint8); an error,
  // not a silent read of the first half.
  writeBytes(dir.file("att3.nrrd"), "NRRD0004\ntype: uint16_t\ndimension: 3\nsizes: 2 2 2\n"
                                    "endian: little\nencoding: raw\n\n" + bytesOf(kU16, false) + "trailing");
  EXPECT_THROW_MSG(readNrrd(dir.file("att3.nrrd")), InputError, "att3.nrrd", "24 bytes", "announce 16",
                   "sizes or the type are wrong");
  writeBytes(dir.file("u8.nrrd"), "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n" +
                                      bytesOf(kU16, false));
  EXPECT_THROW_MSG(readNrrd(dir.file("u8.nrrd")), InputError, "u8.nrrd", "16 bytes", "announce 8");
}

TEST(NrrdIO, DimensionFourWithLeadingSingletonAxis) {
  TempDir dir;
  const std::vector<uint8_t> vals = {1, 2, 3, 4, 5, 6};
  writeBytes(dir.file("d4.nrrd"),
             "NRRD0005\ntype: uint8\ndimension: 4\nspace: right-anterior-superior\n"
             "sizes: 1 3 2 1\nspace directions: none (0.5,0,0) (0,2,0) (0,0,4)\n"
             "kinds: list domain domain domain\nencoding: raw\n"
             "space origin: (-1,-2,-3)\n\n" +
                 std::string(vals.begin(), vals.end()));
  const RawVolume v = readNrrd(dir.file("d4.nrrd"));
  EXPECT_EQ(v.grid.dims, (std::array<int64_t, 3>{3, 2, 1}));
  EXPECT_EQ(v.grid.spacing, (Vec3{0.5, 2, 4}));
  // RAS in the file is LPS in TetFlow: x and y negated.
  EXPECT_EQ(v.grid.origin, (Vec3{1, 2, -3}));
  EXPECT_EQ(v.grid.direction, (Mat3{{{-1, 0, 0}, {0, -1, 0}, {0, 0, 1}}}));
  EXPECT_EQ(valuesOf<uint8_t>(v), vals);

  // Dimension 3 with a 'none' leading axis of size 1 and spacings: a single slice.
  writeBytes(dir.file("d3.nrrd"), "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1 3 2\n"
                                  "kinds: scalar domain domain\nspacings: nan 0.5 0.25\n"
                                  "encoding: raw\n\n" +
                                      std::string(vals.begin(), vals.end()));
  const RawVolume s = readNrrd(dir.file("d3.nrrd"));
  EXPECT_EQ(s.grid.dims, (std::array<int64_t, 3>{3, 2, 1}));
  EXPECT_EQ(s.grid.spacing, (Vec3{0.5, 0.25, 1}));
}

TEST(NrrdIO, DimensionTwoIsOneSlice) {
  TempDir dir;
  const std::vector<int8_t> vals = {-128, 127, 0, -1, 5, 6};
  writeBytes(dir.file("d2.nrrd"), "NRRD0001\ntype: signed char\ndimension: 2\nsizes: 3 2\n"
                                  "spacings: 0.5 0.25\naxis mins: 10 20\nencoding: raw\n\n" +
                                      bytesOf(vals, false));
  RawVolume v = readNrrd(dir.file("d2.nrrd"));
  EXPECT_EQ(v.type, VoxelType::Int8);
  EXPECT_EQ(v.grid.dims, (std::array<int64_t, 3>{3, 2, 1}));
  EXPECT_EQ(v.grid.spacing, (Vec3{0.5, 0.25, 1}));
  EXPECT_EQ(v.grid.origin, (Vec3{10, 20, 0}));
  EXPECT_TRUE(v.grid.isAxisAligned());
  EXPECT_EQ(valuesOf<int8_t>(v), vals);

  // 2D in a 2D space, one axis flipped: the slice normal completes a right-handed frame.
  writeBytes(dir.file("d2s.nrrd"),
             "NRRD0004\ntype: int8\ndimension: 2\nspace dimension: 2\n"
             "sizes: 3 2\nspace directions: (-2,0) (0,3)\nspace origin: (4,5)\n"
             "encoding: raw\n\n" +
                 bytesOf(vals, false));
  v = readNrrd(dir.file("d2s.nrrd"));
  EXPECT_EQ(v.grid.spacing, (Vec3{2, 3, 1}));
  EXPECT_EQ(v.grid.origin, (Vec3{4, 5, 0}));
  const Mat3 want = {{{-1, 0, 0}, {0, 1, 0}, {0, 0, -1}}};
  EXPECT_EQ(v.grid.direction, want);
}

TEST(NrrdIO, AxisMinsGiveTheOriginAndCellCentringIsHonoured) {
  TempDir dir;
  writeBytes(dir.file("m.nrrd"), "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 2\n"
                                 "spacings: 2 4 1\naxis mins: 1 2 3\ncenters: cell cell node\n"
                                 "encoding: raw\n\nab");
  const RawVolume v = readNrrd(dir.file("m.nrrd"));
  EXPECT_EQ(v.grid.origin, (Vec3{2, 4, 3}));
}

TEST(NrrdIO, EveryTypeSpellingOfTheSpec) {
  TempDir dir;
  const std::vector<std::pair<std::string, VoxelType>> spellings = {
      {"signed char", VoxelType::Int8},
      {"int8", VoxelType::Int8},
      {"int8_t", VoxelType::Int8},
      {"uchar", VoxelType::UInt8},
      {"unsigned char", VoxelType::UInt8},
      {"uint8", VoxelType::UInt8},
      {"uint8_t", VoxelType::UInt8},
      {"short", VoxelType::Int16},
      {"short int", VoxelType::Int16},
      {"signed short", VoxelType::Int16},
      {"signed short int", VoxelType::Int16},
      {"int16", VoxelType::Int16},
      {"int16_t", VoxelType::Int16},
      {"ushort", VoxelType::UInt16},
      {"unsigned short", VoxelType::UInt16},
      {"unsigned short int", VoxelType::UInt16},
      {"uint16", VoxelType::UInt16},
      {"uint16_t", VoxelType::UInt16},
      {"int", VoxelType::Int32},
      {"signed int", VoxelType::Int32},
      {"int32", VoxelType::Int32},
      {"int32_t", VoxelType::Int32},
      {"uint", VoxelType::UInt32},
      {"unsigned int", VoxelType::UInt32},
      {"uint32", VoxelType::UInt32},
      {"uint32_t", VoxelType::UInt32},
      {"longlong", VoxelType::Int64},
      {"long long", VoxelType::Int64},
      {"long long int", VoxelType::Int64},
      {"signed long long", VoxelType::Int64},
      {"signed long long int", VoxelType::Int64},
      {"int64", VoxelType::Int64},
      {"int64_t", VoxelType::Int64},
      {"ulonglong", VoxelType::UInt64},
      {"unsigned long long", VoxelType::UInt64},
      {"unsigned long long int", VoxelType::UInt64},
      {"uint64", VoxelType::UInt64},
      {"uint64_t", VoxelType::UInt64},
      {"float", VoxelType::Float32},
      {"double", VoxelType::Float64},
  };
  for (const auto& [name, type] : spellings) {
    SCOPED_TRACE(name);
    const size_t n = voxelTypeSize(type);
    std::string data(2 * n, '\0');
    data[0] = 1; // little endian: value 1 in an integer type
    writeBytes(dir.file("t.nrrd"), "NRRD0004\ntype: " + name +
                                       "\ndimension: 3\nsizes: 2 1 1\nendian: little\n"
                                       "encoding: raw\n\n" +
                                       data);
    const RawVolume v = readNrrd(dir.file("t.nrrd"));
    EXPECT_EQ(v.type, type);
    EXPECT_EQ(v.bytes.size(), 2 * n);
  }
}

TEST(NrrdIO, IgnoresCommentsKeyValuesAndUnusedFields) {
  TempDir dir;
  writeBytes(dir.file("kv.nrrd"),
             "NRRD0004\n# comment: with a colon\nmodality:=MRI\ncontent: my volume\n"
             "type: uchar\nunits: \"mm\" \"mm\" \"mm\"\ndimension: 3\nsizes: 2 1 1\n"
             "labels: \"x\" \"y\" \"z\"\nencoding: raw\nendian: big\nmin: 0\nmax: 255\n"
             "measurement frame: (1,0,0) (0,1,0) (0,0,1)\nthicknesses: nan nan 1\n"
             "space units: \"mm\" \"mm\" \"mm\"\n\n\x05\x06");
  EXPECT_EQ(valuesOf<uint8_t>(readNrrd(dir.file("kv.nrrd"))), (std::vector<uint8_t>{5, 6}));
}

TEST(NrrdIO, ReadsTheSharedSpheres) {
  const std::string path = std::string(TETFLOW_TEST_DATA) + "/spheres1.nrrd";
  if (!fs::exists(path)) GTEST_SKIP() << path << " is not present";
  const RawVolume v = readNrrd(path);
  EXPECT_EQ(v.type, VoxelType::Float32);
  EXPECT_EQ(v.grid.dims, (std::array<int64_t, 3>{28, 28, 28}));
  EXPECT_EQ(v.bytes.size(), 28u * 28 * 28 * 4);
}

// A 25-million-voxel gzip label volume must read in a second or two.
TEST(NrrdIO, LargeGzipReadIsFast) {
  TempDir dir;
  RawVolume v;
  v.grid.dims = {300, 300, 280};
  v.type = VoxelType::UInt8;
  v.bytes.resize(static_cast<size_t>(v.grid.voxelCount()));
  for (int64_t k = 0; k < 280; ++k)
    for (int64_t j = 0; j < 300; ++j)
      for (int64_t i = 0; i < 300; ++i) {
        const double r = std::hypot(i - 150.0, j - 150.0, k - 140.0);
        v.bytes[static_cast<size_t>(i + 300 * (j + 300 * k))] = static_cast<uint8_t>(r < 60    ? 3
                                                                                     : r < 100 ? 2
                                                                                     : r < 130 ? 1
                                                                                               : 0);
      }
  writeNrrd(dir.file("big.nrrd"), v, NrrdEncoding::Gzip);
  const auto t0 = std::chrono::steady_clock::now();
  const RawVolume r = readNrrd(dir.file("big.nrrd"));
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  RecordProperty("read_seconds", std::to_string(s));
  std::printf("[ timing ] 25.2M-voxel uint8 gzip NRRD read in %.3f s\n", s);
  EXPECT_TRUE(r.bytes == v.bytes);
  EXPECT_LT(s, 10.0); // generous: shared machine; typical is well under a second
}

// ------------------------------------------------------------------------------------------------
// Broken files

class NrrdBroken : public ::testing::Test {
protected:
  TempDir dir;
  // Writes an attached file "<name>" from header lines (joined with newlines, then a blank line)
  // and data bytes; returns its path.
  std::string attached(const std::string& name, const std::string& header,
                       const std::string& data) {
    const std::string p = dir.file(name);
    writeBytes(p, header + "\n" + data);
    return p;
  }
};

const std::string kGood =
    "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 2 2 2\nendian: little\nencoding: raw\n";

TEST_F(NrrdBroken, NotANrrd) {
  EXPECT_THROW_MSG(readNrrd(dir.file("none.nrrd")), InputError, "none.nrrd", "not found");
  writeBytes(dir.file("empty.nrrd"), "");
  EXPECT_THROW_MSG(readNrrd(dir.file("empty.nrrd")), InputError, "empty.nrrd", "empty");
  writeBytes(dir.file("junk.nrrd"), std::string("\x89PNG\r\n\x1a\n", 8) + std::string(100000, 'x'));
  EXPECT_THROW_MSG(readNrrd(dir.file("junk.nrrd")), InputError, "junk.nrrd", "not a NRRD file");
  writeBytes(dir.file("v9.nrrd"), "NRRD0009\ntype: uchar\n");
  EXPECT_THROW_MSG(readNrrd(dir.file("v9.nrrd")), InputError, "v9.nrrd:1", "NRRD0009");
  fs::create_directories(dir.path() / "folder.nrrd");
  EXPECT_THROW_MSG(readNrrd(dir.file("folder.nrrd")), InputError, "folder.nrrd", "folder");
}

TEST_F(NrrdBroken, HeaderLines) {
  auto p = attached(
      "t.nhdr", "NRRD0004\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\ntype: quaternion\n", "");
  // (type after the blank line does not count)
  EXPECT_THROW_MSG(readNrrd(p), InputError, "t.nhdr", "missing required field 'type'");
  p = attached("head.nhdr", "NRRD0004\n# c\n#c\n#c\n#c\n#c\ntype: quaternion\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "head.nhdr:7: unknown type 'quaternion'");
  p = attached("b.nrrd", "NRRD0004\ntype: block\nblock size: 4\ndimension: 3\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "b.nrrd:2", "'block'", "not supported");
  p = attached("nc.nrrd", "NRRD0004\ntype uchar\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "nc.nrrd:2", "expected 'field: value'");
  p = attached("dup.nrrd", kGood + "sizes: 2 2 2\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "dup.nrrd:7", "'sizes' appears twice", "line 4");
}

TEST_F(NrrdBroken, MissingRequiredFields) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"type", "type: uint16\n"},      {"dimension", "dimension: 3\n"}, {"sizes", "sizes: 2 2 2\n"},
      {"encoding", "encoding: raw\n"}, {"endian", "endian: little\n"},
  };
  for (const auto& [field, line] : cases) {
    SCOPED_TRACE(field);
    std::string h = kGood;
    h.erase(h.find(line), line.size());
    const auto p = attached("miss.nrrd", h, std::string(16, '\0'));
    EXPECT_THROW_MSG(readNrrd(p), InputError, "miss.nrrd",
                     "missing required field '" + field + "'");
  }
  // endian is not needed for single bytes or ascii.
  auto p = attached("u8.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 1 1\nencoding: raw\n",
                    "ab");
  EXPECT_NO_THROW(readNrrd(p));
  p = attached("asc.nrrd", "NRRD0004\ntype: double\ndimension: 3\nsizes: 2 1 1\nencoding: ascii\n",
               "1 2");
  EXPECT_NO_THROW(readNrrd(p));
}

TEST_F(NrrdBroken, BadNumbersAndShapes) {
  auto p =
      attached("n.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 x 2\nencoding: raw\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "n.nrrd:4", "'x'", "not a whole number");
  p = attached("n.nrrd", "NRRD0004\ntype: uint8\ndimension: three\nsizes: 2 2 2\nencoding: raw\n",
               "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "n.nrrd:3", "'three'");
  p = attached("n.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2\nencoding: raw\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "n.nrrd:4", "sizes has 2 values but dimension is 3");
  p = attached("n.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 0 2\nencoding: raw\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "n.nrrd:4", "size 0");
  p = attached("n.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 -3 2\nencoding: raw\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "n.nrrd:4", "size -3");
  p = attached("o.nrrd",
               "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4294967296 4294967296 "
               "4294967296\nencoding: raw\n",
               "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "o.nrrd:4", "overflow");
  p = attached("o.nrrd",
               "NRRD0004\ntype: double\ndimension: 3\nsizes: 4294967296 1073741824 2\nencoding: "
               "raw\nendian: little\n",
               "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "o.nrrd:4", "overflow");
  for (const char* d : {"1", "5", "0"}) {
    p = attached(
        "d.nrrd",
        std::string("NRRD0004\ntype: uint8\ndimension: ") + d + "\nsizes: 2\nencoding: raw\n", "");
    EXPECT_THROW_MSG(readNrrd(p), InputError, "d.nrrd:3",
                     std::string("dimension ") + d + " is not supported");
  }
  p = attached("v.nrrd",
               "NRRD0004\ntype: float\ndimension: 4\nsizes: 3 2 2 2\nkinds: 3-vector domain domain "
               "domain\nencoding: raw\nendian: little\n",
               "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "v.nrrd:4", "3 values per voxel", "3-vector",
                   "not supported");
  p = attached(
      "v.nrrd",
      "NRRD0004\ntype: float\ndimension: 4\nsizes: 2 2 2 3\nencoding: raw\nendian: little\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "v.nrrd:4", "2 values per voxel");
  p = attached("ts.nrrd",
               "NRRD0004\ntype: float\ndimension: 4\nsizes: 2 2 2 3\nkinds: space space space "
               "time\nencoding: raw\nendian: little\n",
               "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "ts.nrrd:4", "4-dimensional", "time series");
  p = attached("v.nrrd",
               "NRRD0004\ntype: float\ndimension: 3\nsizes: 3 4 5\nkinds: RGB-color domain "
               "domain\nencoding: raw\nendian: little\n",
               "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "v.nrrd:4", "rgb-color", "vector");
}

TEST_F(NrrdBroken, BadGeometry) {
  auto p = attached("s.nrrd", kGood + "spacings: 1 0 1\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "s.nrrd:7", "spacing 0", "positive");
  p = attached("s.nrrd", kGood + "spacings: 1 1 -2\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "s.nrrd:7", "spacing -2", "positive");
  p = attached("s.nrrd", kGood + "spacings: 1 1 abc\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "s.nrrd:7", "'abc' is not a number");
  p = attached("s.nrrd", kGood + "spacings: 1 1\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "s.nrrd:7", "2 values but dimension is 3");
  p = attached("sd.nrrd", kGood + "space dimension: 3\nspace directions: (1,0,0) (0,0,0) (0,0,1)\n",
               "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "sd.nrrd:8", "zero length");
  p = attached("sd.nrrd", kGood + "space directions: (1,0,0) (1,1,0) (0,0,1)\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "sd.nrrd:7", "orthonormal");
  p = attached("sd.nrrd", kGood + "space directions: (1,0,0) (0,1,0)\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "sd.nrrd:7", "2 entries but dimension is 3");
  p = attached("sd.nrrd", kGood + "space directions: (1,0,0) (0,1,0) (0,0\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "sd.nrrd:7", "missing ')'");
  p = attached("sd.nrrd", kGood + "space directions: (1,0,0) (0,1,x) (0,0,1)\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "sd.nrrd:7", "'x' is not a number");
  p = attached("sd.nrrd", kGood + "space directions: (1,0,0) none (0,0,1)\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "sd.nrrd:7", "axis 1", "'none'");
  p = attached("sd.nrrd", kGood + "space: 3D-right-handed\nspace directions: (1,0) (0,1) (0,0)\n",
               "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "sd.nrrd:8", "2 components", "space dimension is 3");
  p = attached("sp.nrrd", kGood + "space: upside-down\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "sp.nrrd:7", "unknown space 'upside-down'");
  p = attached("sp.nrrd", kGood + "space: RAST\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "sp.nrrd:7", "time");
  p = attached("so.nrrd", kGood + "space origin: (1,2)\nspace dimension: 3\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "so.nrrd:7", "space origin has 2 components");
  p = attached("so.nrrd", kGood + "space origin: (1,nan,2)\n", "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "so.nrrd:7", "not finite");
}

TEST_F(NrrdBroken, EncodingAndEndian) {
  for (const char* e : {"bzip2", "hex", "bz2", "zrl"}) {
    std::string h = kGood;
    h.replace(h.find("encoding: raw"), 13, std::string("encoding: ") + e);
    const auto p = attached("e.nrrd", h, "");
    EXPECT_THROW_MSG(readNrrd(p), InputError, "e.nrrd:6", std::string("encoding '") + e + "'",
                     "not supported");
  }
  std::string h = kGood;
  h.replace(h.find("encoding: raw"), 13, "encoding: morse");
  auto p = attached("e.nrrd", h, "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "e.nrrd:6", "unknown encoding 'morse'");
  h = kGood;
  h.replace(h.find("endian: little"), 14, "endian: middle");
  p = attached("e.nrrd", h, "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "e.nrrd:5", "unknown endian 'middle'");
  p = attached("bs.nrrd",
               "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: gzip\nbyte skip: -1\n",
               "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "bs.nrrd:6", "only allowed with raw");
  p = attached("bs.nrrd",
               "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nbyte skip: -2\n",
               "");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "bs.nrrd:6", "byte skip '-2'");
  p = attached("ls.nrrd",
               "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nline skip: 5\n",
               "one\ntwo\n");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "ls.nrrd", "line skip 5", "found only 2");
}

TEST_F(NrrdBroken, TruncatedAndAbsurdData) {
  // raw: 7 of 8 bytes
  auto p = attached("tr.nrrd", kGood, std::string(15, '\0'));
  EXPECT_THROW_MSG(readNrrd(p), InputError, "tr.nrrd", "truncated", "holds 15 bytes, expected 16");
  p = attached("tr.nrrd", kGood + "byte skip: -1\n", std::string(15, '\0'));
  EXPECT_THROW_MSG(readNrrd(p), InputError, "tr.nrrd", "holds 15 bytes, expected 16");
  p = attached("tr.nrrd", kGood + "byte skip: 4\n", std::string(16, '\0'));
  EXPECT_THROW_MSG(readNrrd(p), InputError, "tr.nrrd", "holds 12 bytes, expected 16");
  // A lying header is refused before anything is allocated (1 PB would not fit).
  p = attached("huge.nrrd",
               "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 100000 100000 100000\nencoding: raw\n",
               "abc");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "huge.nrrd",
                   "holds 3 bytes, expected 1000000000000000");
  const std::string small = gzipCompress("abcdefgh", 8);
  p = attached("hugez.nrrd",
               "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 100000 100000 100000\nencoding: gzip\n",
               small);
  EXPECT_THROW_MSG(readNrrd(p), InputError, "hugez.nrrd", "cannot hold");
  // gzip: the stream is shorter than announced
  p = attached("trz.nrrd", kGood.substr(0, kGood.find("encoding")) + "encoding: gzip\n", small);
  EXPECT_THROW_MSG(readNrrd(p), InputError, "trz.nrrd", "truncated", "holds 8 bytes, expected 16");
  // gzip announced but raw bytes stored
  p = attached("bad.nrrd", kGood.substr(0, kGood.find("encoding")) + "encoding: gzip\n",
               std::string(64, 'z'));
  EXPECT_THROW_MSG(readNrrd(p), InputError, "bad.nrrd", "corrupt");
  // no blank line and no data file
  writeBytes(dir.file("nodata.nhdr"), kGood);
  EXPECT_THROW_MSG(readNrrd(dir.file("nodata.nhdr")), InputError, "nodata.nhdr", "no data");
}

TEST_F(NrrdBroken, Ascii) {
  const std::string h = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: ascii\n";
  auto p = attached("a.nrrd", h, "1 2 3 4 5 6 7\n");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "a.nrrd", "ascii data are truncated", "8 values");
  p = attached("a.nrrd", h, "1     2     3     4     5     6     7\n");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "a.nrrd", "they hold 7 values, expected 8 values");
  p = attached("a.nrrd", h, "1 2 abc 4 5 6 7 8\n");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "a.nrrd", "ascii value 3 'abc'", "not a valid uint8");
  p = attached("a.nrrd", h, "1 2 3 300 5 6 7 8\n");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "a.nrrd", "ascii value 4 '300'");
  p = attached("a.nrrd", h, "1 2 3 -1 5 6 7 8\n");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "a.nrrd", "ascii value 4 '-1'");
  p = attached("a.nrrd", h, "1 2 3 4.5 5 6 7 8\n");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "a.nrrd", "ascii value 4 '4.5'");
  p = attached(
      "a.nrrd",
      "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 100000 100000 100000\nencoding: ascii\n",
      "1 2 3");
  EXPECT_THROW_MSG(readNrrd(p), InputError, "a.nrrd", "truncated");
}

TEST_F(NrrdBroken, DetachedDataFiles) {
  writeBytes(dir.file("head.nhdr"), kGood + "data file: missing.raw\n");
  EXPECT_THROW_MSG(readNrrd(dir.file("head.nhdr")), InputError, "head.nhdr:7", "missing.raw",
                   "not found");
  writeBytes(dir.file("list.nhdr"), kGood + "data file: LIST\na.raw\nb.raw\n");
  EXPECT_THROW_MSG(readNrrd(dir.file("list.nhdr")), InputError, "list.nhdr:7", "LIST",
                   "not supported");
  writeBytes(dir.file("fmt.nhdr"), kGood + "data file: slice%03d.raw 1 10 1\n");
  EXPECT_THROW_MSG(readNrrd(dir.file("fmt.nhdr")), InputError, "fmt.nhdr:7", "numbered files");
  // Truncated detached data: both names appear.
  writeBytes(dir.file("short.raw"), std::string(10, '\0'));
  writeBytes(dir.file("short.nhdr"), kGood + "data file: short.raw\n");
  EXPECT_THROW_MSG(readNrrd(dir.file("short.nhdr")), InputError, "short.nhdr", "short.raw",
                   "holds 10 bytes, expected 16");
}

TEST(NrrdIO, RasAndLpsHeadersOfTheSameGridReadAlike) {
  TempDir dir;
  const std::string data(8, '\x07');
  writeBytes(dir.file("lps.nrrd"), "NRRD0004\ntype: uint8\ndimension: 3\nspace: left-posterior-superior\n"
                                   "sizes: 2 2 2\nspace directions: (-1,0,0) (0,-2,0) (0,0,3)\n"
                                   "encoding: raw\nspace origin: (10,20,30)\n\n" + data);
  writeBytes(dir.file("ras.nrrd"), "NRRD0004\ntype: uint8\ndimension: 3\nspace: RAS\n"
                                   "sizes: 2 2 2\nspace directions: (1,0,0) (0,2,0) (0,0,3)\n"
                                   "encoding: raw\nspace origin: (-10,-20,30)\n\n" + data);
  writeBytes(dir.file("las.nrrd"), "NRRD0004\ntype: uint8\ndimension: 3\nspace: left-anterior-superior\n"
                                   "sizes: 2 2 2\nspace directions: (-1,0,0) (0,2,0) (0,0,3)\n"
                                   "encoding: raw\nspace origin: (10,-20,30)\n\n" + data);
  const GridGeometry lps = readNrrd(dir.file("lps.nrrd")).grid;
  EXPECT_EQ(readNrrd(dir.file("ras.nrrd")).grid, lps);
  EXPECT_EQ(readNrrd(dir.file("las.nrrd")).grid, lps);
  EXPECT_EQ(lps.origin, (Vec3{10, 20, 30}));
  EXPECT_EQ(lps.spacing, (Vec3{1, 2, 3}));
}

} // namespace
} // namespace tetflow
