// Tests for Algorithms/IO/MeshIO: round trips (.vtu, .vtk, TetGen), the Gmsh 4.1 writer checked by
// an independent parser (GmshIOTest.cpp tests reading MSH and the 2.2 writer), the .vtu writer against VTK's reader and writer, and broken /
// unwritable inputs.
#include "Algorithms/IO/MeshIO.h"
#include "Algorithms/IO/VtkCancellableWriters.h"
#include "Algorithms/IO/VtuWriter.h"

#include "Algorithms/Core/Progress.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <sys/resource.h>

#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCellType.h>
#include <vtkDoubleArray.h>
#include <vtkFloatArray.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkSmartPointer.h>
#include <vtkTypeInt32Array.h>
#include <vtkTypeInt64Array.h>
#include <vtkUnstructuredGrid.h>
#include <vtkUnstructuredGridWriter.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include "Algorithms/Core/Errors.h"
#include "Fixtures/MeshChecks.h"
#include "TestUtil.h"

namespace tetflow {
namespace {

using test::TempDir;
namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Mesh builders
// ---------------------------------------------------------------------------------------------

using test::orientPositive;

// Grid of nx*ny*nz cubes of edge h at `origin`, each split into the 6 Kuhn tets around its main
// diagonal (a conforming tetrahedralisation). Interior vertices are moved by up to
// `perturb`*h per axis. Tets are then made positively oriented.
TetMesh kuhnGrid(int nx, int ny, int nz, double h, Vec3 origin, double perturb, unsigned seed) {
  TetMesh m;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-perturb * h, perturb * h);
  auto vid = [&](int i, int j, int k) { return i + (nx + 1) * (j + (ny + 1) * k); };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        Vec3 p = origin + Vec3{i * h, j * h, k * h};
        const bool interior = i > 0 && i < nx && j > 0 && j < ny && k > 0 && k < nz;
        if (interior && perturb > 0)
          for (double& c : p) c += u(rng);
        m.points.push_back(p);
      }
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        for (const auto& perm : perms) {
          int c[3] = {i, j, k};
          TetMesh::Tet t{};
          t[0] = vid(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[perm[s]];
            t[s + 1] = vid(c[0], c[1], c[2]);
          }
          m.tets.push_back(t);
        }
  orientPositive(m);
  m.materials.assign(m.numTets(), 0);
  return m;
}

void addFields(TetMesh& m, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1e6, 1e6);
  Field temperature{1, {}}, displacement{3, {}}, quality{1, {}}, direction{3, {}};
  for (const Vec3& p : m.points) {
    temperature.values.push_back(p[0] + 2 * p[1] + 3 * p[2]);
    for (int a = 0; a < 3; ++a) displacement.values.push_back(u(rng) * 1e-9);
  }
  for (size_t t = 0; t < m.numTets(); ++t) {
    quality.values.push_back(m.tetVolume(t));
    for (int a = 0; a < 3; ++a) direction.values.push_back(u(rng));
  }
  m.pointFields["temperature"] = temperature;
  m.pointFields["displacement"] = displacement;
  m.cellFields["quality"] = quality;
  m.cellFields["direction"] = direction;
}

// Unit cube, 6 tets, two materials, point and cell fields (scalar and 3-component).
TetMesh cubeMesh() {
  TetMesh m = kuhnGrid(1, 1, 1, 1.0, {0, 0, 0}, 0.0, 1);
  m.materials = {1, 1, 1, 7, 7, 7};
  addFields(m, 2);
  return m;
}

// Perturbed 3x3x2 grid far from the origin, labels including 0 and a negative one.
TetMesh randomMesh(unsigned seed) {
  TetMesh m = kuhnGrid(3, 3, 2, 0.37, {1000.5, -20.25, 3e-3}, 0.2, seed);
  std::mt19937 rng(seed + 100);
  const int32_t labels[] = {-2, 0, 3, 5};
  for (auto& l : m.materials) l = labels[rng() % 4];
  addFields(m, seed + 200);
  return m;
}

// ---------------------------------------------------------------------------------------------
// Comparison helpers
// ---------------------------------------------------------------------------------------------

bool closeRel(double a, double b) { return std::abs(a - b) <= 1e-12 * std::abs(a); }

void expectSameGeometry(const TetMesh& want, const TetMesh& got) {
  ASSERT_EQ(got.numPoints(), want.numPoints());
  for (size_t i = 0; i < want.numPoints(); ++i)
    for (int a = 0; a < 3; ++a)
      EXPECT_TRUE(closeRel(want.points[i][a], got.points[i][a]))
          << "point " << i << " axis " << a << ": " << want.points[i][a] << " vs "
          << got.points[i][a];
  ASSERT_EQ(got.numTets(), want.numTets());
  for (size_t t = 0; t < want.numTets(); ++t) {
    EXPECT_EQ(got.tets[t], want.tets[t]) << "tet " << t;
    EXPECT_GT(got.tetVolume(t), 0.0) << "tet " << t;
  }
  EXPECT_EQ(got.materials, want.materials);
}

void expectSameFields(const std::map<std::string, Field>& want,
                      const std::map<std::string, Field>& got) {
  ASSERT_EQ(got.size(), want.size());
  for (const auto& [name, f] : want) {
    auto it = got.find(name);
    ASSERT_NE(it, got.end()) << "missing field " << name;
    EXPECT_EQ(it->second.components, f.components) << name;
    ASSERT_EQ(it->second.values.size(), f.values.size()) << name;
    for (size_t i = 0; i < f.values.size(); ++i)
      EXPECT_TRUE(closeRel(f.values[i], it->second.values[i])) << name << "[" << i << "]";
  }
}

std::vector<std::string> dirEntries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

using tetflow::test::readText;

// ---------------------------------------------------------------------------------------------
// Format selection
// ---------------------------------------------------------------------------------------------

TEST(MeshIOFormat, FromPathAndNames) {
  EXPECT_EQ(meshFormatFromPath("a/b.vtu"), MeshFormat::Vtu);
  EXPECT_EQ(meshFormatFromPath("B.VTU"), MeshFormat::Vtu);
  EXPECT_EQ(meshFormatFromPath("x.vtk"), MeshFormat::VtkLegacy);
  EXPECT_EQ(meshFormatFromPath("x.msh"), MeshFormat::Gmsh41);
  EXPECT_EQ(meshFormatFromPath("x.node"), MeshFormat::TetGen);
  EXPECT_EQ(meshFormatFromPath("x.1.ele"), MeshFormat::TetGen);
  EXPECT_STREQ(meshFormatName(MeshFormat::Vtu), "vtu");
  EXPECT_STREQ(meshFormatName(MeshFormat::VtkLegacy), "vtk");
  EXPECT_STREQ(meshFormatName(MeshFormat::Gmsh41), "msh");
  EXPECT_STREQ(meshFormatName(MeshFormat::TetGen), "tetgen");
  EXPECT_STREQ(meshFormatName(MeshFormat::Gmsh22), "msh22");
  EXPECT_STREQ(meshFormatName(MeshFormat::Gmsh22Binary), "msh22_binary");
  EXPECT_THROW_MSG(meshFormatFromPath("dir/mesh.stl"), InputError, "dir/mesh.stl", ".stl",
                   ".vtu", ".vtk", ".msh", ".node", ".ele");
  EXPECT_THROW_MSG(meshFormatFromPath("mesh"), InputError, "mesh", "extension", ".vtu");
  TempDir dir;
  EXPECT_THROW_MSG(writeMesh(dir.file("m.ply"), cubeMesh()), InputError, "m.ply", ".vtu");
  EXPECT_TRUE(dirEntries(dir.path()).empty());
}

// ---------------------------------------------------------------------------------------------
// Round trips
// ---------------------------------------------------------------------------------------------

class MeshIORoundTrip : public ::testing::TestWithParam<std::string> {
protected:
  bool storesFields() const { return GetParam() == ".vtu" || GetParam() == ".vtk"; }
  // TetGen: write under one name, read back under the other.
  std::string readName(const std::string& written) const {
    if (GetParam() == ".node") return written.substr(0, written.size() - 5) + ".ele";
    if (GetParam() == ".ele") return written.substr(0, written.size() - 4) + ".node";
    return written;
  }
  void roundTrip(const TetMesh& mesh) {
    TempDir dir;
    const std::string path = dir.file("mesh" + GetParam());
    writeMesh(path, mesh);
    const TetMesh back = readMesh(readName(path));
    expectSameGeometry(mesh, back);
    if (storesFields()) {
      expectSameFields(mesh.pointFields, back.pointFields);
      expectSameFields(mesh.cellFields, back.cellFields);
    } else {
      EXPECT_TRUE(back.pointFields.empty());
      EXPECT_TRUE(back.cellFields.empty());
    }
    // Only the final files remain: no temporaries.
    std::vector<std::string> want = {"mesh" + GetParam()};
    if (!storesFields()) want = {"mesh.ele", "mesh.node"};
    EXPECT_EQ(dirEntries(dir.path()), want);
  }
};

TEST_P(MeshIORoundTrip, Cube) { roundTrip(cubeMesh()); }

TEST_P(MeshIORoundTrip, PerturbedGrids) {
  for (unsigned seed : {11u, 12u, 13u}) {
    SCOPED_TRACE(seed);
    roundTrip(randomMesh(seed));
  }
}

TEST_P(MeshIORoundTrip, ExtremeValues) {
  TetMesh m = cubeMesh();
  m.points[7] = {1e300, -1e-300, 0.1};
  m.points[3] = {-0.0, 123456789.123456789, -7.0e-17};
  m.materials = {std::numeric_limits<int32_t>::min(), -1, 0, 1, 65535,
                 std::numeric_limits<int32_t>::max()};
  m.cellFields["quality"].values[0] = 5e-324;
  m.cellFields["quality"].values[1] = -1.7976931348623157e308;
  // Orientation of the moved tets is irrelevant to the file round trip; keep it positive anyway.
  orientPositive(m);
  roundTrip(m);
}

TEST_P(MeshIORoundTrip, EmptyMesh) { roundTrip(TetMesh{}); }

TEST_P(MeshIORoundTrip, OverwritesExistingFile) {
  TempDir dir;
  const std::string path = dir.file("mesh" + GetParam());
  writeMesh(path, randomMesh(5));
  const TetMesh cube = cubeMesh();
  writeMesh(path, cube);
  expectSameGeometry(cube, readMesh(readName(path)));
}

INSTANTIATE_TEST_SUITE_P(MeshIO, MeshIORoundTrip,
                         ::testing::Values(".vtu", ".vtk", ".node", ".ele"),
                         [](const auto& info) { return info.param.substr(1); });

TEST(MeshIOVtk, ExplicitFormatOverridesExtension) {
  TempDir dir;
  const TetMesh m = cubeMesh();
  writeMesh(dir.file("mesh.dat"), m, MeshFormat::Vtu);
  expectSameGeometry(m, readMesh(dir.file("mesh.dat"), MeshFormat::Vtu));
  writeMesh(dir.file("legacy.dat"), m, MeshFormat::VtkLegacy);
  expectSameGeometry(m, readMesh(dir.file("legacy.dat"), MeshFormat::VtkLegacy));
  writeMesh(dir.file("tg"), m, MeshFormat::TetGen);
  EXPECT_TRUE(fs::exists(dir.file("tg.node")));
  EXPECT_TRUE(fs::exists(dir.file("tg.ele")));
  expectSameGeometry(m, readMesh(dir.file("tg"), MeshFormat::TetGen));
}

// ---------------------------------------------------------------------------------------------
// VTK specifics and broken VTK files
// ---------------------------------------------------------------------------------------------

// A grid with a tetrahedron (cell 0) and a hexahedron (cell 1).
vtkSmartPointer<vtkUnstructuredGrid> tetAndHexGrid() {
  auto g = vtkSmartPointer<vtkUnstructuredGrid>::New();
  vtkNew<vtkPoints> pts;
  const double p[12][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {2, 0, 0}, {3, 0, 0},
                           {3, 1, 0}, {2, 1, 0}, {2, 0, 1}, {3, 0, 1}, {3, 1, 1}, {2, 1, 1}};
  for (const auto& q : p) pts->InsertNextPoint(q);
  g->SetPoints(pts);
  g->Allocate(2);
  const vtkIdType tet[4] = {0, 1, 2, 3};
  const vtkIdType hex[8] = {4, 5, 6, 7, 8, 9, 10, 11};
  g->InsertNextCell(VTK_TETRA, 4, tet);
  g->InsertNextCell(VTK_HEXAHEDRON, 8, hex);
  return g;
}

TEST(MeshIOVtk, HexahedronCellRefused) {
  TempDir dir;
  auto grid = tetAndHexGrid();
  {
    vtkNew<vtkXMLUnstructuredGridWriter> w;
    w->SetFileName(dir.file("hex.vtu").c_str());
    w->SetInputData(grid);
    ASSERT_EQ(w->Write(), 1);
  }
  {
    vtkNew<vtkUnstructuredGridWriter> w;
    w->SetFileName(dir.file("hex.vtk").c_str());
    w->SetInputData(grid);
    ASSERT_EQ(w->Write(), 1);
  }
  for (const char* name : {"hex.vtu", "hex.vtk"}) {
    SCOPED_TRACE(name);
    const std::string path = dir.file(name);
    EXPECT_THROW_MSG(readMesh(path), InputError, path.c_str(), "cell 1", "Hexahedron", "12");
  }
}

TEST(MeshIOVtk, MissingMaterialIsZeroAndArraysBecomeDoubleFields) {
  TempDir dir;
  vtkNew<vtkUnstructuredGrid> g;
  vtkNew<vtkPoints> pts;
  pts->SetDataTypeToFloat();
  // Deliberately stored with negative orientation: the reader must hand out a positive tet.
  const double p[4][3] = {{0, 0, 0}, {0, 1, 0}, {1, 0, 0}, {0, 0, 1}};
  for (const auto& q : p) pts->InsertNextPoint(q);
  g->SetPoints(pts);
  const vtkIdType tet[4] = {0, 1, 2, 3};
  g->Allocate(1);
  g->InsertNextCell(VTK_TETRA, 4, tet);
  vtkNew<vtkFloatArray> f;
  f->SetName("speed");
  f->SetNumberOfComponents(2);
  for (int i = 0; i < 4; ++i) f->InsertNextTuple2(i * 0.5, -i);
  g->GetPointData()->AddArray(f);
  vtkNew<vtkXMLUnstructuredGridWriter> w;
  w->SetFileName(dir.file("plain.vtu").c_str());
  w->SetInputData(g);
  ASSERT_EQ(w->Write(), 1);

  const TetMesh m = readMesh(dir.file("plain.vtu"));
  ASSERT_EQ(m.numPoints(), 4u);
  ASSERT_EQ(m.numTets(), 1u);
  EXPECT_EQ(m.materials, std::vector<int32_t>{0});
  EXPECT_GT(m.tetVolume(0), 0.0);
  EXPECT_EQ((TetMesh::Tet{1, 0, 2, 3}), m.tets[0]);
  ASSERT_EQ(m.pointFields.count("speed"), 1u);
  EXPECT_EQ(m.pointFields.at("speed").components, 2);
  EXPECT_EQ(m.pointFields.at("speed").values,
            (std::vector<double>{0, 0, 0.5, -1, 1, -2, 1.5, -3}));
  EXPECT_TRUE(m.cellFields.empty());
}

TEST(MeshIOVtk, MissingFiles) {
  TempDir dir;
  for (const char* name : {"none.vtu", "none.vtk", "none.node", "none.ele"}) {
    SCOPED_TRACE(name);
    EXPECT_THROW_MSG(readMesh(dir.file(name)), InputError, "none.", "not found");
  }
}

TEST(MeshIOVtk, GarbageFiles) {
  TempDir dir;
  std::mt19937 rng(99);
  std::string noise(4096, '\0');
  for (char& c : noise) c = static_cast<char>(rng() & 0xff);
  const std::string texts[] = {
      "",
      "this is not a mesh\n",
      noise,
      "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\">\n<Unstruct",
      "<VTKFile type=\"PolyData\" version=\"0.1\"><PolyData><Piece NumberOfPoints=\"0\" "
      "NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">"
      "</Piece></PolyData></VTKFile>\n",
      "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\"><UnstructuredGrid><Piece "
      "NumberOfPoints=\"4\" NumberOfCells=\"1\"></Piece></UnstructuredGrid></VTKFile>\n",
      "# vtk DataFile Version 4.2\nx\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 99999 double\n",
      "# vtk DataFile Version 4.2\nx\nASCII\nDATASET POLYDATA\nPOINTS 1 float\n0 0 0\n",
      "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n"
      "0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 7\nCELL_TYPES 1\n10\n",
  };
  int k = 0;
  for (const std::string& text : texts) {
    for (const char* ext : {".vtu", ".vtk"}) {
      const std::string path = dir.file("garbage" + std::to_string(k) + ext);
      SCOPED_TRACE(path);
      test::writeBytes(path, text);
      EXPECT_THROW_MSG(readMesh(path), InputError, path.c_str());
    }
    ++k;
  }
}

// Cut a valid file at many places inside its data: every prefix must be an InputError.
void expectTruncationsRefused(const std::string& full, size_t dataEnd, const std::string& path) {
  ASSERT_GT(dataEnd, 0u);
  std::vector<size_t> cuts = {0, 1, 10, dataEnd - 1, dataEnd - 3};
  for (size_t c = 17; c < dataEnd; c += std::max<size_t>(1, dataEnd / 60)) cuts.push_back(c);
  for (size_t c : cuts) {
    SCOPED_TRACE("cut at " + std::to_string(c) + " of " + std::to_string(full.size()));
    test::writeBytes(path, full.substr(0, c));
    EXPECT_THROW_MSG(readMesh(path), InputError, path.c_str());
  }
}

TEST(MeshIOVtk, TruncatedVtu) {
  TempDir dir;
  const std::string good = dir.file("good.vtu");
  writeMesh(good, randomMesh(21));
  const std::string full = readText(good);
  // Appended data ends right before "</AppendedData>"; XML after it carries no data.
  const size_t dataEnd = full.rfind("</AppendedData>");
  ASSERT_NE(dataEnd, std::string::npos);
  expectTruncationsRefused(full, dataEnd - 3, dir.file("cut.vtu"));
}

TEST(MeshIOVtk, TruncatedVtk) {
  TempDir dir;
  const std::string good = dir.file("good.vtk");
  writeMesh(good, randomMesh(22));
  const std::string full = readText(good);
  expectTruncationsRefused(full, full.size() - 2, dir.file("cut.vtk"));
}

// Damaged sizes that made VTK 9.1 crash or throw inside its readers must become InputError.
TEST(MeshIOVtk, CorruptedLegacyCellBlock) {
  TempDir dir;
  writeMesh(dir.file("good.vtk"), cubeMesh());
  const std::string full = readText(dir.file("good.vtk"));
  const size_t line = full.find("\nCELLS ");
  ASSERT_NE(line, std::string::npos);
  const size_t data = full.find('\n', line + 1) + 1;
  // 4.2 layout "npts id id id id": a huge npts made vtkCellArray::AppendLegacyFormat segfault.
  std::string bad = full;
  bad[data] = '\x7f';
  const std::string path = dir.file("bad.vtk");
  test::writeBytes(path, bad);
  EXPECT_THROW_MSG(readMesh(path), InputError, path.c_str(), "CELLS", "cell 0");
  // Fewer cell types than cells made VTK read past its type buffer.
  std::string fewer = full;
  const size_t types = fewer.find("\nCELL_TYPES 6\n");
  ASSERT_NE(types, std::string::npos);
  fewer.replace(types, 14, "\nCELL_TYPES 2\n");
  test::writeBytes(path, fewer);
  EXPECT_THROW_MSG(readMesh(path), InputError, path.c_str(), "CELL_TYPES");
  // A second CELLS section whose block is cut short made AppendLegacyFormat segfault (found by
  // fuzzing; Testing/Fuzz/corpus/vtk/finding-crash-second-cells).
  std::string twice = full;
  const size_t typesAt = twice.find("\nCELL_TYPES ");
  ASSERT_NE(typesAt, std::string::npos);
  twice.insert(typesAt + 1, "CELLS 6 30\n\x04\x00\x00\n");
  test::writeBytes(path, twice);
  EXPECT_THROW_MSG(readMesh(path), InputError, path.c_str(), "more than one CELLS section");
  // Absurd point count.
  std::string huge = full;
  const size_t pts = huge.find("POINTS 8 double");
  ASSERT_NE(pts, std::string::npos);
  huge.replace(pts, 15, "POINTS 800000000000 double");
  test::writeBytes(path, huge);
  EXPECT_THROW_MSG(readMesh(path), InputError, path.c_str(), "POINTS");
}

TEST(MeshIOVtk, CorruptedVtuCompressionHeader) {
  TempDir dir;
  writeMesh(dir.file("good.vtu"), cubeMesh());
  std::string full = readText(dir.file("good.vtu"));
  const size_t data = full.find("encoding=\"raw\"");
  ASSERT_NE(data, std::string::npos);
  const size_t underscore = full.find('_', data);
  ASSERT_NE(underscore, std::string::npos);
  // First header word of the first array = number of compressed blocks (UInt64).
  for (size_t k = 1; k <= 8; ++k) full[underscore + k] = '\xff';
  const std::string path = dir.file("bad.vtu");
  test::writeBytes(path, full);
  EXPECT_THROW_MSG(readMesh(path), InputError, path.c_str());
}

// Deterministic corruption (byte changes, cuts, garbage runs, header digits): every result is
// a mesh or an InputError; anything else (another exception, a crash) fails.
TEST(MeshIOVtk, CorruptedFilesNeverEscapeAsOtherErrors) {
  TempDir dir;
  std::mt19937 rng(2024);
  for (const char* ext : {".vtu", ".vtk"}) {
    const std::string good = dir.file(std::string("good") + ext);
    writeMesh(good, randomMesh(51));
    const std::string src = readText(good);
    const std::string path = dir.file(std::string("fuzz") + ext);
    int refused = 0;
    for (int i = 0; i < 120; ++i) {
      std::string b = src;
      auto pick = [&](size_t n) { return static_cast<size_t>(rng() % n); };
      switch (i % 4) {
      case 0:
        for (int k = 0, n = 1 + static_cast<int>(rng() % 8); k < n; ++k)
          b[pick(b.size())] = static_cast<char>(rng() & 0xff);
        break;
      case 1: b.resize(pick(b.size())); break;
      case 2: {
        const size_t p = pick(b.size());
        for (size_t k = p; k < std::min(b.size(), p + 1 + pick(64)); ++k)
          b[k] = static_cast<char>(rng() & 0xff);
        break;
      }
      default: {
        std::vector<size_t> digits;
        for (size_t k = 0; k < std::min<size_t>(b.size(), 4000); ++k)
          if (b[k] >= '0' && b[k] <= '9') digits.push_back(k);
        for (int k = 0; k < 3 && !digits.empty(); ++k)
          b[digits[pick(digits.size())]] = static_cast<char>('0' + rng() % 10);
      }
      }
      test::writeBytes(path, b);
      try {
        const TetMesh m = readMesh(path);
        for (size_t t = 0; t < m.numTets(); ++t) EXPECT_GE(m.tetVolume(t), 0.0);
      } catch (const InputError& e) {
        ++refused;
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      }
    }
    EXPECT_GT(refused, 30) << ext;
  }
}

TEST(MeshIOVtk, ReservedAndEmptyFieldNames) {
  TempDir dir;
  TetMesh m = cubeMesh();
  m.cellFields["material"] = Field{1, std::vector<double>(m.numTets(), 1.0)};
  EXPECT_THROW_MSG(writeMesh(dir.file("m.vtu"), m), InputError, "m.vtu", "material");
  TetMesh e = cubeMesh();
  e.pointFields[""] = Field{1, std::vector<double>(e.numPoints(), 1.0)};
  EXPECT_THROW_MSG(writeMesh(dir.file("e.vtk"), e), InputError, "e.vtk", "empty name");
  EXPECT_TRUE(dirEntries(dir.path()).empty());
}

// ---------------------------------------------------------------------------------------------
// The .vtu writer (VtuWriter.h): read back by VTK's reader, and against VTK's own writer
// ---------------------------------------------------------------------------------------------

// Random tets over random points (the file format does not need a conforming mesh), positively
// oriented or flat (readMesh keeps both as they are), labels -3..12, point and
// cell fields with 1 and 3 components of random (incompressible) doubles.
TetMesh randomTets(size_t np, size_t nt, unsigned seed) {
  TetMesh m;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-50, 50);
  for (size_t i = 0; i < np; ++i) m.points.push_back({u(rng), u(rng), u(rng)});
  for (size_t t = 0; t < nt; ++t) {
    TetMesh::Tet tet{};
    for (int32_t& v : tet) v = static_cast<int32_t>(rng() % np);
    m.tets.push_back(tet);
    m.materials.push_back(static_cast<int32_t>(rng() % 16) - 3);
  }
  orientPositive(m);
  // A nearly flat tet may be negative both ways round (rounding); readMesh would swap it back.
  for (size_t t = 0; t < nt; ++t)
    if (m.tetVolume(t) < 0) m.tets[t][1] = m.tets[t][0];
  auto field = [&](size_t n, int components) {
    Field f{components, {}};
    for (size_t i = 0; i < n * size_t(components); ++i) f.values.push_back(u(rng) * 1e-3);
    return f;
  };
  m.pointFields["p1"] = field(np, 1);
  m.pointFields["p3"] = field(np, 3);
  m.cellFields["c1"] = field(nt, 1);
  m.cellFields["c3"] = field(nt, 3);
  return m;
}

// What writeMesh did before VtuWriter: VTK's writer with the same settings.
void writeWithVtk(const std::string& path, const TetMesh& m, bool wideCells = false) {
  vtkNew<vtkUnstructuredGrid> grid;
  vtkNew<vtkPoints> pts;
  pts->SetDataTypeToDouble();
  pts->SetNumberOfPoints(static_cast<vtkIdType>(m.numPoints()));
  for (size_t i = 0; i < m.numPoints(); ++i)
    pts->SetPoint(static_cast<vtkIdType>(i), m.points[i].data());
  grid->SetPoints(pts);
  vtkNew<vtkCellArray> cells;
  const vtkIdType nt = static_cast<vtkIdType>(m.numTets());
  auto fill = [&](auto* offsets, auto* conn) {
    offsets->SetNumberOfValues(nt + 1);
    conn->SetNumberOfValues(4 * nt);
    for (vtkIdType t = 0; t <= nt; ++t) offsets->SetValue(t, 4 * t);
    for (vtkIdType t = 0; t < nt; ++t)
      for (int k = 0; k < 4; ++k) conn->SetValue(4 * t + k, m.tets[size_t(t)][k]);
    cells->SetData(offsets, conn);
  };
  if (wideCells) {
    vtkNew<vtkTypeInt64Array> offsets, conn;
    fill(offsets.Get(), conn.Get());
  } else {
    vtkNew<vtkTypeInt32Array> offsets, conn;
    fill(offsets.Get(), conn.Get());
  }
  grid->SetCells(VTK_TETRA, cells);
  vtkNew<vtkIntArray> mat;
  mat->SetName("material");
  mat->SetNumberOfValues(nt);
  for (vtkIdType t = 0; t < nt; ++t) mat->SetValue(t, m.materials[size_t(t)]);
  grid->GetCellData()->AddArray(mat);
  auto add = [](const std::map<std::string, Field>& fields, vtkDataSetAttributes* attr) {
    for (const auto& [name, f] : fields) {
      vtkNew<vtkDoubleArray> a;
      a->SetName(name.c_str());
      a->SetNumberOfComponents(f.components);
      a->SetNumberOfValues(static_cast<vtkIdType>(f.values.size()));
      for (size_t i = 0; i < f.values.size(); ++i)
        a->SetValue(static_cast<vtkIdType>(i), f.values[i]);
      attr->AddArray(a);
    }
  };
  add(m.pointFields, grid->GetPointData());
  add(m.cellFields, grid->GetCellData());
  vtkNew<vtkXMLUnstructuredGridWriter> w;
  w->SetFileName(path.c_str());
  w->SetInputData(grid);
  w->SetDataModeToAppended();
  w->EncodeAppendedDataOff();
  w->SetCompressorTypeToZLib();
  w->SetCompressionLevel(1);
  w->SetHeaderTypeToUInt64();
  ASSERT_EQ(w->Write(), 1);
}

void expectIdentical(const TetMesh& want, const TetMesh& got) {
  EXPECT_TRUE(got.points == want.points);
  EXPECT_TRUE(got.tets == want.tets);
  EXPECT_TRUE(got.materials == want.materials);
  EXPECT_TRUE(got.pointFields == want.pointFields);
  EXPECT_TRUE(got.cellFields == want.cellFields);
}

// Attributes of the file's XML elements named `element`, in order (the XML ends where the
// appended data start).
std::vector<std::map<std::string, std::string>> xmlTags(const std::string& file,
                                                        const std::string& element) {
  const std::string xml = file.substr(0, file.find("<AppendedData"));
  std::vector<std::map<std::string, std::string>> tags;
  for (size_t at = xml.find("<" + element + " "); at != std::string::npos;
       at = xml.find("<" + element + " ", at + 1)) {
    std::map<std::string, std::string> attrs;
    size_t p = at + element.size() + 1;
    const size_t end = xml.find('>', p);
    while (true) {
      const size_t eq = xml.find("=\"", p);
      if (eq == std::string::npos || eq > end) break;
      size_t name = eq;
      while (name > p && xml[name - 1] != ' ') --name;
      const size_t close = xml.find('"', eq + 2);
      attrs[xml.substr(name, eq - name)] = xml.substr(eq + 2, close - eq - 2);
      p = close + 1;
    }
    tags.push_back(attrs);
  }
  return tags;
}

std::string appendedData(const std::string& file) {
  const size_t start = file.find('_', file.find("<AppendedData encoding=\"raw\">")) + 1;
  const size_t end = file.rfind("</AppendedData>");
  return file.substr(start, end - start);
}

std::string trimmed(std::string s) {
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// Sizes: nothing; points without tets; one tet; several blocks per array; every array an exact
// multiple of the 32 KiB block (8192 points, 32768 tets); many blocks and chunks of 3 blocks.
const std::vector<std::array<size_t, 2>> kVtuSizes = {
    {0, 0}, {5, 0}, {4, 1}, {300, 1000}, {8192, 32768}, {12345, 50001}};

TEST(MeshIOVtu, RandomMeshesReadBackExactly) {
  TempDir dir;
  unsigned seed = 1;
  for (const auto& [np, nt] : kVtuSizes) {
    SCOPED_TRACE(std::to_string(np) + " points, " + std::to_string(nt) + " tets");
    const TetMesh m = randomTets(np, nt, seed++);
    writeMesh(dir.file("m.vtu"), m);
    expectIdentical(m, readMesh(dir.file("m.vtu")));
    // Chunks of 3 blocks (many writes and cancellation checks per array) give the same bytes.
    VtuWriteOptions small;
    small.blocksPerChunk = 3;
    writeVtuFile(dir.file("small.vtu"), m, small);
    EXPECT_TRUE(readText(dir.file("small.vtu")) == readText(dir.file("m.vtu")));
  }
  EXPECT_EQ(dirEntries(dir.path()), (std::vector<std::string>{"m.vtu", "small.vtu"}));
}

// The file of VtuWriter is VTK's file: the same arrays (types, names, components, order and
// offsets), the same appended bytes (VTK's zlib is the system zlib, so even the compressed blocks
// agree; with storeIncompressible off, since VTK compresses every array), and the same mesh when
// read; the ranges agree to VTK's 11 digits.
TEST(MeshIOVtu, SameFileAsVtksWriter) {
  TempDir dir;
  unsigned seed = 40;
  for (const auto& [np, nt] : kVtuSizes) {
    for (const bool wide : {false, true}) {
      SCOPED_TRACE(std::to_string(np) + " points, " + std::to_string(nt) + " tets" +
                   (wide ? ", 64-bit cells" : ""));
      const TetMesh m = randomTets(np, nt, seed++);
      const std::string ours = dir.file("ours.vtu"), vtks = dir.file("vtk.vtu");
      VtuWriteOptions options;
      options.int64Cells = wide;
      options.storeIncompressible = false;
      writeVtuFile(ours, m, options);
      writeWithVtk(vtks, m, wide);
      const std::string a = readText(ours), b = readText(vtks);
      EXPECT_EQ(a.substr(0, a.find('\n')), b.substr(0, b.find('\n')));
      const auto pa = xmlTags(a, "Piece"), pb = xmlTags(b, "Piece");
      ASSERT_EQ(pa.size(), 1u);
      ASSERT_EQ(pb.size(), 1u);
      EXPECT_EQ(pa[0].at("NumberOfPoints"), trimmed(pb[0].at("NumberOfPoints")));
      EXPECT_EQ(pa[0].at("NumberOfCells"), trimmed(pb[0].at("NumberOfCells")));
      const auto ta = xmlTags(a, "DataArray"), tb = xmlTags(b, "DataArray");
      ASSERT_EQ(ta.size(), tb.size());
      ASSERT_EQ(ta.size(), 4u + m.pointFields.size() + m.cellFields.size() + 1);
      EXPECT_EQ(ta.back().at("Name"), "types");
      EXPECT_EQ(ta[ta.size() - 3].at("type"), wide ? "Int64" : "Int32"); // connectivity
      for (size_t i = 0; i < ta.size(); ++i) {
        SCOPED_TRACE(ta[i].count("Name") ? ta[i].at("Name") : "?");
        for (const char* key : {"type", "Name", "NumberOfComponents", "format", "offset"}) {
          const std::string va = ta[i].count(key) ? ta[i].at(key) : "-";
          const std::string vb = tb[i].count(key) ? trimmed(tb[i].at(key)) : "-";
          EXPECT_EQ(va, vb) << key;
        }
        // Single-component value arrays with values carry a range; VTK rounds it to 11 digits.
        const std::string name = ta[i].at("Name");
        const bool ranged =
            (name == "p1" && np > 0) || ((name == "material" || name == "c1") && nt > 0);
        EXPECT_EQ(ta[i].count("RangeMin") == 1 && ta[i].count("RangeMax") == 1, ranged);
        if (ranged)
          for (const char* key : {"RangeMin", "RangeMax"}) {
            const double va = std::stod(ta[i].at(key)), vb = std::stod(tb[i].at(key));
            EXPECT_NEAR(va, vb, 1e-10 * std::max(1.0, std::abs(vb))) << key;
          }
      }
      // The block header of the first array (p1): [blocks, 32768, bytes in a partial last block
      // (0 when the last block is full), compressed sizes].
      uint64_t head[3];
      std::memcpy(head, appendedData(a).data(), sizeof head);
      const uint64_t bytes = 8 * np;
      EXPECT_EQ(head[0], (bytes + 32767) / 32768);
      EXPECT_EQ(head[1], 32768u);
      EXPECT_EQ(head[2], bytes % 32768);
      EXPECT_TRUE(appendedData(a) == appendedData(b)) << "appended data differ";
      expectIdentical(m, readMesh(ours));
      expectIdentical(readMesh(vtks), readMesh(ours));
    }
  }
}

// The compressed size of every block of the appended array whose DataArray tag names `name`.
std::vector<uint64_t> blockSizes(const std::string& file, const std::string& name) {
  for (const auto& tag : xmlTags(file, "DataArray"))
    if (tag.count("Name") && tag.at("Name") == name) {
      const std::string data = appendedData(file);
      const size_t at = std::stoull(tag.at("offset"));
      uint64_t blocks = 0;
      std::memcpy(&blocks, data.data() + at, 8);
      std::vector<uint64_t> sizes(blocks);
      std::memcpy(sizes.data(), data.data() + at + 24, 8 * blocks);
      return sizes;
    }
  ADD_FAILURE() << "no array " << name;
  return {};
}

// Random doubles (every bit in use, as in quality fields) barely shrink: but for the first block
// of each group of 8 (compressed, to decide) their array goes out in stored zlib blocks, a few
// bytes longer than the block; arrays that shrink (the offsets 4, 8,
// 12, ..., a constant field) are still compressed. Both kinds read back exactly with VTK's
// reader, and the file is the same for any chunk size.
TEST(MeshIOVtu, IncompressibleArraysAreStored) {
  TempDir dir;
  TetMesh m = randomTets(20000, 70000, 7);
  m.cellFields["constant"] = Field{1, std::vector<double>(70000, 0.25)};
  writeMesh(dir.file("m.vtu"), m);
  const std::string file = readText(dir.file("m.vtu"));
  const std::vector<uint64_t> random = blockSizes(file, "c1"), constant = blockSizes(file, "constant"),
                              offsets = blockSizes(file, "offsets");
  ASSERT_EQ(random.size(), (70000u * 8 + 32767) / 32768);
  for (size_t k = 0; k + 1 < random.size(); ++k) {
    if (k % 8 == 0) { // the first of each group of 8 is compressed (it decides): it shrinks by less than a fifth
      EXPECT_GT(random[k], 0.8 * 32768) << "block " << k;
      EXPECT_LT(random[k], 32768u) << "block " << k;
    } else { // stored: the block plus zlib's framing
      EXPECT_GT(random[k], 32768u) << "block " << k;
      EXPECT_LT(random[k], 32768u + 64) << "block " << k;
    }
  }
  for (uint64_t z : constant) EXPECT_LT(z, 1000u);
  for (uint64_t z : offsets) EXPECT_LT(z, 20000u);
  expectIdentical(m, readMesh(dir.file("m.vtu")));
  VtuWriteOptions small;
  small.blocksPerChunk = 3;
  writeVtuFile(dir.file("small.vtu"), m, small);
  EXPECT_TRUE(readText(dir.file("small.vtu")) == file);
  // With storing off the same arrays are compressed at level 1 and the file is smaller.
  VtuWriteOptions packed;
  packed.storeIncompressible = false;
  writeVtuFile(dir.file("packed.vtu"), m, packed);
  for (uint64_t z : blockSizes(readText(dir.file("packed.vtu")), "c1")) EXPECT_LT(z, 32768u);
  expectIdentical(m, readMesh(dir.file("packed.vtu")));
}

// VTK 9.1's writer puts names into the XML as they are (a name with '"' or '<' made its file
// unreadable); ours escapes them.
TEST(MeshIOVtu, FieldNamesAreEscaped) {
  TempDir dir;
  TetMesh m = cubeMesh();
  const std::string odd = "a<b & \"c\" 'd'>";
  m.pointFields[odd] = m.pointFields.at("temperature");
  m.cellFields[odd + "2"] = m.cellFields.at("direction");
  writeMesh(dir.file("m.vtu"), m);
  expectIdentical(m, readMesh(dir.file("m.vtu")));
}

// Ranges leave out NaN, and an array without a finite value gets none.
TEST(MeshIOVtu, RangesOfSingleComponentArrays) {
  TempDir dir;
  TetMesh m = cubeMesh();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  m.cellFields["some_nan"] = Field{1, {nan, 2.5, -3, nan, 0, 1}};
  m.cellFields["all_nan"] = Field{1, std::vector<double>(6, nan)};
  m.cellFields["infinite"] = Field{1, {1, 2, 3, 4, 5, std::numeric_limits<double>::infinity()}};
  writeMesh(dir.file("m.vtu"), m);
  std::map<std::string, std::map<std::string, std::string>> byName;
  for (const auto& tag : xmlTags(readText(dir.file("m.vtu")), "DataArray"))
    byName[tag.at("Name")] = tag;
  EXPECT_EQ(byName["material"]["RangeMin"], "1");
  EXPECT_EQ(byName["material"]["RangeMax"], "7");
  EXPECT_EQ(byName["some_nan"]["RangeMin"], "-3");
  EXPECT_EQ(byName["some_nan"]["RangeMax"], "2.5");
  EXPECT_EQ(byName["all_nan"].count("RangeMin"), 0u);
  EXPECT_EQ(byName["infinite"].count("RangeMax"), 0u);
  EXPECT_EQ(byName["direction"].count("RangeMin"), 0u); // 3 components
  const TetMesh back = readMesh(dir.file("m.vtu"));
  EXPECT_TRUE(std::isnan(back.cellFields.at("all_nan").values[3]));
  EXPECT_EQ(back.cellFields.at("some_nan").values[1], 2.5);
}

// Cancelled in the middle of a write: the writer stops at its next chunk, leaves no file and
// keeps the old one.
TEST(MeshIOVtu, ACancelledWriteStopsAtTheNextChunk) {
  class CancelAtAQuarter : public Progress {
  public:
    double last = 0;
    int reports = 0;

  protected:
    void onReport(double fraction) override {
      last = fraction;
      ++reports;
      if (fraction >= 0.25) requestCancel();
    }
  };
  TempDir dir;
  const std::string path = dir.file("keep.vtu");
  const TetMesh old = cubeMesh();
  writeMesh(path, old);
  const TetMesh big = randomTets(20000, 60000, 7);
  VtuWriteOptions options;
  options.blocksPerChunk = 3;
  CancelAtAQuarter progress;
  {
    const ScopedCurrentProgress current(&progress);
    EXPECT_THROW(writeVtuFile(path, big, options), Cancelled);
  }
  EXPECT_GE(progress.last, 0.25);
  EXPECT_LT(progress.last, 0.3); // nothing was compressed after the cancellation
  EXPECT_GT(progress.reports, 5);
  EXPECT_EQ(dirEntries(dir.path()), std::vector<std::string>{"keep.vtu"});
  expectIdentical(old, readMesh(path));
  // Without a cancellation every chunk is reported, up to the whole file.
  class LastFraction : public Progress {
  public:
    double last = 0;

  protected:
    void onReport(double fraction) override { last = fraction; }
  } whole;
  {
    const ScopedCurrentProgress current(&whole);
    writeVtuFile(path, big, options);
  }
  EXPECT_EQ(whole.last, 1.0);
  expectIdentical(big, readMesh(path));
}

// A write that fails midway (here: the file-size limit, as a full disk would) is an InputError
// naming the file and the system's reason; the old file stays and no temp file is left.
TEST(MeshIOVtu, AWriteErrorLeavesNothing) {
  TempDir dir;
  const TetMesh m = randomTets(20000, 60000, 8);
  const std::string missing = (dir.path() / "no_such_folder" / "m.vtu").string();
  EXPECT_THROW_MSG(writeMesh(missing, m), InputError, missing, "does not exist");
  EXPECT_TRUE(dirEntries(dir.path()).empty());

  const std::string path = dir.file("keep.vtu");
  const TetMesh old = cubeMesh();
  writeMesh(path, old);
  struct rlimit saved {};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &saved), 0);
  struct rlimit small = saved;
  small.rlim_cur = 256 * 1024;
  // Ignored, SIGXFSZ no longer ends the process and the write fails with EFBIG instead.
  void (*savedHandler)(int) = std::signal(SIGXFSZ, SIG_IGN);
  if (setrlimit(RLIMIT_FSIZE, &small) == 0) {
    EXPECT_THROW_MSG(writeMesh(path, m), InputError, path, ": cannot write: ",
                     std::strerror(EFBIG), "nothing was written");
    setrlimit(RLIMIT_FSIZE, &saved);
  } else {
    ADD_FAILURE() << "setrlimit: " << std::strerror(errno);
  }
  std::signal(SIGXFSZ, savedHandler);
  EXPECT_EQ(dirEntries(dir.path()), std::vector<std::string>{"keep.vtu"});
  expectIdentical(old, readMesh(path));
}

// ---------------------------------------------------------------------------------------------
// TetGen
// ---------------------------------------------------------------------------------------------

std::vector<std::vector<std::string>> tokenLines(const std::string& path) {
  std::vector<std::vector<std::string>> lines;
  std::istringstream in(readText(path));
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::vector<std::string> toks;
    std::string t;
    while (ls >> t) toks.push_back(t);
    if (!toks.empty()) lines.push_back(toks);
  }
  return lines;
}

TEST(MeshIOTetGen, FileLayoutAndOrientation) {
  TempDir dir;
  TetMesh m = cubeMesh();
  m.points[0] = {0.1, -2.5e-7, 1.0 / 3.0};
  orientPositive(m);
  writeMesh(dir.file("cube.ele"), m);
  const auto node = tokenLines(dir.file("cube.node"));
  const auto ele = tokenLines(dir.file("cube.ele"));
  ASSERT_EQ(node.size(), 9u);
  EXPECT_EQ(node[0], (std::vector<std::string>{"8", "3", "0", "0"}));
  EXPECT_EQ(node[1], (std::vector<std::string>{"1", "0.10000000000000001", "-2.4999999999999999e-07",
                                               "0.33333333333333331"}));
  for (size_t i = 1; i < node.size(); ++i) EXPECT_EQ(node[i][0], std::to_string(i));
  ASSERT_EQ(ele.size(), 7u);
  EXPECT_EQ(ele[0], (std::vector<std::string>{"6", "4", "1"}));
  for (size_t t = 0; t < 6; ++t) {
    const auto& l = ele[t + 1];
    ASSERT_EQ(l.size(), 6u);
    EXPECT_EQ(l[0], std::to_string(t + 1));
    // 1-based corners in TetGen order; TetGen 1.5 keeps orient3d(a,b,c,d) < 0, i.e. positive
    // TetFlow volume: the same order as in memory.
    Vec3 c[4];
    for (int k = 0; k < 4; ++k) {
      const int v = std::stoi(l[1 + k]);
      ASSERT_GE(v, 1);
      ASSERT_LE(v, 8);
      EXPECT_EQ(v - 1, m.tets[t][k]);
      c[k] = m.points[static_cast<size_t>(v - 1)];
    }
    EXPECT_GT(signedTetVolume(c[0], c[1], c[2], c[3]), 0.0);
    EXPECT_EQ(l[5], std::to_string(m.materials[t]));
  }
}

TEST(MeshIOTetGen, ReadsZeroBasedCommentsAttributesMarkers) {
  TempDir dir;
  test::writeBytes(dir.file("t.node"),
                   "# a TetGen node file\n"
                   "5 3 2 1   # 5 nodes, 2 attributes, markers\n"
                   "\n"
                   "0  0.0 0.0 0.0   7.5 8.5  1\n"
                   "1  1.0 0.0 0.0   7.5 8.5  1\r\n"
                   "2  0.0 1.0 0.0   7.5 8.5  0  # comment after data\n"
                   "3  0.0 0.0 1.0   7.5 8.5  2\n"
                   "4  1e0 1E+0 +1.0 0 0 0\n");
  // No region attribute -> material 0; tet 1 is stored inverted and must come back positive.
  test::writeBytes(dir.file("t.ele"),
                   "2 4 0\n"
                   "0 0 1 2 3\n"
                   "# between\n"
                   "1 2 1 3 4\n");
  const TetMesh m = readMesh(dir.file("t.node"));
  ASSERT_EQ(m.numPoints(), 5u);
  EXPECT_EQ(m.points[4], (Vec3{1, 1, 1}));
  ASSERT_EQ(m.numTets(), 2u);
  EXPECT_EQ(m.tets[0], (TetMesh::Tet{0, 1, 2, 3}));
  EXPECT_EQ(m.materials, (std::vector<int32_t>{0, 0}));
  EXPECT_GT(m.tetVolume(0), 0.0);
  EXPECT_GT(m.tetVolume(1), 0.0);
  EXPECT_EQ(m.tets[1], (TetMesh::Tet{1, 2, 3, 4}));
}

TEST(MeshIOTetGen, RegionAttributeIsMaterial) {
  TempDir dir;
  test::writeBytes(dir.file("r.node"), "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
  test::writeBytes(dir.file("r.ele"), "1 4 1\n1 1 2 3 4 -12\n");
  const TetMesh m = readMesh(dir.file("r.ele"));
  EXPECT_EQ(m.materials, std::vector<int32_t>{-12});
  test::writeBytes(dir.file("r.ele"), "1 4 1\n1 1 2 3 4 2.5\n");
  EXPECT_THROW_MSG(readMesh(dir.file("r.ele")), InputError, "r.ele", "line 2", "region attribute");
  test::writeBytes(dir.file("r.ele"), "1 4 1\n1 1 2 3 4\n");
  EXPECT_THROW_MSG(readMesh(dir.file("r.ele")), InputError, "r.ele", "line 2", "region attribute");
}

TEST(MeshIOTetGen, TruncatedNodeFile) {
  TempDir dir;
  writeMesh(dir.file("m.node"), cubeMesh());
  std::string node = readText(dir.file("m.node"));
  // Keep the header and four nodes, cut the fifth in the middle of a line.
  size_t pos = 0;
  for (int i = 0; i < 5; ++i) pos = node.find('\n', pos) + 1;
  test::writeBytes(dir.file("m.node"), node.substr(0, pos + 3));
  EXPECT_THROW_MSG(readMesh(dir.file("m.ele")), InputError, "m.node", "line 6");
  test::writeBytes(dir.file("m.node"), node.substr(0, pos));
  EXPECT_THROW_MSG(readMesh(dir.file("m.ele")), InputError, "m.node", "4 of the 8 nodes",
                   "truncated");
}

TEST(MeshIOTetGen, EleRefersToMissingNode) {
  TempDir dir;
  test::writeBytes(dir.file("m.node"), "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
  test::writeBytes(dir.file("m.ele"), "2 4 0\n1 1 2 3 4\n2 1 2 3 99\n");
  EXPECT_THROW_MSG(readMesh(dir.file("m.node")), InputError, "m.ele", "line 3", "node 99",
                   "m.node", "1..4");
  test::writeBytes(dir.file("m.ele"), "1 4 0\n1 0 2 3 4\n"); // 0 with 1-based nodes
  EXPECT_THROW_MSG(readMesh(dir.file("m.node")), InputError, "m.ele", "line 2", "node 0");
}

TEST(MeshIOTetGen, BrokenFiles) {
  TempDir dir;
  const std::string node = dir.file("b.node"), ele = dir.file("b.ele");
  const std::string goodNode = "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n";
  const std::string goodEle = "1 4 0\n1 1 2 3 4\n";
  struct Case {
    std::string node, ele;
    std::vector<std::string> fragments;
  };
  const std::vector<Case> cases = {
      {goodNode, "1 10 0\n1 1 2 3 4 5 6 7 8 9 10\n", {"b.ele", "line 1", "10-node"}},
      {goodNode, "1 3 0\n1 1 2 3\n", {"b.ele", "line 1", "only 4"}},
      {goodNode, "3 4 0\n1 1 2 3 4\n", {"b.ele", "1 of the 3 tetrahedra", "truncated"}},
      {goodNode, "1 4 0\n1 1 2 x 4\n", {"b.ele", "line 2", "'x'"}},
      {goodNode, "", {"b.ele", "empty"}},
      {"4 2 0 0\n1 0 0\n", goodEle, {"b.node", "line 1", "dimension 2"}},
      {"4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 nan\n4 0 0 1\n", goodEle, {"b.node", "line 4", "nan"}},
      {"4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1.5.2 0\n4 0 0 1\n", goodEle, {"b.node", "line 4"}},
      {"4 3 0 0\n1 0 0 0\n3 1 0 0\n", goodEle, {"b.node", "line 3", "out of sequence"}},
      {"4 3 0 0\n5 0 0 0\n", goodEle, {"b.node", "line 2", "0 or 1"}},
      {"4 3 0 0\n1 0 0\n", goodEle, {"b.node", "line 2", "z coordinate"}},
      {"999999999999 3 0 0\n1 0 0 0\n", goodEle, {"b.node"}},
      {"", goodEle, {"b.node", "empty"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.node + "|" + c.ele);
    test::writeBytes(node, c.node);
    test::writeBytes(ele, c.ele);
    try {
      readMesh(node);
      ADD_FAILURE() << "expected InputError";
    } catch (const InputError& e) {
      for (const std::string& f : c.fragments)
        EXPECT_NE(std::string(e.what()).find(f), std::string::npos)
            << "message '" << e.what() << "' lacks '" << f << "'";
    }
  }
  fs::remove(ele);
  test::writeBytes(node, goodNode);
  EXPECT_THROW_MSG(readMesh(node), InputError, "b.ele", "not found");
}

// ---------------------------------------------------------------------------------------------
// Gmsh MSH 4.1: parsed back by an independent minimal parser
// ---------------------------------------------------------------------------------------------

struct MshVolume {
  int tag = 0;
  double box[6] = {};
  std::vector<int> physical;
};
struct MshBlock {
  int dim = 0, entity = 0, type = 0;
  std::vector<std::vector<long>> elements; // tag followed by node tags
};
struct MshFile {
  std::vector<std::string> sectionOrder;
  std::string version, fileType, dataSize;
  std::map<int, std::pair<int, std::string>> physicalNames; // tag -> (dim, name)
  std::vector<int> entityCounts;
  std::vector<MshVolume> volumes;
  long nodeBlocks = 0, numNodes = 0, minNode = 0, maxNode = 0;
  std::map<long, Vec3> nodes;
  std::vector<int> nodeBlockEntity;
  long elemBlocks = 0, numElements = 0, minElem = 0, maxElem = 0;
  std::vector<MshBlock> blocks;
};

MshFile parseMsh(const std::string& path) {
  MshFile f;
  std::istringstream all(readText(path));
  std::string line;
  std::map<std::string, std::string> sections;
  while (std::getline(all, line)) {
    if (line.empty()) continue;
    EXPECT_EQ(line[0], '$') << "text outside a section: " << line;
    const std::string name = line.substr(1);
    f.sectionOrder.push_back(name);
    std::string body;
    bool closed = false;
    while (std::getline(all, line)) {
      if (line == "$End" + name) {
        closed = true;
        break;
      }
      body += line + "\n";
    }
    EXPECT_TRUE(closed) << "section " << name << " not closed";
    sections[name] = body;
  }
  {
    std::istringstream s(sections["MeshFormat"]);
    s >> f.version >> f.fileType >> f.dataSize;
  }
  {
    std::istringstream s(sections["PhysicalNames"]);
    int n = 0;
    s >> n;
    for (int i = 0; i < n; ++i) {
      int dim = 0, tag = 0;
      std::string name;
      s >> dim >> tag >> std::quoted(name);
      EXPECT_TRUE(s) << "bad $PhysicalNames entry " << i;
      EXPECT_EQ(f.physicalNames.count(tag), 0u) << "duplicate physical tag " << tag;
      f.physicalNames[tag] = {dim, name};
    }
    std::string rest;
    EXPECT_FALSE(s >> rest) << "extra text in $PhysicalNames";
  }
  {
    std::istringstream s(sections["Entities"]);
    f.entityCounts.resize(4);
    for (int& c : f.entityCounts) s >> c;
    for (int i = 0; i < f.entityCounts[3]; ++i) {
      MshVolume v;
      int np = 0, nb = 0;
      s >> v.tag;
      for (double& b : v.box) s >> b;
      s >> np;
      v.physical.resize(static_cast<size_t>(std::max(np, 0)));
      for (int& p : v.physical) s >> p;
      s >> nb;
      EXPECT_EQ(nb, 0);
      EXPECT_TRUE(s) << "bad volume entity " << i;
      f.volumes.push_back(v);
    }
    std::string rest;
    EXPECT_FALSE(s >> rest) << "extra text in $Entities";
  }
  {
    std::istringstream s(sections["Nodes"]);
    s >> f.nodeBlocks >> f.numNodes >> f.minNode >> f.maxNode;
    for (long b = 0; b < f.nodeBlocks; ++b) {
      int dim = 0, entity = 0, parametric = 0;
      long count = 0;
      s >> dim >> entity >> parametric >> count;
      EXPECT_EQ(parametric, 0);
      f.nodeBlockEntity.push_back(dim * 1000 + entity);
      std::vector<long> tags(static_cast<size_t>(count));
      for (long& t : tags) s >> t;
      for (long t : tags) {
        Vec3 p;
        s >> p[0] >> p[1] >> p[2];
        EXPECT_EQ(f.nodes.count(t), 0u) << "duplicate node " << t;
        f.nodes[t] = p;
      }
      EXPECT_TRUE(s) << "bad node block " << b;
    }
    std::string rest;
    EXPECT_FALSE(s >> rest) << "extra text in $Nodes";
  }
  {
    std::istringstream s(sections["Elements"]);
    s >> f.elemBlocks >> f.numElements >> f.minElem >> f.maxElem;
    for (long b = 0; b < f.elemBlocks; ++b) {
      MshBlock blk;
      long count = 0;
      s >> blk.dim >> blk.entity >> blk.type >> count;
      const int nodesPer = blk.type == 4 ? 4 : 0;
      EXPECT_EQ(nodesPer, 4) << "element type " << blk.type;
      for (long e = 0; e < count; ++e) {
        std::vector<long> el(static_cast<size_t>(1 + nodesPer));
        for (long& x : el) s >> x;
        blk.elements.push_back(el);
      }
      EXPECT_TRUE(s) << "bad element block " << b;
      f.blocks.push_back(blk);
    }
    std::string rest;
    EXPECT_FALSE(s >> rest) << "extra text in $Elements";
  }
  return f;
}

// Check the file against `m`; labels -> expected physical tags.
void checkMsh(const std::string& path, const TetMesh& m, const std::map<int32_t, int>& tagOf) {
  const MshFile f = parseMsh(path);
  EXPECT_EQ(f.sectionOrder, (std::vector<std::string>{"MeshFormat", "PhysicalNames", "Entities",
                                                      "Nodes", "Elements"}));
  EXPECT_EQ(f.version, "4.1");
  EXPECT_EQ(f.fileType, "0");
  EXPECT_EQ(f.dataSize, "8");

  // One 3D physical group per material, named material_<label>.
  ASSERT_EQ(f.physicalNames.size(), tagOf.size());
  std::map<int, int32_t> labelOfTag;
  for (const auto& [label, tag] : tagOf) {
    auto it = f.physicalNames.find(tag);
    ASSERT_NE(it, f.physicalNames.end()) << "no physical group with tag " << tag;
    EXPECT_EQ(it->second.first, 3);
    EXPECT_EQ(it->second.second, "material_" + std::to_string(label));
    labelOfTag[tag] = label;
  }

  // One volume entity per material carrying its physical tag.
  EXPECT_EQ(f.entityCounts, (std::vector<int>{0, 0, 0, static_cast<int>(tagOf.size())}));
  std::map<int, int32_t> labelOfEntity;
  std::map<int, MshVolume> volumeOf;
  for (const MshVolume& v : f.volumes) {
    ASSERT_EQ(v.physical.size(), 1u);
    ASSERT_EQ(labelOfTag.count(v.physical[0]), 1u);
    EXPECT_EQ(labelOfEntity.count(v.tag), 0u) << "duplicate entity tag";
    labelOfEntity[v.tag] = labelOfTag[v.physical[0]];
    volumeOf[v.tag] = v;
  }

  // Nodes: 1..n, coordinates exact, on a volume entity.
  EXPECT_EQ(f.numNodes, static_cast<long>(m.numPoints()));
  EXPECT_EQ(f.minNode, 1);
  EXPECT_EQ(f.maxNode, static_cast<long>(m.numPoints()));
  ASSERT_EQ(f.nodes.size(), m.numPoints());
  for (int e : f.nodeBlockEntity) {
    EXPECT_EQ(e / 1000, 3);
    EXPECT_EQ(labelOfEntity.count(e % 1000), 1u);
  }
  for (size_t i = 0; i < m.numPoints(); ++i) {
    const Vec3& p = f.nodes.at(static_cast<long>(i) + 1);
    for (int a = 0; a < 3; ++a) EXPECT_TRUE(closeRel(m.points[i][a], p[a])) << i;
  }

  // Elements: one block per material, type 4, consecutive tags from 1, tets grouped by material
  // in their original order, positively oriented, inside their entity's bounding box.
  EXPECT_EQ(f.elemBlocks, static_cast<long>(tagOf.size()));
  EXPECT_EQ(f.numElements, static_cast<long>(m.numTets()));
  EXPECT_EQ(f.minElem, m.numTets() ? 1 : 0);
  EXPECT_EQ(f.maxElem, static_cast<long>(m.numTets()));
  std::map<int32_t, std::vector<TetMesh::Tet>> want, got;
  for (size_t t = 0; t < m.numTets(); ++t) want[m.materials[t]].push_back(m.tets[t]);
  long nextTag = 1;
  std::set<int> blockEntities;
  for (const MshBlock& b : f.blocks) {
    EXPECT_EQ(b.dim, 3);
    EXPECT_EQ(b.type, 4);
    ASSERT_EQ(labelOfEntity.count(b.entity), 1u);
    EXPECT_TRUE(blockEntities.insert(b.entity).second) << "two blocks for entity " << b.entity;
    const int32_t label = labelOfEntity[b.entity];
    const MshVolume& vol = volumeOf[b.entity];
    for (const auto& el : b.elements) {
      EXPECT_EQ(el[0], nextTag++);
      TetMesh::Tet t{};
      for (int k = 0; k < 4; ++k) {
        t[k] = static_cast<int32_t>(el[1 + k] - 1);
        const Vec3& p = f.nodes.at(el[1 + k]);
        for (int a = 0; a < 3; ++a) {
          EXPECT_GE(p[a], vol.box[a]);
          EXPECT_LE(p[a], vol.box[3 + a]);
        }
      }
      EXPECT_GT(signedTetVolume(f.nodes.at(el[1]), f.nodes.at(el[2]), f.nodes.at(el[3]),
                                f.nodes.at(el[4])),
                0.0);
      got[label].push_back(t);
    }
  }
  EXPECT_EQ(got, want);
}

TEST(MeshIOGmsh, CubeTwoMaterials) {
  TempDir dir;
  const TetMesh m = cubeMesh();
  writeMesh(dir.file("cube.msh"), m);
  checkMsh(dir.file("cube.msh"), m, {{1, 1}, {7, 7}});
  EXPECT_EQ(dirEntries(dir.path()), std::vector<std::string>{"cube.msh"});
}

TEST(MeshIOGmsh, NonPositiveLabelsGetFreshTags) {
  TempDir dir;
  const TetMesh m = randomMesh(31); // labels -2, 0, 3, 5
  std::set<int32_t> labels(m.materials.begin(), m.materials.end());
  ASSERT_EQ(labels, (std::set<int32_t>{-2, 0, 3, 5}));
  writeMesh(dir.file("r.msh"), m);
  // Labels >= 1 keep their value; -2 and 0 get 6 and 7 (above the maximum label 5), in order.
  checkMsh(dir.file("r.msh"), m, {{-2, 6}, {0, 7}, {3, 3}, {5, 5}});
  const std::string text = readText(dir.file("r.msh"));
  EXPECT_NE(text.find("3 6 \"material_-2\""), std::string::npos);
  EXPECT_NE(text.find("3 7 \"material_0\""), std::string::npos);
}

TEST(MeshIOGmsh, AllLabelsNonPositive) {
  TempDir dir;
  TetMesh m = cubeMesh();
  m.materials = {0, 0, -5, -5, 0, -5};
  writeMesh(dir.file("n.msh"), m);
  checkMsh(dir.file("n.msh"), m, {{-5, 1}, {0, 2}});
}

TEST(MeshIOGmsh, EmptySectionsLeftOut) {
  TempDir dir;
  writeMesh(dir.file("empty.msh"), TetMesh{});
  const MshFile e = parseMsh(dir.file("empty.msh"));
  EXPECT_EQ(e.sectionOrder, (std::vector<std::string>{"MeshFormat", "Entities"}));
  EXPECT_EQ(e.entityCounts, (std::vector<int>{0, 0, 0, 0}));

  TetMesh pts;
  pts.points = {{0, 0, 0}, {1, 2, 3}};
  writeMesh(dir.file("pts.msh"), pts);
  const MshFile p = parseMsh(dir.file("pts.msh"));
  EXPECT_EQ(p.sectionOrder, (std::vector<std::string>{"MeshFormat", "Entities", "Nodes", "Elements"}));
  ASSERT_EQ(p.volumes.size(), 1u);
  EXPECT_TRUE(p.volumes[0].physical.empty());
  EXPECT_EQ(p.nodes.size(), 2u);
  EXPECT_EQ(p.numElements, 0);
}

// Cross-check with the real Gmsh when it is installed: it must read the file without warnings and
// re-export (as MSH 2.2, which lists each element's physical tag) the same tets and materials.
TEST(MeshIOGmsh, AcceptedByGmshIfInstalled) {
  if (std::system("command -v gmsh > /dev/null 2>&1") != 0) GTEST_SKIP() << "gmsh not installed";
  TempDir dir;
  const TetMesh m = randomMesh(41);
  writeMesh(dir.file("in.msh"), m);
  const std::string log = dir.file("gmsh.log");
  const std::string cmd = "gmsh '" + dir.file("in.msh") + "' -0 -format msh22 -o '" +
                          dir.file("out.msh") + "' > '" + log + "' 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << readText(log);
  const std::string logText = readText(log);
  EXPECT_EQ(logText.find("Warning"), std::string::npos) << logText;
  EXPECT_EQ(logText.find("Error"), std::string::npos) << logText;

  std::istringstream in(readText(dir.file("out.msh")));
  std::string line;
  std::map<int, std::string> names;
  std::map<long, Vec3> nodes;
  std::map<int32_t, std::vector<TetMesh::Tet>> got, want;
  while (std::getline(in, line)) {
    if (line == "$PhysicalNames") {
      int n = 0;
      in >> n;
      for (int i = 0; i < n; ++i) {
        int dim = 0, tag = 0;
        std::string name;
        in >> dim >> tag >> std::quoted(name);
        names[tag] = name;
      }
    } else if (line == "$Nodes") {
      long n = 0;
      in >> n;
      for (long i = 0; i < n; ++i) {
        long id = 0;
        Vec3 p;
        in >> id >> p[0] >> p[1] >> p[2];
        nodes[id] = p;
      }
    } else if (line == "$Elements") {
      long n = 0;
      in >> n;
      ASSERT_EQ(n, static_cast<long>(m.numTets()));
      for (long i = 0; i < n; ++i) {
        long id = 0;
        int type = 0, ntags = 0;
        in >> id >> type >> ntags;
        std::vector<int> tags(static_cast<size_t>(ntags));
        for (int& t : tags) in >> t;
        ASSERT_EQ(type, 4);
        ASSERT_GE(ntags, 1);
        TetMesh::Tet t{};
        for (int32_t& v : t) {
          long nid = 0;
          in >> nid;
          v = static_cast<int32_t>(nid - 1);
        }
        const std::string& name = names[tags[0]];
        ASSERT_EQ(name.rfind("material_", 0), 0u) << name;
        got[std::stoi(name.substr(9))].push_back(t);
      }
    }
  }
  ASSERT_EQ(nodes.size(), m.numPoints());
  for (size_t i = 0; i < m.numPoints(); ++i)
    for (int a = 0; a < 3; ++a)
      EXPECT_TRUE(closeRel(m.points[i][a], nodes[static_cast<long>(i) + 1][a])) << i;
  for (size_t t = 0; t < m.numTets(); ++t) want[m.materials[t]].push_back(m.tets[t]);
  EXPECT_EQ(got, want);
}

// ---------------------------------------------------------------------------------------------
// Refused writes
// ---------------------------------------------------------------------------------------------

TEST(MeshIOWrite, MissingFolderLeavesNothing) {
  TempDir dir;
  const TetMesh m = cubeMesh();
  for (const char* name : {"m.vtu", "m.vtk", "m.msh", "m.node", "m.ele"}) {
    SCOPED_TRACE(name);
    const std::string path = (dir.path() / "no_such_folder" / name).string();
    EXPECT_THROW_MSG(writeMesh(path, m), InputError, "no_such_folder");
    EXPECT_FALSE(fs::exists(dir.path() / "no_such_folder"));
  }
  EXPECT_TRUE(dirEntries(dir.path()).empty());
}

TEST(MeshIOWrite, InvalidMeshRefusedBeforeWriting) {
  TempDir dir;
  TetMesh badMaterials = cubeMesh();
  badMaterials.materials.pop_back();
  TetMesh badIndex = cubeMesh();
  badIndex.tets[2][3] = 8;
  TetMesh badField = cubeMesh();
  badField.pointFields["displacement"].values.pop_back();
  TetMesh badPoint = cubeMesh();
  badPoint.points[1][2] = std::nan("");
  for (const char* name : {"m.vtu", "m.vtk", "m.msh", "m.node"}) {
    SCOPED_TRACE(name);
    const std::string path = dir.file(name);
    EXPECT_THROW_MSG(writeMesh(path, badMaterials), InputError, path.c_str(), "material labels");
    EXPECT_THROW_MSG(writeMesh(path, badIndex), InputError, path.c_str(), "tet 2", "vertex 8");
    EXPECT_THROW_MSG(writeMesh(path, badField), InputError, path.c_str(), "displacement");
    EXPECT_THROW_MSG(writeMesh(path, badPoint), InputError, path.c_str(), "vertex 1");
  }
  EXPECT_TRUE(dirEntries(dir.path()).empty());
}

TEST(MeshIOWrite, FailedWriteKeepsOldFile) {
  TempDir dir;
  const TetMesh good = cubeMesh();
  writeMesh(dir.file("keep.vtu"), good);
  TetMesh bad = good;
  bad.tets[0][0] = -1;
  EXPECT_THROW(writeMesh(dir.file("keep.vtu"), bad), InputError);
  expectSameGeometry(good, readMesh(dir.file("keep.vtu")));
  EXPECT_EQ(dirEntries(dir.path()), std::vector<std::string>{"keep.vtu"});
}

// A write whose module was cancelled keeps the old file and leaves no temp file, for our own
// writers and VTK's alike (the commit checks the running module's progress sink).
TEST(MeshIOWrite, ACancelledWriteKeepsTheOldFile) {
  TempDir dir;
  const TetMesh good = cubeMesh();
  for (const std::string name : {"keep.vtu", "keep.vtk", "keep.node"}) {
    writeMesh(dir.file(name), good);
    TetMesh other = good;
    other.points[0][0] += 0.25;
    NullProgress cancelled;
    cancelled.requestCancel();
    {
      const ScopedCurrentProgress current(&cancelled);
      EXPECT_THROW(writeMesh(dir.file(name), other), Cancelled) << name;
    }
    expectSameGeometry(good, readMesh(dir.file(name)));
    writeMesh(dir.file(name), other); // no module running: written
    expectSameGeometry(other, readMesh(dir.file(name)));
  }
  EXPECT_EQ(dirEntries(dir.path()).size(), 4u) << "keep.vtu, keep.vtk, keep.node, keep.ele and nothing else";
}

// VTK's legacy writer, through its cancellable subclass, stops at its first piece once the running
// module is cancelled: a mesh of 400 k tets is abandoned after a small part of its file. (The
// .vtu writer is our own: MeshIOVtu.ACancelledWriteStopsAtTheNextChunk.)
TEST(MeshIOWrite, VtkLegacyWriterStopsEarlyOnceTheModuleIsCancelled) {
  TempDir dir;
  const vtkIdType nt = 400000, np = 100000;
  std::mt19937 rng(3);
  vtkNew<vtkPoints> pts;
  pts->SetDataTypeToDouble();
  pts->SetNumberOfPoints(np);
  std::uniform_real_distribution<double> u(0, 1);
  for (vtkIdType i = 0; i < np; ++i) pts->SetPoint(i, u(rng), u(rng), u(rng));
  vtkNew<vtkUnstructuredGrid> grid;
  grid->SetPoints(pts);
  grid->Allocate(nt);
  for (vtkIdType t = 0; t < nt; ++t) {
    const vtkIdType ids[4] = {vtkIdType(rng() % np), vtkIdType(rng() % np), vtkIdType(rng() % np),
                              vtkIdType(rng() % np)};
    grid->InsertNextCell(VTK_TETRA, 4, ids);
  }
  vtkNew<vtkFloatArray> noise; // incompressible, so the full file is large
  noise->SetName("noise");
  noise->SetNumberOfTuples(np);
  for (vtkIdType i = 0; i < np; ++i) noise->SetValue(i, float(u(rng)));
  grid->GetPointData()->AddArray(noise);

  auto writeBoth = [&](bool cancel) {
    NullProgress progress;
    if (cancel) progress.requestCancel();
    const ScopedCurrentProgress current(&progress);
    vtkNew<CancellableLegacyVtkWriter> vtk;
    vtk->SetFileName(dir.file("g.vtk").c_str());
    vtk->SetInputData(grid);
    vtk->SetFileTypeToBinary();
    const int okVtk = vtk->Write();
    EXPECT_EQ(okVtk == 1 && vtk->GetErrorCode() == 0, !cancel);
    // (The legacy writer deletes its file when its stream fails.)
    return fs::exists(dir.file("g.vtk")) ? fs::file_size(dir.file("g.vtk")) : uintmax_t(0);
  };
  const auto full = writeBoth(false);
  EXPECT_GT(full, 4000000u);
  vtkObject::GlobalWarningDisplayOff(); // the writers' "out of disk space" messages
  const auto stopped = writeBoth(true);
  vtkObject::GlobalWarningDisplayOn();
  EXPECT_LT(stopped, full / 4);
}

// The VTK writers borrow the mesh's coordinates and double fields without a copy: writing must
// leave the mesh exactly as it was (VTK's legacy writer swaps bytes, in its own buffer).
TEST(MeshIOWrite, WritingLeavesTheMeshUntouched) {
  TempDir dir;
  TetMesh m = cubeMesh();
  Field pf;
  pf.components = 3;
  for (size_t i = 0; i < 3 * m.numPoints(); ++i) pf.values.push_back(0.1 * double(i) - 1.0 / 3.0);
  m.pointFields["flow"] = pf;
  Field cf;
  for (size_t t = 0; t < m.numTets(); ++t) cf.values.push_back(std::sqrt(double(t) + 0.5));
  m.cellFields["quality"] = cf;
  const TetMesh before = m;
  for (const std::string name : {"m.vtu", "m.vtk"}) {
    writeMesh(dir.file(name), m);
    EXPECT_TRUE(m.points == before.points) << name;
    EXPECT_TRUE(m.pointFields == before.pointFields) << name;
    EXPECT_TRUE(m.cellFields == before.cellFields) << name;
    const TetMesh back = readMesh(dir.file(name));
    EXPECT_TRUE(back.points == before.points) << name;
    EXPECT_TRUE(back.pointFields.at("flow") == pf) << name;
    EXPECT_TRUE(back.cellFields.at("quality") == cf) << name;
  }
}

} // namespace
} // namespace tetflow
