// The materials' names and conductivities through every mesh format that carries them: .vtu and
// .vtk (field data: one integer array per name holding (label, 3), as meshio files Gmsh's
// physical groups, and "material_conductivities"), and .msh (physical names); meshio (Debian's
// python3-meshio) sees the names of a .vtu.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "Algorithms/IO/MeshIO.h"
#include "TestUtil.h"

namespace tetflow {
namespace {

TetMesh namedMesh() {
  TetMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  m.tets = {{0, 1, 2, 3}, {1, 2, 3, 4}};
  if (m.tetVolume(1) < 0) std::swap(m.tets[1][0], m.tets[1][1]);
  m.materials = {3, 5};
  m.materialNames = {{3, "grey matter"}, {5, "CSF & <fluid> \"x\""}};
  m.materialConductivities = {{3, 0.275}, {5, 1.654}};
  return m;
}

TEST(MaterialNamesIO, VtuAndVtkCarryNamesAndConductivities) {
  test::TempDir dir;
  const TetMesh m = namedMesh();
  for (const char* name : {"m.vtu", "m.vtk"}) {
    SCOPED_TRACE(name);
    writeMesh(dir.file(name), m);
    const TetMesh back = readMesh(dir.file(name));
    EXPECT_EQ(back.materialNames, m.materialNames);
    EXPECT_EQ(back.materialConductivities, m.materialConductivities);
    EXPECT_EQ(back.materials, m.materials);
    EXPECT_TRUE(back.cellFields.empty()); // field data are not cell fields
  }
  // Gmsh: names only, a double quote stored as a single one (MSH quotes its names).
  writeMesh(dir.file("m.msh"), m, MeshFormat::Gmsh22);
  EXPECT_EQ(readMesh(dir.file("m.msh")).materialNames,
            (std::map<int32_t, std::string>{{3, "grey matter"}, {5, "CSF & <fluid> 'x'"}}));
}

TEST(MaterialNamesIO, ANameGivenToTwoLabelsKeepsBoth) {
  test::TempDir dir;
  TetMesh m = namedMesh();
  m.materialNames = {{3, "bone"}, {5, "bone"}};
  m.materialConductivities.clear();
  writeMesh(dir.file("m.vtu"), m);
  EXPECT_EQ(readMesh(dir.file("m.vtu")).materialNames, m.materialNames);
}

TEST(MaterialNamesIO, MeshioReadsTheNamesOfAVtu) {
  ASSERT_EQ(std::system("/usr/bin/python3 -c 'import meshio' > /dev/null 2>&1"), 0)
      << "meshio is missing: scripts/setup.sh installs it (Debian package python3-meshio)";
  test::TempDir dir;
  writeMesh(dir.file("m.vtu"), namedMesh());
  const std::string out = dir.file("out.txt");
  const std::string cmd = "/usr/bin/python3 -c \"import meshio; m = meshio.read('" + dir.file("m.vtu") +
                          "'); print(len(m.points), sum(len(c.data) for c in m.cells)); "
                          "[print(k, *v.ravel().tolist()) for k, v in sorted(m.field_data.items())]\" > '" +
                          out + "' 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream in(out);
  std::stringstream s;
  s << in.rdbuf();
  EXPECT_EQ(s.str(), "5 2\nCSF & <fluid> \"x\" 5 3\ngrey matter 3 3\nmaterial_conductivities 3.0 0.275 5.0 1.654\n");
}

} // namespace
} // namespace tetflow
