// NIfTI, MetaImage and VTI through VTK: round trips, hand-written files in both byte orders, and
// broken files with their messages.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <random>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/IO/FileUtil.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Algorithms/IO/VtkVolumeIO.h"
#include "TestUtil.h"

using namespace tetflow;
using tetflow::test::TempDir;
using tetflow::test::writeBytes;

namespace {

RawVolume randomRaw(VoxelType t, std::array<int64_t, 3> dims, unsigned seed) {
  RawVolume v;
  v.grid.dims = dims;
  v.grid.spacing = {0.617, 0.617, 1.333};
  v.grid.origin = {-12.5, 3.25, 100.0};
  v.type = t;
  v.bytes.resize(static_cast<size_t>(v.grid.voxelCount()) * voxelTypeSize(t));
  std::mt19937 rng(seed);
  for (auto& b : v.bytes) b = static_cast<unsigned char>(rng());
  if (!voxelTypeIsInteger(t)) { // keep floats finite: small integers
    const int64_t n = v.grid.voxelCount();
    for (int64_t i = 0; i < n; ++i) {
      if (t == VoxelType::Float32) {
        float x = static_cast<float>(static_cast<int>(rng() % 2001) - 1000) / 8.0f;
        std::memcpy(v.bytes.data() + i * 4, &x, 4);
      } else {
        double x = static_cast<double>(static_cast<int>(rng() % 2001) - 1000) / 8.0;
        std::memcpy(v.bytes.data() + i * 8, &x, 8);
      }
    }
  }
  return v;
}

void expectNearGeometry(const GridGeometry& a, const GridGeometry& b, double tol = 1e-5) {
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(a.dims[i], b.dims[i]);
    EXPECT_NEAR(a.spacing[i], b.spacing[i], tol);
    EXPECT_NEAR(a.origin[i], b.origin[i], tol);
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(a.direction[i][j], b.direction[i][j], 1e-6);
  }
}

// Same voxels at the same physical places, whatever the index order (VTK turns a left-handed
// NIfTI grid into a right-handed one by reversing the slices).
void expectSamePhysicalVolume(const RawVolume& a, const RawVolume& b) {
  ASSERT_EQ(a.type, b.type);
  ASSERT_EQ(a.grid.voxelCount(), b.grid.voxelCount());
  const auto& g = a.grid;
  for (int64_t k = 0; k < g.dims[2]; ++k)
    for (int64_t j = 0; j < g.dims[1]; ++j)
      for (int64_t i = 0; i < g.dims[0]; ++i) {
        const Vec3 d = g.indexToPhysical(i, j, k) - b.grid.origin;
        int64_t idx[3];
        for (int ax = 0; ax < 3; ++ax) {
          double s = 0;
          for (int r = 0; r < 3; ++r) s += b.grid.direction[r][ax] * d[r];
          idx[ax] = std::llround(s / b.grid.spacing[ax]);
          ASSERT_GE(idx[ax], 0);
          ASSERT_LT(idx[ax], b.grid.dims[ax]);
        }
        const int64_t ia = i + g.dims[0] * (j + g.dims[1] * k);
        const int64_t ib = idx[0] + b.grid.dims[0] * (idx[1] + b.grid.dims[1] * idx[2]);
        ASSERT_EQ(a.valueAsDouble(ia), b.valueAsDouble(ib)) << i << "," << j << "," << k;
      }
}

// Minimal NIfTI-1 single-file writer used to make hand-written test files in either byte order.
std::string niftiBytes(bool bigEndian, int16_t datatype, int16_t bitpix, std::array<int16_t, 3> dim,
                       std::array<float, 3> pixdim, std::array<float, 3> offset,
                       const std::vector<unsigned char>& voxelsLittleEndian, int16_t ndim = 3,
                       int16_t dim4 = 1) {
  std::string h(352, '\0');
  auto put = [&](size_t off, const void* p, size_t n) {
    std::memcpy(h.data() + off, p, n);
    if (bigEndian) std::reverse(h.begin() + off, h.begin() + off + n);
  };
  const int32_t sizeofHdr = 348;
  put(0, &sizeofHdr, 4);
  int16_t dims[8] = {ndim, dim[0], dim[1], dim[2], dim4, 1, 1, 1};
  for (int i = 0; i < 8; ++i) put(40 + 2 * i, &dims[i], 2);
  put(70, &datatype, 2);
  put(72, &bitpix, 2);
  float pd[8] = {1, pixdim[0], pixdim[1], pixdim[2], 1, 1, 1, 1};
  for (int i = 0; i < 8; ++i) put(76 + 4 * i, &pd[i], 4);
  const float voxOffset = 352;
  put(108, &voxOffset, 4);
  const float slope = 1.0f;
  put(112, &slope, 4);
  const int16_t qformCode = 1;
  put(252, &qformCode, 2);
  // identity quaternion (b=c=d=0), offsets in RAS
  for (int a = 0; a < 3; ++a) put(268 + 4 * a, &offset[a], 4);
  std::memcpy(h.data() + 344, "n+1\0", 4);
  std::string data(voxelsLittleEndian.begin(), voxelsLittleEndian.end());
  if (bigEndian && bitpix > 8) {
    const size_t s = static_cast<size_t>(bitpix / 8);
    for (size_t i = 0; i + s <= data.size(); i += s) std::reverse(data.begin() + i, data.begin() + i + s);
  }
  return h + data;
}

std::vector<unsigned char> int16Bytes(const std::vector<int16_t>& v) {
  std::vector<unsigned char> b(v.size() * 2);
  std::memcpy(b.data(), v.data(), b.size());
  return b;
}

} // namespace

TEST(VtkVolumeIO, RoundTripEveryTypeThroughNiftiMetaImageAndVti) {
  TempDir tmp;
  const VoxelType types[] = {VoxelType::Int8,   VoxelType::UInt8,  VoxelType::Int16,
                             VoxelType::UInt16, VoxelType::Int32,  VoxelType::UInt32,
                             VoxelType::Float32, VoxelType::Float64};
  unsigned seed = 1;
  for (const char* ext : {".nii", ".nii.gz", ".mha", ".mhd", ".vti"}) {
    for (VoxelType t : types) {
      const RawVolume v = randomRaw(t, {5, 4, 3}, seed++);
      const std::string f = tmp.file(std::string("v_") + voxelTypeName(t) + ext);
      writeVolume(f, v);
      const RawVolume r = readVolume(f);
      SCOPED_TRACE(f);
      EXPECT_EQ(r.type, v.type);
      expectNearGeometry(r.grid, v.grid);
      EXPECT_EQ(r.bytes, v.bytes);
    }
  }
}

TEST(VtkVolumeIO, RotatedAndFlippedAxesRoundTripThroughNiftiAndVti) {
  TempDir tmp;
  RawVolume v = randomRaw(VoxelType::UInt8, {6, 5, 4}, 42);
  const double c = std::cos(0.3), s = std::sin(0.3);
  // A rotation about z, and a flip of the k axis.
  const Mat3 dirs[] = {{{{c, -s, 0}, {s, c, 0}, {0, 0, 1}}}, {{{1, 0, 0}, {0, 1, 0}, {0, 0, -1}}}};
  for (const Mat3& d : dirs) {
    v.grid.direction = d;
    for (const char* name : {"r.nii.gz", "r.vti"}) {
      const std::string f = tmp.file(name);
      writeVolume(f, v);
      const RawVolume r = readVolume(f);
      SCOPED_TRACE(f);
      expectSamePhysicalVolume(v, r);
      if (det(d) > 0) { // right-handed grids come back exactly as written
        expectNearGeometry(r.grid, v.grid, 1e-4);
        EXPECT_EQ(r.bytes, v.bytes);
      }
    }
  }
  EXPECT_THROW_MSG(writeVolume(tmp.file("r.mha"), v), InputError, "r.mha", ".nrrd");
  EXPECT_FALSE(std::filesystem::exists(tmp.file("r.mha")));
}

TEST(VtkVolumeIO, HandWrittenNiftiInBothByteOrders) {
  TempDir tmp;
  const std::vector<int16_t> vals = {0, 84, 85, 127, 255, -7, 300, 1000, 0, 1, 2, 3};
  for (bool big : {false, true}) {
    const std::string f = tmp.file(big ? "be.nii" : "le.nii");
    writeBytes(f, niftiBytes(big, /*DT_INT16*/ 4, 16, {3, 2, 2}, {0.5f, 0.75f, 2.0f},
                             {10.0f, -20.0f, 30.0f}, int16Bytes(vals)));
    const LabelVolume l = readLabelVolume(f);
    SCOPED_TRACE(f);
    EXPECT_EQ(l.grid.dims, (std::array<int64_t, 3>{3, 2, 2}));
    EXPECT_NEAR(l.grid.spacing[1], 0.75, 1e-7);
    EXPECT_NEAR(l.grid.spacing[2], 2.0, 1e-7);
    // RAS (10,-20,30) in the file is LPS (-10, 20, 30) in TetFlow.
    EXPECT_NEAR(l.grid.origin[0], -10.0, 1e-6);
    EXPECT_NEAR(l.grid.origin[1], 20.0, 1e-6);
    EXPECT_NEAR(l.grid.origin[2], 30.0, 1e-6);
    ASSERT_EQ(l.data.size(), vals.size());
    for (size_t i = 0; i < vals.size(); ++i) EXPECT_EQ(l.data[i], vals[i]);
    // Physical position of voxel (1,0,0) moves along -x in LPS (RAS +x).
    EXPECT_NEAR(l.grid.indexToPhysical(1, 0, 0)[0], -10.5, 1e-6);
  }
}

TEST(VtkVolumeIO, HandWrittenMetaImageInBothByteOrders) {
  TempDir tmp;
  const std::vector<int16_t> vals = {1, -2, 300, 4, 5, 6, 7, 8};
  for (bool msb : {false, true}) {
    std::string data(reinterpret_cast<const char*>(vals.data()), vals.size() * 2);
    if (msb)
      for (size_t i = 0; i < data.size(); i += 2) std::swap(data[i], data[i + 1]);
    const std::string f = tmp.file(msb ? "be.mha" : "le.mha");
    writeBytes(f, std::string("ObjectType = Image\nNDims = 3\nBinaryData = True\n") +
                      "BinaryDataByteOrderMSB = " + (msb ? "True" : "False") +
                      "\nOffset = 1.5 -2 3\nElementSpacing = 0.5 0.25 2\nDimSize = 2 2 2\n"
                      "ElementType = MET_SHORT\nElementDataFile = LOCAL\n" + data);
    const LabelVolume l = readLabelVolume(f);
    SCOPED_TRACE(f);
    EXPECT_EQ(l.grid.dims, (std::array<int64_t, 3>{2, 2, 2}));
    EXPECT_DOUBLE_EQ(l.grid.origin[0], 1.5);
    EXPECT_DOUBLE_EQ(l.grid.origin[1], -2.0);
    EXPECT_DOUBLE_EQ(l.grid.spacing[1], 0.25);
    for (size_t i = 0; i < vals.size(); ++i) EXPECT_EQ(l.data[i], vals[i]);
  }
}

TEST(VtkVolumeIO, MetaImageTransformMatrixGivesAxisDirections) {
  TempDir tmp;
  const std::string f = tmp.file("rot.mha");
  // i axis along +y, j axis along -x, k along +z (columns listed axis by axis).
  writeBytes(f, std::string("ObjectType = Image\nNDims = 3\nTransformMatrix = 0 1 0 -1 0 0 0 0 1\n"
                            "Offset = 0 0 0\nElementSpacing = 1 1 1\nDimSize = 2 1 1\n"
                            "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n") +
                    std::string("\x01\x02", 2));
  const RawVolume r = readVolume(f);
  const Vec3 p = r.grid.indexToPhysical(1, 0, 0);
  EXPECT_NEAR(p[0], 0.0, 1e-12);
  EXPECT_NEAR(p[1], 1.0, 1e-12);
}

TEST(VtkVolumeIO, AsciiVtiIsRead) {
  TempDir tmp;
  const std::string f = tmp.file("a.vti");
  writeBytes(f, R"(<?xml version="1.0"?>
<VTKFile type="ImageData" version="1.0" byte_order="BigEndian" header_type="UInt64">
  <ImageData WholeExtent="0 2 0 1 0 0" Origin="1 2 3" Spacing="0.5 0.5 4" Direction="1 0 0 0 1 0 0 0 1">
    <Piece Extent="0 2 0 1 0 0">
      <PointData Scalars="labels">
        <DataArray type="Int32" Name="labels" format="ascii">0 84 85 127 255 7</DataArray>
      </PointData>
    </Piece>
  </ImageData>
</VTKFile>
)");
  const LabelVolume l = readLabelVolume(f);
  EXPECT_EQ(l.grid.dims, (std::array<int64_t, 3>{3, 2, 1}));
  EXPECT_EQ(l.data, (std::vector<int32_t>{0, 84, 85, 127, 255, 7}));
  EXPECT_DOUBLE_EQ(l.grid.origin[2], 3.0);
  EXPECT_DOUBLE_EQ(l.grid.spacing[2], 4.0);
}

TEST(VtkVolumeIO, BrokenFilesGiveClearErrors) {
  TempDir tmp;
  const std::vector<int16_t> vals(27, 3);
  const std::string good = niftiBytes(false, 4, 16, {3, 3, 3}, {1, 1, 1}, {0, 0, 0}, int16Bytes(vals));

  const std::string trunc = tmp.file("trunc.nii");
  writeBytes(trunc, good.substr(0, good.size() - 10));
  EXPECT_THROW_MSG(readVolume(trunc), InputError, "trunc.nii", "truncated");

  const std::string gzTrunc = tmp.file("trunc.nii.gz");
  const std::string gz = gzipCompress(good.data(), good.size());
  writeBytes(gzTrunc, gz.substr(0, gz.size() / 2));
  EXPECT_THROW(readVolume(gzTrunc), InputError);

  const std::string huge = tmp.file("huge.nii");
  writeBytes(huge, niftiBytes(false, 4, 16, {30000, 30000, 30000}, {1, 1, 1}, {0, 0, 0}, int16Bytes(vals)));
  EXPECT_THROW_MSG(readVolume(huge), InputError, "huge.nii", "header");

  const std::string time = tmp.file("time.nii");
  writeBytes(time, niftiBytes(false, 4, 16, {3, 3, 1}, {1, 1, 1}, {0, 0, 0}, int16Bytes(vals), 4, 3));
  EXPECT_THROW_MSG(readVolume(time), InputError, "time.nii", "3-D");

  const std::string zeroSpacing = tmp.file("zero.nii");
  writeBytes(zeroSpacing, niftiBytes(false, 4, 16, {3, 3, 3}, {1, 0, 1}, {0, 0, 0}, int16Bytes(vals)));
  EXPECT_THROW_MSG(readVolume(zeroSpacing), InputError, "zero.nii", "pixdim[2]");

  const std::string garbage = tmp.file("garbage.nii");
  writeBytes(garbage, std::string(400, 'x'));
  EXPECT_THROW_MSG(readVolume(garbage), InputError, "garbage.nii", "NIfTI");

  const std::string mhaShort = tmp.file("short.mha");
  writeBytes(mhaShort, "ObjectType = Image\nNDims = 3\nDimSize = 10 10 10\nElementType = MET_UCHAR\n"
                       "ElementDataFile = LOCAL\nabc");
  EXPECT_THROW_MSG(readVolume(mhaShort), InputError, "short.mha", "1000", "truncated");

  const std::string mhdMissing = tmp.file("missing.mhd");
  writeBytes(mhdMissing, "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n"
                         "ElementDataFile = nothere.raw\n");
  EXPECT_THROW_MSG(readVolume(mhdMissing), InputError, "missing.mhd", "nothere.raw", "does not exist");

  const std::string mhaVec = tmp.file("vec.mha");
  writeBytes(mhaVec, "ObjectType = Image\nNDims = 3\nDimSize = 1 1 1\nElementNumberOfChannels = 3\n"
                     "ElementType = MET_UCHAR\nElementDataFile = LOCAL\nabc");
  EXPECT_THROW_MSG(readVolume(mhaVec), InputError, "vec.mha", "scalar");

  const std::string vtiBad = tmp.file("bad.vti");
  writeBytes(vtiBad, "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\"><ImageData");
  EXPECT_THROW_MSG(readVolume(vtiBad), InputError, "bad.vti");

  EXPECT_THROW_MSG(readVolume(tmp.file("none.nii.gz")), InputError, "none.nii.gz", "not found");
  EXPECT_THROW_MSG(readVolume(tmp.file("x.png")), InputError, "x.png", "unknown volume format",
                   ".nrrd");
}

// Headers that disagree with their data (issue "reliability", item 7): each a clear error, never
// a crash (a datatype of 999 crashed VTK's reader) or a silent misread.
TEST(VtkVolumeIO, HeadersThatDisagreeWithTheirDataAreRefused) {
  TempDir tmp;
  const std::vector<int16_t> vals(27, 3);
  const std::string good = niftiBytes(false, 4, 16, {3, 3, 3}, {1, 1, 1}, {0, 0, 0}, int16Bytes(vals));
  auto patched = [&](const std::string& name, size_t at, const void* v, size_t n, const std::string& tail = "") {
    std::string b = good;
    std::memcpy(b.data() + at, v, n);
    writeBytes(tmp.file(name), b + tail);
    return tmp.file(name);
  };
  const int16_t dt999 = 999, rgb = 128, bitpix8 = 8;
  const float vox0 = 0.0f;
  EXPECT_THROW_MSG(readVolume(patched("dt.nii", 70, &dt999, 2)), InputError, "dt.nii", "datatype = 999", "byte 70");
  EXPECT_THROW_MSG(readVolume(patched("rgb.nii", 70, &rgb, 2)), InputError, "rgb.nii", "datatype = 128");
  EXPECT_THROW_MSG(readVolume(patched("bits.nii", 72, &bitpix8, 2)), InputError, "bits.nii", "bitpix = 8",
                   "datatype 4");
  EXPECT_THROW_MSG(readVolume(patched("vox0.nii", 108, &vox0, 4)), InputError, "vox0.nii", "vox_offset = 0",
                   "348");
  EXPECT_THROW_MSG(readVolume(patched("pair.nii", 344, "ni1", 4)), InputError, "pair.nii", "two-file");
  EXPECT_THROW_MSG(readVolume(patched("long.nii", 0, "\x5c\x01\0\0", 4, "extra")), InputError, "long.nii",
                   "406 bytes in all", "411 bytes");
  const std::string gz = tmp.file("ok.nii.gz");
  writeBytes(gz, gzipCompress(good.data(), good.size()));
  EXPECT_EQ(readVolume(gz).grid.voxelCount(), 27);

  const std::string head = "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n";
  auto mha = [&](const std::string& name, const std::string& extra, const std::string& data) {
    writeBytes(tmp.file(name), head + extra + "ElementDataFile = LOCAL\n" + data);
    return tmp.file(name);
  };
  EXPECT_EQ(readVolume(mha("ok.mha", "ElementSpacing = 1 2 3\n", "abcdefgh")).grid.spacing, (Vec3{1, 2, 3}));
  EXPECT_THROW_MSG(readVolume(mha("z.mha", "CompressedData = True\n", "abcdefgh")), InputError, "z.mha",
                   "CompressedData = True", "zlib");
  EXPECT_THROW_MSG(readVolume(mha("neg.mha", "ElementSpacing = 1 -2 1\n", "abcdefgh")), InputError, "neg.mha:5",
                   "ElementSpacing has -2", "positive");
  EXPECT_THROW_MSG(readVolume(mha("cnt.mha", "ElementSpacing = 1 1\n", "abcdefgh")), InputError, "cnt.mha:5",
                   "2 values", "DimSize has 3");
  EXPECT_THROW_MSG(readVolume(mha("long.mha", "", "abcdefghij")), InputError, "long.mha", "10 bytes",
                   "DimSize or ElementType is wrong");
  writeBytes(tmp.file("nd.mha"), "ObjectType = Image\nNDims = 2\nDimSize = 2 2 2\nElementType = MET_UCHAR\n"
                                 "ElementDataFile = LOCAL\nabcdefgh");
  EXPECT_THROW_MSG(readVolume(tmp.file("nd.mha")), InputError, "nd.mha:2", "NDims = 2", "3 values");
}

TEST(VtkVolumeIO, FloatVolumeWithNaNIsRefusedAsScalarAndNonIntegerAsLabel) {
  TempDir tmp;
  RawVolume v = randomRaw(VoxelType::Float32, {3, 3, 3}, 5);
  for (int64_t i = 0; i < 27; ++i) {
    const float whole = static_cast<float>(i % 5);
    std::memcpy(v.bytes.data() + i * 4, &whole, 4);
  }
  float half = 0.5f;
  std::memcpy(v.bytes.data() + 4 * 4, &half, 4);
  const std::string f = tmp.file("half.mha");
  writeVolume(f, v);
  EXPECT_THROW_MSG(readLabelVolume(f), InputError, "half.mha", "(1, 1, 0)", "not a label");
  float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(v.bytes.data() + 5 * 4, &nan, 4);
  writeVolume(f, v);
  EXPECT_THROW_MSG(readScalarVolume(f), InputError, "half.mha", "(2, 1, 0)", "NaN");
}

TEST(VtkVolumeIO, UnwritableTargetLeavesNothing) {
  TempDir tmp;
  const RawVolume v = randomRaw(VoxelType::UInt8, {2, 2, 2}, 3);
  EXPECT_THROW_MSG(writeVolume(tmp.file("nofolder/x.nii.gz"), v), InputError, "does not exist");
  // An existing target stays untouched when the write is refused.
  const std::string f = tmp.file("keep.mha");
  writeBytes(f, "original");
  RawVolume rotated = v;
  rotated.grid.direction = {{{0, 1, 0}, {1, 0, 0}, {0, 0, -1}}};
  EXPECT_THROW(writeVolume(f, rotated), InputError);
  EXPECT_EQ(std::string(readFileBytes(f).data(), 8), "original");
  size_t files = 0;
  for (auto& e : std::filesystem::directory_iterator(tmp.path())) { (void)e; ++files; }
  EXPECT_EQ(files, 1u); // no temp files left
}

// Found by fuzzing (Testing/Fuzz/corpus/*/finding-*): a MetaImage whose ElementDataFile is a
// numbered pattern reached vsnprintf inside VTK's MetaIO with a damaged header as the format (a
// crash), and a VTI with an inverted extent gave a negative voxel count ("internal error").
TEST(VtkVolumeIO, MultiFileMetaImageAndInvertedVtiExtentsAreRefused) {
  TempDir dir;
  const std::string head = "ObjectType = Image\nNDims = 3\nBinaryData = True\nDimSize = 2 2 2\nElementType = MET_UCHAR\n";
  writeBytes(dir.file("p.mha"), head + "ElementDataFile = slice%03d.raw 1 2 1\n");
  EXPECT_THROW_MSG(readVolume(dir.file("p.mha")), InputError, "p.mha", "multi-file layout", "one .mha");
  writeBytes(dir.file("l.mha"), head + "ElementDataFile = LIST\na.raw\nb.raw\n");
  EXPECT_THROW_MSG(readVolume(dir.file("l.mha")), InputError, "l.mha", "multi-file layout");
  writeBytes(dir.file("c.mha"), head + "ElementDataFile = LOCAL\x01\x02\n" + std::string(8, '\1'));
  EXPECT_THROW_MSG(readVolume(dir.file("c.mha")), InputError, "c.mha", "control characters");
  writeBytes(dir.file("i.vti"), "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
                                "<ImageData WholeExtent=\"5 2 0 1 0 1\" Origin=\"0 0 0\" Spacing=\"1 1 1\">\n"
                                "<Piece Extent=\"0 2 0 1 0 1\"><PointData Scalars=\"l\"><DataArray type=\"UInt8\" Name=\"l\" "
                                "format=\"ascii\">0 1 2 2 1 0 3 3 3 0 0 1</DataArray></PointData></Piece>\n"
                                "</ImageData>\n</VTKFile>\n");
  EXPECT_THROW_MSG(readVolume(dir.file("i.vti")), InputError, "i.vti", "empty or inverted");
}
