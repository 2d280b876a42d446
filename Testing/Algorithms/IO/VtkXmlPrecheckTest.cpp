// Tests for Algorithms/IO/VtkXmlPrecheck: VTK XML files of every layout VTK writes (appended raw,
// appended base64, inline base64; compressed or not; UInt32 or UInt64 headers; either byte order)
// pass it and read back, and damaged headers, block sizes and counts are refused by name before VTK
// allocates anything (VTK 9.1 asked for a 250 TB new[] on one of them, which aborts under ASan).
#include "Algorithms/IO/VtkXmlPrecheck.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>

#include <vtkCellType.h>
#include <vtkIntArray.h>
#include <vtkCellData.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/IO/MeshIO.h"
#include "Algorithms/IO/VtkVolumeIO.h"
#include "TestUtil.h"

namespace tetflow {
namespace {

using test::TempDir;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A 4x4x4 grid of points split into tets (5 per cube is enough to be a valid mesh for VTK), with
// the material array TetFlow reads.
vtkNew<vtkUnstructuredGrid> smallGrid() {
  vtkNew<vtkUnstructuredGrid> g;
  vtkNew<vtkPoints> pts;
  const int n = 4;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) pts->InsertNextPoint(i, j, k);
  g->SetPoints(pts);
  auto id = [&](int i, int j, int k) { return vtkIdType(i + n * (j + n * k)); };
  vtkNew<vtkIntArray> mat;
  mat->SetName("material");
  for (int k = 0; k + 1 < n; ++k)
    for (int j = 0; j + 1 < n; ++j)
      for (int i = 0; i + 1 < n; ++i) {
        // One tet per cube corner 0: (0,0,0),(1,0,0),(0,1,0),(0,0,1) -- positively oriented.
        const vtkIdType q[4] = {id(i, j, k), id(i + 1, j, k), id(i, j + 1, k), id(i, j, k + 1)};
        g->InsertNextCell(VTK_TETRA, 4, q);
        mat->InsertNextValue(1 + (i + j + k) % 3);
      }
  g->GetCellData()->AddArray(mat);
  return g;
}

struct Layout {
  const char* name;
  int mode; // 0 appended raw, 1 appended base64, 2 inline base64
  bool compressed;
  bool header64;
  bool bigEndian;
};

const Layout kLayouts[] = {
    {"appended raw zlib UInt64", 0, true, true, false},
    {"appended raw zlib UInt32 big-endian", 0, true, false, true},
    {"appended raw uncompressed UInt64", 0, false, true, false},
    {"appended base64 zlib UInt32", 1, true, false, false},
    {"appended base64 uncompressed UInt64", 1, false, true, false},
    {"inline base64 zlib UInt64", 2, true, true, false},
    {"inline base64 uncompressed UInt32 big-endian", 2, false, false, true},
};

void writeLayout(const std::string& path, const Layout& l) {
  vtkNew<vtkXMLUnstructuredGridWriter> w;
  auto g = smallGrid();
  w->SetInputData(g);
  w->SetFileName(path.c_str());
  if (l.mode == 2) {
    w->SetDataModeToBinary();
  } else {
    w->SetDataModeToAppended();
    w->SetEncodeAppendedData(l.mode == 1);
  }
  if (l.compressed)
    w->SetCompressorTypeToZLib();
  else
    w->SetCompressorTypeToNone();
  if (l.header64)
    w->SetHeaderTypeToUInt64();
  else
    w->SetHeaderTypeToUInt32();
  if (l.bigEndian)
    w->SetByteOrderToBigEndian();
  else
    w->SetByteOrderToLittleEndian();
  ASSERT_EQ(w->Write(), 1) << l.name;
}

// Offset of the first array's data (its header) in the file.
size_t firstArrayData(const std::string& s, const Layout& l) {
  if (l.mode == 2) {
    size_t p = s.find("format=\"binary\"");
    p = s.find('>', p) + 1;
    while (std::isspace(static_cast<unsigned char>(s[p]))) ++p;
    return p;
  }
  const size_t tag = s.find("<AppendedData");
  const size_t us = s.find('_', tag) + 1;
  // The first appended array is the one with offset="0".
  return us;
}

std::string base64(const std::string& raw) {
  static const char* a = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < raw.size(); i += 3) {
    uint32_t v = 0;
    const size_t n = std::min<size_t>(3, raw.size() - i);
    for (size_t k = 0; k < 3; ++k) v = (v << 8) | (k < n ? static_cast<unsigned char>(raw[i + k]) : 0u);
    for (size_t k = 0; k < 4; ++k) out.push_back(k <= n ? a[(v >> (18 - 6 * k)) & 63] : '=');
  }
  return out;
}

// Header words as the file stores them.
std::string words(const std::vector<uint64_t>& w, const Layout& l) {
  const size_t size = l.header64 ? 8 : 4;
  std::string out;
  for (uint64_t x : w)
    for (size_t b = 0; b < size; ++b) {
      const size_t shift = l.bigEndian ? 8 * (size - 1 - b) : 8 * b;
      out.push_back(static_cast<char>((x >> shift) & 0xff));
    }
  return out;
}

// Replaces the first array's header by `header` (re-encoded for base64 layouts; the base64 text
// is padded or cut to the old length so the rest of the file stays where it was).
std::string withHeader(const std::string& file, const Layout& l, const std::vector<uint64_t>& header) {
  std::string s = file;
  const size_t at = firstArrayData(s, l);
  const std::string raw = words(header, l);
  if (l.mode == 0) {
    s.replace(at, raw.size(), raw);
  } else {
    std::string enc = base64(raw);
    while (!enc.empty() && enc.back() == '=') enc.pop_back();
    enc.resize(enc.size() - enc.size() % 4); // whole groups only
    s.replace(at, enc.size(), enc);
  }
  return s;
}

TEST(VtkXmlPrecheck, EveryLayoutVtkWritesPassesAndReadsBack) {
  TempDir dir;
  for (const Layout& l : kLayouts) {
    const std::string p = dir.file(std::string("ok-") + std::to_string(&l - kLayouts) + ".vtu");
    writeLayout(p, l);
    EXPECT_NO_THROW(precheckVtkXml(p)) << l.name;
    const TetMesh m = readMesh(p);
    EXPECT_EQ(m.numTets(), 27u) << l.name;
    EXPECT_EQ(m.numPoints(), 64u) << l.name;
  }
  // TetFlow's own writers (.vtu mesh, .vti volume).
  TetMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.tets = {{0, 1, 2, 3}};
  m.materials = {4};
  writeMesh(dir.file("own.vtu"), m);
  EXPECT_NO_THROW(precheckVtkXml(dir.file("own.vtu")));
}

TEST(VtkXmlPrecheck, AbsurdBlockSizesAndCountsAreRefusedByName) {
  TempDir dir;
  for (const Layout& l : kLayouts) {
    const std::string good = dir.file("good.vtu");
    writeLayout(good, l);
    const std::string src = slurp(good);
    const std::string p = dir.file("bad.vtu");
    auto expectRefused = [&](const std::string& bytes, const std::string& words, const char* what) {
      test::writeBytes(p, bytes);
      try {
        precheckVtkXml(p);
        ADD_FAILURE() << l.name << ": " << what << " was accepted";
      } catch (const InputError& e) {
        const std::string msg = e.what();
        EXPECT_NE(msg.find(p), std::string::npos) << msg;
        EXPECT_NE(msg.find("Name=\"material\""), std::string::npos) << l.name << ": " << msg;
        EXPECT_NE(msg.find(words), std::string::npos) << l.name << ": " << msg;
      }
      // And through the reader: the same refusal, never an allocation.
      EXPECT_THROW(readMesh(p), InputError) << l.name << ": " << what;
    };
    const uint64_t huge = l.header64 ? 0xe6e6e6e6e6e6e6e6ull : 0xe6e6e6e6ull;
    if (l.compressed) {
      // One block: [blocks, block size, last size, compressed size].
      expectRefused(withHeader(src, l, {1, 32768, 108, huge}), "compressed block 0", "a huge compressed block");
      expectRefused(withHeader(src, l, {huge}), "compressed blocks", "a huge block count");
      expectRefused(withHeader(src, l, {1, huge, 108, 20}), "uncompressed bytes", "a huge block size");
      expectRefused(withHeader(src, l, {1, 100, 200, 20}), "larger than its block size", "a last block past its size");
    } else {
      expectRefused(withHeader(src, l, {huge}), "bytes of data", "a huge array size");
    }
  }
}

TEST(VtkXmlPrecheck, PieceCountsBeyondTheFileAreRefused) {
  TempDir dir;
  const std::string good = dir.file("good.vtu");
  writeLayout(good, kLayouts[0]);
  const std::string src = slurp(good);
  const std::string p = dir.file("bad.vtu");
  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string s = src;
    const size_t at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) s.replace(at, from.size(), to);
    return s;
  };
  test::writeBytes(p, replaced("NumberOfPoints=\"64\"", "NumberOfPoints=\"999999999999999\""));
  EXPECT_THROW_MSG(precheckVtkXml(p), InputError, "bad.vtu", "NumberOfPoints");
  EXPECT_THROW(readMesh(p), InputError);
  test::writeBytes(p, replaced("NumberOfCells=\"27\"", "NumberOfCells=\"-5\""));
  EXPECT_THROW_MSG(precheckVtkXml(p), InputError, "bad.vtu", "negative NumberOfCells");
  EXPECT_THROW(readMesh(p), InputError);
  test::writeBytes(p, replaced("offset=\"0\"", "offset=\"99999999\""));
  EXPECT_THROW_MSG(precheckVtkXml(p), InputError, "bad.vtu", "past the end of the appended data");
  EXPECT_THROW(readMesh(p), InputError);
}

TEST(VtkXmlPrecheck, ImageDataExtentsAndBlocksAreChecked) {
  TempDir dir;
  RawVolume v;
  v.grid.dims = {6, 5, 4};
  v.grid.spacing = {1, 1, 1};
  v.type = VoxelType::UInt8;
  v.bytes.assign(6 * 5 * 4, 3);
  const std::string good = dir.file("v.vti");
  writeVti(good, v);
  EXPECT_NO_THROW(precheckVtkXml(good));
  std::string s = slurp(good);
  const size_t at = s.find("WholeExtent=\"");
  ASSERT_NE(at, std::string::npos);
  const size_t end = s.find('"', at + 13);
  std::string bad = s;
  bad.replace(at, end - at + 1, "WholeExtent=\"0 2000000 0 2000000 0 2000000\"");
  test::writeBytes(dir.file("w.vti"), bad);
  EXPECT_THROW_MSG(precheckVtkXml(dir.file("w.vti")), InputError, "w.vti", "WholeExtent");
  EXPECT_THROW(readVti(dir.file("w.vti")), InputError);
}

} // namespace
} // namespace tetflow
