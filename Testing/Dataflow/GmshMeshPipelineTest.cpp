// A mesh made by another tool goes through TetFlow's modules: Gmsh (Debian's gmsh, which
// scripts/setup.sh installs) meshes a box holding a ball, and ReadMesh -> EvaluateQuality (quality
// only: there are no voxels to certify against) -> AssembleFEMPoisson (electrodes along x) runs on
// its MSH file, for each MSH variant Gmsh writes.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "Dataflow/Executor.h"
#include "TestModules.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {

using tetflow::test::readText;

TEST(GmshMeshPipeline, ReadCheckedAndSolvedOn) {
  ASSERT_EQ(std::system("command -v gmsh > /dev/null 2>&1"), 0)
      << "gmsh is missing: scripts/setup.sh installs it (Debian package gmsh)";
  test::TempDir dir;
  test::writeBytes(dir.file("ball.geo"), R"(SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 10, 10, 10};
Sphere(2) = {5, 5, 5, 3};
BooleanFragments{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Physical Volume("brain", 7) = {2};
Physical Volume("scalp", 3) = {3};
Mesh.MeshSizeMax = 1.5;
)");
  ModuleRegistry reg;
  test::registerTestModules(reg);
  double firstResistance = 0;
  for (const char* options : {"-format msh22", "-bin -format msh22", "-format msh41", "-bin -format msh41"}) {
    SCOPED_TRACE(options);
    const std::string mesh = dir.file("ball.msh"), log = dir.file("gmsh.log");
    ASSERT_EQ(std::system(("gmsh '" + dir.file("ball.geo") + "' -3 " + options + " -o '" + mesh + "' > '" + log +
                           "' 2>&1")
                              .c_str()),
              0)
        << readText(log);
    Network net(reg);
    const auto read = net.addModule("ReadMesh");
    net.setParameterText(read, "filename", mesh);
    const auto quality = net.addModule("EvaluateQuality");
    const auto fem = net.addModule("AssembleFEMPoisson");
    net.setParameterText(fem, "boundary_condition", "electrodes");
    net.setParameterText(fem, "conductivities", "3:1; 7:1");
    net.connect(read, 0, quality, 0);
    net.connect(read, 0, fem, 0);
    Executor exec;
    const auto sum = exec.execute(net);
    ASSERT_TRUE(sum.success) << exec.state(read)->error << exec.state(quality)->error << exec.state(fem)->error;

    EXPECT_EQ(std::get<std::string>(*exec.state(read)->report.find("material_names")), "3 scalp; 7 brain");
    const Report& q = exec.state(quality)->report;
    EXPECT_EQ(std::get<std::string>(*q.find("material_7_name")), "brain");
    EXPECT_EQ(std::get<bool>(*q.find("valid")), true);
    EXPECT_EQ(std::get<bool>(*q.find("boundary_closed")), true);
    EXPECT_EQ(q.number("inverted"), 0);
    EXPECT_EQ(q.number("nonmanifold_faces"), 0);
    EXPECT_NEAR(q.number("volume_mm3"), 1000.0, 1e-9);
    EXPECT_GT(q.number("min_dihedral_deg"), 0.0);

    // One conductivity everywhere: the ball changes nothing, and the box conducts like a slab.
    // The electrodes are the boundary within 5 % of the extent at x = 0 and x = 10 (0.5 mm up the
    // sides), so the resistance lies between the slab's 9 mm and 10 mm ones: L / (sigma A) with
    // A = 100 mm^2 and sigma = 1 S/m = 1e-3 S/mm, in kOhm (V / mA).
    const Report& f = exec.state(fem)->report;
    EXPECT_EQ(std::get<bool>(*f.find("converged")), true);
    EXPECT_EQ(std::get<std::string>(*f.find("materials")), "3 7");
    EXPECT_GE(f.number("potential_min"), -1e-9);
    EXPECT_LE(f.number("potential_max"), 1 + 1e-9);
    const double R = f.number("resistance");
    EXPECT_GT(R, 9.0 / (1e-3 * 100) * 1e-3);
    EXPECT_LT(R, 10.0 / (1e-3 * 100) * 1e-3);
    // Every variant holds the same mesh: the same answer.
    if (firstResistance == 0) firstResistance = R;
    EXPECT_NEAR(R, firstResistance, 1e-9 * R);
  }
}

} // namespace
