// INR reader / writer: round trips of every voxel type (plain and gzip), hand-written headers in
// both CPU byte orders, gzip detected by content, and a corpus of broken files.
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
#include "Algorithms/IO/InrIO.h"
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



// Random bytes are fine here: INR stores the bytes as they are (no text form).
RawVolume randomRawBytes(VoxelType t, const GridGeometry& g, uint64_t seed) {
  RawVolume v;
  v.grid = g;
  v.type = t;
  std::mt19937_64 rng(seed);
  v.bytes.resize(static_cast<size_t>(g.voxelCount()) * voxelTypeSize(t));
  for (auto& b : v.bytes) b = static_cast<unsigned char>(rng());
  return v;
}

// "#INRIMAGE-4#{" + lines, padded with newlines to `blocks` * 256 bytes, closed by "##}".
std::string inrHeader(const std::string& lines, int blocks = 1) {
  std::string h = "#INRIMAGE-4#{\n" + lines;
  const size_t total = static_cast<size_t>(blocks) * 256;
  EXPECT_LE(h.size() + 4, total);
  h.append(total - h.size() - 4, '\n');
  return h + "##}\n";
}

using tetflow::test::readText;

// ------------------------------------------------------------------------------------------------
// Round trips

TEST(InrIO, RoundTripEveryTypePlainAndGzip) {
  TempDir dir;
  GridGeometry g;
  g.dims = {5, 3, 4};
  g.spacing = {0.3, 1.0 / 3.0, 2.5};
  g.origin = {-10.1, 0.0, 1e-7};
  uint64_t seed = 11;
  for (VoxelType t : kAllTypes) {
    for (const char* name : {"vol.inr", "vol.inr.gz", "VOL.INR.GZ"}) {
      SCOPED_TRACE(std::string(voxelTypeName(t)) + " " + name);
      const RawVolume v = randomRawBytes(t, g, seed++);
      const std::string path = dir.file(name);
      writeInr(path, v);
      const std::string bytes = readText(path);
      EXPECT_EQ(looksGzipped(bytes.data(), bytes.size()), std::string(name) != "vol.inr");
      const RawVolume r = readInr(path);
      EXPECT_EQ(r.type, v.type);
      EXPECT_EQ(r.grid, v.grid); // exact: %.17g
      EXPECT_TRUE(r.bytes == v.bytes);
    }
  }
}

TEST(InrIO, WrittenHeaderIsPaddedTo256Bytes) {
  TempDir dir;
  GridGeometry g;
  g.dims = {2, 3, 1};
  g.spacing = {0.5, 0.25, 4};
  g.origin = {1, 2, 3};
  const RawVolume v = randomRawBytes(VoxelType::Float32, g, 3);
  writeInr(dir.file("h.inr"), v);
  const std::string f = readText(dir.file("h.inr"));
  ASSERT_EQ(f.size(), 256 + v.bytes.size());
  EXPECT_EQ(f.substr(0, 14), "#INRIMAGE-4#{\n");
  EXPECT_EQ(f.substr(252, 4), "##}\n");
  for (const char* frag :
       {"XDIM=2\n", "YDIM=3\n", "ZDIM=1\n", "VDIM=1\n", "TYPE=float\n", "PIXSIZE=32 bits\n",
        "CPU=decm\n", "VX=0.5\n", "VY=0.25\n", "VZ=4\n", "TX=1\n", "TY=2\n", "TZ=3\n"})
    EXPECT_NE(f.find(frag), std::string::npos) << frag;
  // Data little endian right after the header.
  EXPECT_EQ(f.substr(256), bytesOf(valuesOf<float>(v), false));
}

TEST(InrIO, WriterRefusesRotatedGridsAndLeavesNothingBehind) {
  TempDir dir;
  GridGeometry g;
  g.dims = {2, 2, 2};
  g.direction = {{{-1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  const RawVolume v = randomRawBytes(VoxelType::UInt8, g, 1);
  writeBytes(dir.file("keep.inr"), "old");
  EXPECT_THROW_MSG(writeInr(dir.file("keep.inr"), v), InputError, "keep.inr", "rotated or flipped",
                   ".nrrd");
  EXPECT_EQ(readText(dir.file("keep.inr")), "old");
  RawVolume ok = v;
  ok.grid.direction = identity3();
  EXPECT_THROW_MSG(writeInr((dir.path() / "nope" / "x.inr.gz").string(), ok), InputError, "nope",
                   "does not exist");
  EXPECT_FALSE(fs::exists(dir.path() / "nope"));
  RawVolume bad = ok;
  bad.bytes.resize(3);
  EXPECT_THROW_MSG(writeInr(dir.file("keep.inr"), bad), InputError, "keep.inr", "expected 8");
  EXPECT_EQ(readText(dir.file("keep.inr")), "old");
  int entries = 0;
  for (const auto& e : fs::directory_iterator(dir.path())) {
    (void)e;
    ++entries;
  }
  EXPECT_EQ(entries, 1);
}

// ------------------------------------------------------------------------------------------------
// Hand-written files

TEST(InrIO, ReadsBothCpuByteOrders) {
  TempDir dir;
  const std::vector<int16_t> vals = {-32768, 32767, 0, -1, 258, 1000, -1000, 7};
  for (const char* cpu : {"decm", "alpha", "pc", "sun", "sgi"}) {
    SCOPED_TRACE(cpu);
    const bool big = std::string(cpu) == "sun" || std::string(cpu) == "sgi";
    const std::string h = inrHeader(std::string("XDIM=2\nYDIM=2\nZDIM=2\nVDIM=1\n") +
                                    "TYPE=signed fixed\nPIXSIZE=16 bits\nSCALE=2**0\nCPU=" + cpu +
                                    "\nVX=0.5\nVY=0.75\nVZ=3\n#GEOMETRY=CARTESIAN\n");
    writeBytes(dir.file("s16.inr"), h + bytesOf(vals, big));
    const RawVolume v = readInr(dir.file("s16.inr"));
    EXPECT_EQ(v.type, VoxelType::Int16);
    EXPECT_EQ(v.grid.dims, (std::array<int64_t, 3>{2, 2, 2}));
    EXPECT_EQ(v.grid.spacing, (Vec3{0.5, 0.75, 3}));
    EXPECT_EQ(v.grid.origin, (Vec3{0, 0, 0})); // no TX/TY/TZ
    EXPECT_TRUE(v.grid.isAxisAligned());
    EXPECT_EQ(valuesOf<int16_t>(v), vals);
  }
  const std::vector<double> d = {1.5, -0.1, 1e300, 4};
  writeBytes(
      dir.file("f64.inr"),
      inrHeader("XDIM=1\nYDIM=4\nTYPE=float\nPIXSIZE=64 bits\nCPU=sun\nTX=-1.5\nTY=2\nTZ=1e3\n") +
          bytesOf(d, true));
  const RawVolume v = readInr(dir.file("f64.inr"));
  EXPECT_EQ(v.type, VoxelType::Float64);
  EXPECT_EQ(v.grid.dims, (std::array<int64_t, 3>{1, 4, 1})); // ZDIM defaults to 1
  EXPECT_EQ(v.grid.origin, (Vec3{-1.5, 2, 1000}));
  EXPECT_EQ(valuesOf<double>(v), d);
}

TEST(InrIO, ReadsEveryTypeAndPixelSize) {
  TempDir dir;
  const std::vector<std::tuple<std::string, int, VoxelType>> cases = {
      {"unsigned fixed", 8, VoxelType::UInt8},   {"signed fixed", 8, VoxelType::Int8},
      {"unsigned fixed", 16, VoxelType::UInt16}, {"signed fixed", 16, VoxelType::Int16},
      {"unsigned fixed", 32, VoxelType::UInt32}, {"signed fixed", 32, VoxelType::Int32},
      {"unsigned fixed", 64, VoxelType::UInt64}, {"signed fixed", 64, VoxelType::Int64},
      {"float", 32, VoxelType::Float32},         {"float", 64, VoxelType::Float64},
  };
  for (const auto& [type, bits, want] : cases) {
    SCOPED_TRACE(type + " " + std::to_string(bits));
    writeBytes(dir.file("t.inr"), inrHeader("XDIM=3\nYDIM=1\nZDIM=1\nTYPE=" + type + "\nPIXSIZE=" +
                                            std::to_string(bits) + " bits\nCPU=pc\n") +
                                      std::string(3 * static_cast<size_t>(bits) / 8, '\x01'));
    const RawVolume v = readInr(dir.file("t.inr"));
    EXPECT_EQ(v.type, want);
    EXPECT_EQ(v.bytes.size(), 3u * bits / 8);
  }
}

TEST(InrIO, LongHeaderAndGzipDetectedByContent) {
  TempDir dir;
  std::string comments;
  for (int i = 0; i < 30; ++i) comments += "#comment line number " + std::to_string(i) + "\n";
  const std::vector<uint16_t> vals = {1, 2, 3, 4, 5, 6};
  const std::string file =
      inrHeader("XDIM=3\nYDIM=2\nZDIM=1\nVDIM=1\n" + comments +
                    "TYPE=unsigned fixed\nPIXSIZE=16 bits\nCPU=sgi\nVX=1\nVY=1\nVZ=1\n",
                4) +
      bytesOf(vals, true);
  writeBytes(dir.file("long.inr"), file);
  EXPECT_EQ(valuesOf<uint16_t>(readInr(dir.file("long.inr"))), vals);
  // Gzip content under a plain .inr name, and under .inr.gz.
  const std::string packed = gzipCompress(file.data(), file.size());
  writeBytes(dir.file("packed.inr"), packed);
  EXPECT_EQ(valuesOf<uint16_t>(readInr(dir.file("packed.inr"))), vals);
  writeBytes(dir.file("packed.inr.gz"), packed);
  EXPECT_EQ(valuesOf<uint16_t>(readInr(dir.file("packed.inr.gz"))), vals);
  // Plain content under a .gz name.
  writeBytes(dir.file("plain.inr.gz"), file);
  EXPECT_EQ(valuesOf<uint16_t>(readInr(dir.file("plain.inr.gz"))), vals);
  // A tiny gzip file (header + 1 byte).
  const std::string tiny =
      inrHeader("XDIM=1\nYDIM=1\nTYPE=unsigned fixed\nPIXSIZE=8 bits\n") + "\x2a";
  writeBytes(dir.file("tiny.inr.gz"), gzipCompress(tiny.data(), tiny.size()));
  EXPECT_EQ(valuesOf<uint8_t>(readInr(dir.file("tiny.inr.gz"))), (std::vector<uint8_t>{42}));
}

// A 25-million-voxel gzip label volume must read in a second or two.
TEST(InrIO, LargeGzipReadIsFast) {
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
  writeInr(dir.file("big.inr.gz"), v);
  const auto t0 = std::chrono::steady_clock::now();
  const RawVolume r = readInr(dir.file("big.inr.gz"));
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  RecordProperty("read_seconds", std::to_string(s));
  std::printf("[ timing ] 25.2M-voxel uint8 gzip INR read in %.3f s\n", s);
  EXPECT_TRUE(r.bytes == v.bytes);
  EXPECT_LT(s, 10.0); // generous: shared machine; typical is well under a second
}

// ------------------------------------------------------------------------------------------------
// Broken files

const std::string kFields =
    "XDIM=2\nYDIM=2\nZDIM=2\nVDIM=1\nTYPE=unsigned fixed\nPIXSIZE=8 bits\nCPU=decm\n"
    "VX=1\nVY=1\nVZ=1\n";

// Header with `from` replaced by `to` in the standard fields.
std::string headerWith(const std::string& from, const std::string& to) {
  std::string f = kFields;
  const size_t p = f.find(from);
  EXPECT_NE(p, std::string::npos) << from;
  f.replace(p, from.size(), to);
  return inrHeader(f);
}

TEST(InrBroken, NotAnInr) {
  TempDir dir;
  EXPECT_THROW_MSG(readInr(dir.file("none.inr")), InputError, "none.inr", "not found");
  writeBytes(dir.file("empty.inr"), "");
  EXPECT_THROW_MSG(readInr(dir.file("empty.inr")), InputError, "empty.inr", "not an INR file");
  writeBytes(dir.file("nrrd.inr"), "NRRD0004\ntype: uchar\n" + std::string(5000, 'x'));
  EXPECT_THROW_MSG(readInr(dir.file("nrrd.inr")), InputError, "nrrd.inr", "not an INR file");
  const std::string z = gzipCompress("hello world", 11);
  writeBytes(dir.file("z.inr.gz"), z);
  EXPECT_THROW_MSG(readInr(dir.file("z.inr.gz")), InputError, "z.inr.gz", "not an INR file");
  writeBytes(dir.file("corrupt.inr.gz"), std::string("\x1f\x8b", 2) + std::string(300, 'q'));
  EXPECT_THROW_MSG(readInr(dir.file("corrupt.inr.gz")), InputError, "corrupt.inr.gz", "corrupt");
  // The end line never comes.
  writeBytes(dir.file("open.inr"), "#INRIMAGE-4#{\nXDIM=2\n" + std::string(600, '\n'));
  EXPECT_THROW_MSG(readInr(dir.file("open.inr")), InputError, "open.inr", "truncated", "##}");
  const std::string open = "#INRIMAGE-4#{\nXDIM=2\n" + std::string(600, '\n');
  writeBytes(dir.file("open.inr.gz"), gzipCompress(open.data(), open.size()));
  EXPECT_THROW_MSG(readInr(dir.file("open.inr.gz")), InputError, "open.inr.gz", "##}");
  writeBytes(dir.file("endless.inr"), "#INRIMAGE-4#{\n" + std::string(2 << 20, '\n'));
  EXPECT_THROW_MSG(readInr(dir.file("endless.inr")), InputError, "endless.inr", "1 MiB");
}

TEST(InrBroken, HeaderFields) {
  TempDir dir;
  const std::string data(8, '\0');
  struct Case {
    std::string from, to;
    std::vector<std::string> fragments;
  };
  const std::vector<Case> cases = {
      {"XDIM=2\n", "", {"b.inr", "no XDIM"}},
      {"YDIM=2\n", "", {"b.inr", "no YDIM"}},
      {"TYPE=unsigned fixed\n", "", {"b.inr", "no TYPE"}},
      {"PIXSIZE=8 bits\n", "", {"b.inr", "no PIXSIZE"}},
      {"VDIM=1", "VDIM=3", {"b.inr:5", "VDIM=3", "vector"}},
      {"TYPE=unsigned fixed", "TYPE=packed", {"b.inr:6", "unknown TYPE 'packed'"}},
      {"PIXSIZE=8 bits", "PIXSIZE=12 bits", {"b.inr:7", "PIXSIZE '12 bits'", "8, 16, 32 or 64"}},
      {"PIXSIZE=8 bits", "PIXSIZE=eight", {"b.inr:7", "'eight'", "like '8 bits'"}},
      {"TYPE=unsigned fixed\nPIXSIZE=8 bits",
       "TYPE=float\nPIXSIZE=16 bits",
       {"b.inr:7", "does not match TYPE float"}},
      {"CPU=decm", "CPU=vax", {"b.inr:8", "unknown CPU 'vax'"}},
      {"VX=1", "VX=0", {"b.inr:9", "VX=0", "positive"}},
      {"VY=1", "VY=-2.5", {"b.inr:10", "VY=-2.5", "positive"}},
      {"VZ=1", "VZ=abc", {"b.inr:11", "VZ 'abc' is not a number"}},
      {"XDIM=2", "XDIM=abc", {"b.inr:2", "XDIM 'abc'", "whole number"}},
      {"YDIM=2", "YDIM=0", {"b.inr:3", "YDIM '0'"}},
      {"ZDIM=2", "ZDIM=-4", {"b.inr:4", "ZDIM '-4'"}},
      {"VX=1", "TX=nan", {"b.inr:9", "TX 'nan' is not a number"}},
      {"VX=1", "junk line", {"b.inr:9", "expected KEY=VALUE"}},
      {"XDIM=2\nYDIM=2\nZDIM=2",
       "XDIM=4294967296\nYDIM=4294967296\nZDIM=4294967296",
       {"b.inr", "overflows"}},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.to);
    writeBytes(dir.file("b.inr"), headerWith(c.from, c.to) + data);
    try {
      readInr(dir.file("b.inr"));
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      for (const auto& f : c.fragments)
        EXPECT_NE(std::string(e.what()).find(f), std::string::npos)
            << "message '" << e.what() << "' lacks '" << f << "'";
    }
  }
}

TEST(InrBroken, TruncatedMismatchedAndAbsurdData) {
  TempDir dir;
  const std::string h = inrHeader(kFields);
  writeBytes(dir.file("t.inr"), h + std::string(7, '\0'));
  EXPECT_THROW_MSG(readInr(dir.file("t.inr")), InputError, "t.inr", "truncated",
                   "holds 7 bytes after the header, expected 8");
  writeBytes(dir.file("m.inr"), h + std::string(16, '\0'));
  EXPECT_THROW_MSG(readInr(dir.file("m.inr")), InputError, "m.inr", "does not match",
                   "holds 16 bytes after the header, expected 8");
  const std::string tz = h + std::string(7, '\0');
  writeBytes(dir.file("t.inr.gz"), gzipCompress(tz.data(), tz.size()));
  EXPECT_THROW_MSG(readInr(dir.file("t.inr.gz")), InputError, "t.inr.gz", "truncated",
                   "expected 264");
  // Lying sizes: refused before allocating (1e15 bytes).
  const std::string huge =
      headerWith("XDIM=2\nYDIM=2\nZDIM=2", "XDIM=100000\nYDIM=100000\nZDIM=100000");
  writeBytes(dir.file("huge.inr"), huge + "abc");
  EXPECT_THROW_MSG(readInr(dir.file("huge.inr")), InputError, "huge.inr",
                   "holds 3 bytes after the header, expected 1000000000000000");
  writeBytes(dir.file("huge.inr.gz"), gzipCompress(huge.data(), huge.size()));
  EXPECT_THROW_MSG(readInr(dir.file("huge.inr.gz")), InputError, "huge.inr.gz", "cannot hold");
}

} // namespace
} // namespace tetflow
