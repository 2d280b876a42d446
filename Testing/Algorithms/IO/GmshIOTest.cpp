// Tests for Algorithms/IO/GmshIO: MSH 4.1 and 2.2 (ASCII and binary) written and read back on
// random meshes; what TetFlow writes read by two independent readers (meshio from Debian's
// python3-meshio, and Gmsh itself); meshes that Gmsh makes (every MSH variant) read; refused and
// damaged files. scripts/setup.sh installs gmsh and python3-meshio; without them these tests fail
// and say so.
#include "Algorithms/IO/MeshIO.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "Algorithms/Core/Errors.h"
#include "Fixtures/RandomLabels.h"
#include "Fixtures/VoxelMesh.h"
#include "TestUtil.h"

namespace tetflow {
namespace {

using test::TempDir;

const MeshFormat kVariants[] = {MeshFormat::Gmsh41, MeshFormat::Gmsh22, MeshFormat::Gmsh22Binary};

using tetflow::test::readText;

int shellStatus(const std::string& cmd) { return std::system(cmd.c_str()); }

bool haveGmsh() { return shellStatus("command -v gmsh > /dev/null 2>&1") == 0; }
bool haveMeshio() { return shellStatus("/usr/bin/python3 -c 'import meshio' > /dev/null 2>&1") == 0; }
#define REQUIRE_GMSH() ASSERT_TRUE(haveGmsh()) << "gmsh is missing: scripts/setup.sh installs it (Debian package gmsh)"
#define REQUIRE_MESHIO() \
  ASSERT_TRUE(haveMeshio()) << "meshio is missing: scripts/setup.sh installs it (Debian package python3-meshio)"

// A random multi-label mesh: the exact mesh of a random Voronoi volume with thin sheets, its
// vertices jittered, labels shifted so that 0 and negative labels occur, and names for some.
TetMesh randomLabelledMesh(unsigned seed) {
  std::mt19937 rng(seed);
  const int n = 5 + int(rng() % 4); // voronoiWithSheets needs n >= 5
  LabelVolume v = test::voronoiWithSheets(rng, n);
  v.grid.origin = {-12.5 + seed, 3.25, 1e3};
  v.grid.spacing = {0.7, 1.1, 0.9};
  TetMesh m = test::voxelMesh(v);
  std::uniform_real_distribution<double> jitter(-0.05, 0.05);
  for (Vec3& p : m.points)
    for (double& c : p) c += jitter(rng);
  for (int32_t& L : m.materials) L -= 1; // labels -1, 0, 1, ...
  m.materialNames[1] = "grey matter";
  m.materialNames[2] = "CSF";
  return m;
}

// The mesh's tets as (material, corner vertex ids) in sorted order, for comparing meshes whose
// tets come in another order.
std::vector<std::tuple<int32_t, TetMesh::Tet>> tetSet(const TetMesh& m) {
  std::vector<std::tuple<int32_t, TetMesh::Tet>> s;
  for (size_t t = 0; t < m.numTets(); ++t) s.push_back({m.materials[t], m.tets[t]});
  std::sort(s.begin(), s.end());
  return s;
}

void expectSameMesh(const TetMesh& want, const TetMesh& got, bool sameOrder) {
  ASSERT_EQ(got.points, want.points); // exact: 17 digits or binary doubles
  ASSERT_EQ(got.numTets(), want.numTets());
  if (sameOrder) {
    EXPECT_EQ(got.tets, want.tets);
    EXPECT_EQ(got.materials, want.materials);
  } else {
    EXPECT_EQ(tetSet(got), tetSet(want));
  }
  for (size_t t = 0; t < got.numTets(); ++t) ASSERT_GT(got.tetVolume(t), 0.0) << t;
}

TEST(GmshIO, EveryVariantRoundTripsRandomMeshes) {
  TempDir dir;
  for (unsigned seed = 1; seed <= 6; ++seed) {
    const TetMesh m = randomLabelledMesh(seed);
    for (MeshFormat f : kVariants) {
      SCOPED_TRACE(std::string(meshFormatName(f)) + " seed " + std::to_string(seed));
      const std::string path = dir.file("r.msh");
      writeMesh(path, m, f);
      const TetMesh back = readMesh(path);
      // MSH 2.2 keeps the stored order; 4.1 groups the tets by material.
      expectSameMesh(m, back, f != MeshFormat::Gmsh41);
      std::map<int32_t, std::string> names;
      for (int32_t L : std::set<int32_t>(m.materials.begin(), m.materials.end()))
        if (m.materialNames.count(L)) names[L] = m.materialNames.at(L);
      EXPECT_EQ(back.materialNames, names);
      EXPECT_TRUE(back.pointFields.empty() && back.cellFields.empty());
    }
  }
}

TEST(GmshIO, BinaryIsTheSameMeshAsAscii) {
  TempDir dir;
  const TetMesh m = randomLabelledMesh(9);
  writeMesh(dir.file("a.msh"), m, MeshFormat::Gmsh22);
  writeMesh(dir.file("b.msh"), m, MeshFormat::Gmsh22Binary);
  const std::string a = readText(dir.file("a.msh")), b = readText(dir.file("b.msh"));
  EXPECT_EQ(a.substr(0, 27), "$MeshFormat\n2.2 0 8\n$EndMes");
  EXPECT_EQ(b.substr(0, 20), "$MeshFormat\n2.2 1 8\n");
  const TetMesh ra = readMesh(dir.file("a.msh")), rb = readMesh(dir.file("b.msh"));
  EXPECT_EQ(ra.points, rb.points);
  EXPECT_EQ(ra.tets, rb.tets);
  EXPECT_EQ(ra.materials, rb.materials);
}

// What meshio reads from a file: points, tets with physical tags, names.
struct MeshioView {
  std::vector<Vec3> points;
  std::vector<std::tuple<int32_t, TetMesh::Tet>> tets; // (physical tag, corners)
  std::map<int, std::string> volumeNames;              // physical tag -> name
};

MeshioView meshioRead(const std::string& path, const std::string& dumpPath) {
  const std::string cmd = "/usr/bin/python3 '" + std::string(TETFLOW_SOURCE_DIR) +
                          "/Testing/Scripts/meshio_dump.py' '" + path + "' > '" + dumpPath + "' 2>&1";
  MeshioView v;
  if (shellStatus(cmd) != 0) {
    ADD_FAILURE() << "meshio could not read " << path << ":\n" << readText(dumpPath);
    return v;
  }
  std::istringstream in(readText(dumpPath));
  for (std::string line; std::getline(in, line);) {
    std::istringstream ls(line);
    std::string kind;
    ls >> kind;
    if (kind == "p") {
      Vec3 p;
      for (double& c : p) {
        std::string t;
        ls >> t;
        std::from_chars(t.data(), t.data() + t.size(), c);
      }
      v.points.push_back(p);
    } else if (kind == "t") {
      TetMesh::Tet q;
      int32_t tag = 0;
      ls >> q[0] >> q[1] >> q[2] >> q[3] >> tag;
      v.tets.push_back({tag, q});
    } else if (kind == "name") {
      int dim = 0, tag = 0;
      ls >> dim >> tag;
      std::string name;
      std::getline(ls >> std::ws, name);
      if (dim == 3) v.volumeNames[tag] = name;
    }
  }
  return v;
}

TEST(GmshIO, MeshioReadsWhatWeWrite) {
  REQUIRE_MESHIO();
  TempDir dir;
  for (unsigned seed : {2u, 5u}) {
    TetMesh m = randomLabelledMesh(seed);
    // meshio files physical tags, which are the labels for labels >= 1: keep to those here.
    for (int32_t& L : m.materials) L += 2;
    m.materialNames = {{3, "grey matter"}, {4, "CSF"}};
    for (MeshFormat f : kVariants) {
      SCOPED_TRACE(std::string(meshFormatName(f)) + " seed " + std::to_string(seed));
      writeMesh(dir.file("m.msh"), m, f);
      const MeshioView v = meshioRead(dir.file("m.msh"), dir.file("dump.txt"));
      EXPECT_EQ(v.points, m.points);
      std::vector<std::tuple<int32_t, TetMesh::Tet>> want = tetSet(m), got = v.tets;
      std::sort(got.begin(), got.end());
      EXPECT_EQ(got, want);
      std::map<int, std::string> names;
      for (int32_t L : std::set<int32_t>(m.materials.begin(), m.materials.end()))
        names[L] = m.materialNames.count(L) ? m.materialNames.at(L) : "material_" + std::to_string(L);
      EXPECT_EQ(v.volumeNames, names);
    }
  }
}

// The tets as (material, corner positions), sorted: Gmsh numbers the nodes of an MSH 2 file again
// (grouped by the volume they lie in) when it writes them, so the comparison is by position.
std::vector<std::pair<int32_t, std::array<Vec3, 4>>> tetsByPosition(const TetMesh& m) {
  std::vector<std::pair<int32_t, std::array<Vec3, 4>>> s;
  for (size_t t = 0; t < m.numTets(); ++t) {
    std::array<Vec3, 4> c;
    for (int k = 0; k < 4; ++k) c[size_t(k)] = m.points[size_t(m.tets[t][size_t(k)])];
    // Rotate the corners (an even permutation keeps the orientation) so the smallest comes first.
    const size_t first = size_t(std::min_element(c.begin(), c.end()) - c.begin());
    static const int even[4][4] = {{0, 1, 2, 3}, {1, 0, 3, 2}, {2, 3, 0, 1}, {3, 2, 1, 0}};
    std::array<Vec3, 4> r;
    for (int k = 0; k < 4; ++k) r[size_t(k)] = c[size_t(even[first][k])];
    // The other three in their cyclic order starting at the smallest (a rotation: even).
    const size_t m1 = size_t(std::min_element(r.begin() + 1, r.end()) - r.begin());
    std::rotate(r.begin() + 1, r.begin() + long(m1), r.end());
    s.push_back({m.materials[t], r});
  }
  std::sort(s.begin(), s.end());
  return s;
}

// Gmsh reads each variant without a warning and writes it again as MSH 4.1 binary; TetFlow reads
// that back as the same mesh.
TEST(GmshIO, GmshReadsWhatWeWrite) {
  REQUIRE_GMSH();
  TempDir dir;
  TetMesh m = randomLabelledMesh(4);
  for (int32_t& L : m.materials) L += 2; // physical tags = labels
  m.materialNames = {{3, "scalp"}};
  for (MeshFormat f : kVariants) {
    SCOPED_TRACE(meshFormatName(f));
    writeMesh(dir.file("in.msh"), m, f);
    const std::string log = dir.file("gmsh.log");
    ASSERT_EQ(shellStatus("gmsh '" + dir.file("in.msh") + "' -0 -bin -format msh41 -o '" + dir.file("out.msh") + "' > '" +
                  log + "' 2>&1"),
              0)
        << readText(log);
    EXPECT_EQ(readText(log).find("Warning"), std::string::npos) << readText(log);
    EXPECT_EQ(readText(log).find("Error"), std::string::npos) << readText(log);
    const TetMesh back = readMesh(dir.file("out.msh"));
    ASSERT_EQ(back.numPoints(), m.numPoints());
    EXPECT_EQ(tetsByPosition(back), tetsByPosition(m));
    EXPECT_EQ(back.materialNames, (std::map<int32_t, std::string>{{3, "scalp"}}));
  }
}

// A box with a ball inside, two named physical volumes and a physical surface, meshed by Gmsh.
const char* kBallInBox = R"(SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 10, 10, 10};
Sphere(2) = {5, 5, 5, 3};
BooleanFragments{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Physical Volume("brain", 7) = {2};
Physical Volume("scalp", 3) = {3};
Physical Surface("outer", 11) = {1, 2, 3, 4, 5, 6};
Mesh.MeshSizeMax = 2;
)";

// Meshes `geo` with Gmsh into `out` with the given options; the test fails when Gmsh does.
void gmshMesh(const TempDir& dir, const std::string& geo, const std::string& options, const std::string& out) {
  test::writeBytes(dir.file("model.geo"), geo);
  const std::string log = dir.file("gmsh.log");
  ASSERT_EQ(shellStatus("gmsh '" + dir.file("model.geo") + "' -3 " + options + " -o '" + out + "' > '" + log + "' 2>&1"), 0)
      << readText(log);
}

TEST(GmshIO, ReadsMeshesGmshMakesInEveryVariant) {
  REQUIRE_GMSH();
  TempDir dir;
  std::vector<TetMesh> meshes;
  for (const char* options : {"-format msh22", "-bin -format msh22", "-format msh41", "-bin -format msh41"}) {
    SCOPED_TRACE(options);
    const std::string path = dir.file("ball.msh");
    gmshMesh(dir, kBallInBox, options, path);
    TetMesh m = readMesh(path);
    // Boundary triangles of the physical surface are skipped; two labels with their names.
    EXPECT_EQ(std::set<int32_t>(m.materials.begin(), m.materials.end()), (std::set<int32_t>{3, 7}));
    EXPECT_EQ(m.materialNames, (std::map<int32_t, std::string>{{3, "scalp"}, {7, "brain"}}));
    double box = 0, ball = 0;
    for (size_t t = 0; t < m.numTets(); ++t) {
      ASSERT_GT(m.tetVolume(t), 0.0);
      (m.materials[t] == 7 ? ball : box) += m.tetVolume(t);
    }
    EXPECT_NEAR(box + ball, 1000.0, 1e-9); // the box's faces are planes: exact
    // The ball is a polyhedron inscribed in the sphere of radius 3 (edges up to 2): a little smaller.
    EXPECT_LT(ball, 4.0 / 3.0 * M_PI * 27.0);
    EXPECT_GT(ball, 0.85 * 4.0 / 3.0 * M_PI * 27.0);
    meshes.push_back(std::move(m));
  }
  // The four files hold one mesh: the same tets, materials and (to the ASCII files' 16 digits)
  // points.
  for (size_t i = 1; i < meshes.size(); ++i) {
    ASSERT_EQ(meshes[i].numPoints(), meshes[0].numPoints());
    for (size_t p = 0; p < meshes[0].numPoints(); ++p)
      for (int a = 0; a < 3; ++a) ASSERT_NEAR(meshes[i].points[p][a], meshes[0].points[p][a], 1e-12);
    EXPECT_EQ(meshes[i].tets, meshes[0].tets);
    EXPECT_EQ(meshes[i].materials, meshes[0].materials);
  }
}

TEST(GmshIO, WithoutPhysicalGroupsTheEntityIsTheMaterial) {
  REQUIRE_GMSH();
  TempDir dir;
  const std::string geo = R"(SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 4, 4, 4};
Box(2) = {4, 0, 0, 4, 4, 4};
Coherence;
Mesh.MeshSizeMax = 2;
)";
  for (const char* options : {"-format msh22", "-format msh41"}) {
    SCOPED_TRACE(options);
    gmshMesh(dir, geo, options, dir.file("boxes.msh"));
    const TetMesh m = readMesh(dir.file("boxes.msh"));
    EXPECT_EQ(std::set<int32_t>(m.materials.begin(), m.materials.end()), (std::set<int32_t>{1, 2}));
    EXPECT_TRUE(m.materialNames.empty());
    double left = 0;
    for (size_t t = 0; t < m.numTets(); ++t)
      if (m.materials[t] == 1) left += m.tetVolume(t);
    EXPECT_NEAR(left, 64.0, 1e-9);
  }
}

TEST(GmshIO, SecondOrderTetsAreRefusedByName) {
  REQUIRE_GMSH();
  TempDir dir;
  gmshMesh(dir, kBallInBox, "-order 2 -format msh41", dir.file("o2.msh"));
  EXPECT_THROW_MSG(readMesh(dir.file("o2.msh")), InputError, "o2.msh", "10-node (second-order) tetrahedron",
                   "type 11", "only 4-node tetrahedra", "Mesh.ElementOrder = 1");
}

// Hand-written files for what Gmsh does not make on request.
const std::string kHeader22 = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
const std::string kNodes22 = "$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 1 1 1\n$EndNodes\n";

TEST(GmshIO, HandWrittenFilesAndTheirMessages) {
  TempDir dir;
  auto refused = [&](const std::string& text, std::initializer_list<std::string> fragments) {
    test::writeBytes(dir.file("h.msh"), text);
    try {
      readMesh(dir.file("h.msh"));
      ADD_FAILURE() << "accepted:\n" << text;
    } catch (const InputError& e) {
      for (const std::string& f : fragments)
        EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << e.what() << "\nlacks: " << f;
    }
  };
  // Accepted: sparse node tags, a tet listed with its corners in the other orientation, a line
  // and a triangle skipped, an element listed twice (two physical groups) kept once.
  test::writeBytes(dir.file("ok.msh"),
                   kHeader22 + "$Nodes\n4\n10 0 0 0\n20 1 0 0\n30 0 1 0\n1000000 0 0 1\n$EndNodes\n"
                               "$Elements\n5\n1 1 2 5 1 10 20\n2 2 2 5 1 10 20 30\n3 4 2 6 1 20 10 30 1000000\n"
                               "3 4 2 8 1 20 10 30 1000000\n4 15 2 5 1 10\n$EndElements\n");
  const TetMesh ok = readMesh(dir.file("ok.msh"));
  ASSERT_EQ(ok.numTets(), 1u);
  EXPECT_EQ(ok.materials, std::vector<int32_t>{6});
  EXPECT_GT(ok.tetVolume(0), 0.0);
  EXPECT_EQ(ok.numPoints(), 4u);

  refused("$NOD\n1\n1 0 0 0\n$ENDNOD\n", {"not a Gmsh MSH file", "$MeshFormat"});
  refused("$MeshFormat\n4 0 8\n$EndMeshFormat\n", {"MSH version 4 is not read", "2.2 and 4.1"});
  refused("$MeshFormat\n3.0 0 8\n$EndMeshFormat\n", {"MSH version 3.0"});
  refused(kHeader22 + kNodes22 + "$Elements\n1\n1 5 2 1 1 1 2 3 4 5 1 2 3\n$EndElements\n",
          {"h.msh, line 14", "($Elements)", "8-node hexahedron", "type 5"});
  refused(kHeader22 + kNodes22 + "$Elements\n1\n1 4 2 1 1 1 2 3 9\n$EndElements\n",
          {"element 1 refers to node 9", "does not hold"});
  refused(kHeader22 + "$Elements\n1\n1 4 2 1 1 1 2 3 4\n$EndElements\n" + kNodes22, {"$Elements comes before $Nodes"});
  refused(kHeader22 + kNodes22 + "$Elements\n2\n1 4 2 1 1 1 2 3 4\n", {"ends inside the section", "truncated"});
  refused(kHeader22 + "$Nodes\n99999999\n1 0 0 0\n$EndNodes\n", {"99999999 nodes", "more than the rest of the file"});
  refused(kHeader22 + "$Nodes\n2\n1 0 0 0\n1 1 1 1\n$EndNodes\n", {"node tag 1 appears twice"});
  refused(kHeader22 + "$Nodes\n1\n1 0 zero 0\n$EndNodes\n", {"expected a number y coordinate", "'zero'"});
  refused(kHeader22 + "$Comments\nno end\n", {"$Comments has no $EndComments"});
  refused(kHeader22 + kNodes22 + "$Elements\n1\n1 99 2 1 1 1 2 3 4\n$EndElements\n", {"unknown element type 99"});
  refused("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PartitionedEntities\n$EndPartitionedEntities\n",
          {"partitioned MSH files are not read"});
  refused("$MeshFormat\n2.2 1 4\n", {"data size 4"});
  refused("$MeshFormat\n2.2 1 8\n\x02\x00", {"truncated"});
}

// Damaged copies of valid files (truncated anywhere, bytes flipped) are refused with InputError
// or read as some valid mesh; nothing else may happen.
TEST(GmshIO, DamagedFilesAreRefusedCleanly) {
  TempDir dir;
  const TetMesh m = randomLabelledMesh(3);
  std::mt19937 rng(17);
  for (MeshFormat f : kVariants) {
    writeMesh(dir.file("good.msh"), m, f);
    const std::string good = readText(dir.file("good.msh"));
    int refusedCount = 0;
    for (int trial = 0; trial < 60; ++trial) {
      std::string bad = good;
      if (trial % 2 == 0) {
        bad.resize(rng() % bad.size());
      } else {
        for (int k = 0; k < 4; ++k) bad[rng() % bad.size()] = char(rng() % 256);
      }
      test::writeBytes(dir.file("bad.msh"), bad);
      try {
        const TetMesh r = readMesh(dir.file("bad.msh"));
        for (const auto& q : r.tets)
          for (int32_t v : q) ASSERT_TRUE(v >= 0 && size_t(v) < r.numPoints());
      } catch (const InputError&) {
        ++refusedCount;
      }
    }
    EXPECT_GE(refusedCount, 30) << meshFormatName(f); // every truncation, at least
  }
}

TEST(GmshIO, NamesWithQuotesAreStorable) {
  TempDir dir;
  TetMesh m = randomLabelledMesh(2);
  m.materialNames[1] = "say \"hi\"\nthere";
  writeMesh(dir.file("q.msh"), m, MeshFormat::Gmsh22);
  const TetMesh back = readMesh(dir.file("q.msh"));
  EXPECT_EQ(back.materialNames.at(1), "say 'hi' there");
}

} // namespace
} // namespace tetflow
