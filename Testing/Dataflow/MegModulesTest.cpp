// The MEG modules in a network: ComputeMegLeadField against AssembleFEMPoisson + ComputeMEG direct
// solves on a small four-layer head, ComputeMEG against Sarvas, and their errors.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>

#include "Algorithms/IO/FileUtil.h"
#include "Dataflow/Executor.h"
#include "Modules/StandardModules.h"
#include "Fixtures/PhantomNet.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {
const char* kMegSigma = "1:0.33; 2:0.0042; 3:1.79; 4:0.33";

// Small head phantom (radii 20/17/14/12 mm, 1 mm voxels, 3 mm lattice).
void addSmallHead(Network& net) { test::addHeadPipeline(net, "20 17 14 12", 1.0, 3.0); }

// Sensors 6 mm outside the small head: radial and tangential magnetometers, one gradiometer.
std::string sensorCsv() {
  std::ostringstream s;
  s << "name x y z nx ny nz weight\n";
  for (int i = 0; i < 8; ++i) {
    const double z = 1 - (i + 0.5) / 8 * 1.2, rho = std::sqrt(1 - z * z), phi = 2.399963 * i, r = 26;
    const double d[3] = {rho * std::cos(phi), rho * std::sin(phi), z};
    s << "M" << i << " " << r * d[0] << " " << r * d[1] << " " << r * d[2] << " " << d[0] << " " << d[1] << " " << d[2] << "\n";
    s << "T" << i << " " << r * d[0] << " " << r * d[1] << " " << r * d[2] << " " << -d[1] << " " << d[0] << " 0\n";
  }
  s << "G 0 5 26 0 0 1 1\nG 0 5 36 0 0 1 -1\n";
  return s.str();
}

const Eigen::MatrixXd& matrixOut(Executor& exec, const std::string& id) {
  return *dynamic_cast<const DenseMatrixData&>(*exec.state(id)->outputs.at(0)).value;
}
// The small head with sensorCsv() (sensors.txt in dir), ComputeMegLeadField "lf" of `sources`
// (written to src.csv in dir) on it, and for each
// source s and axis k the direct solve "d<s><k>" (AssembleFEMPoisson) with ComputeMEG "b<s><k>",
// all with source model `model` and a 1e-12 tolerance.
void addLeadFieldAndDirectSolves(Network& net, const test::TempDir& dir, const std::vector<Vec3>& sources,
                                 const char* model) {
  std::ostringstream csv;
  csv << "x,y,z\n";
  for (const Vec3& x : sources) csv << x[0] << "," << x[1] << "," << x[2] << "\n";
  test::writeBytes(dir.file("src.csv"), csv.str());
  test::writeBytes(dir.file("sensors.txt"), sensorCsv());
  addSmallHead(net);
  net.addModule("ComputeMegLeadField", "lf");
  net.setParameterText("lf", "conductivities", kMegSigma);
  net.setParameterText("lf", "sensors_file", dir.file("sensors.txt"));
  net.setParameterText("lf", "sources_file", dir.file("src.csv"));
  net.setParameterText("lf", "tolerance", "1e-12");
  net.setParameterText("lf", "source_model", model);
  net.connect("cl", 0, "lf", 0);
  const char* axes[] = {"1 0 0", "0 1 0", "0 0 1"};
  for (size_t s = 0; s < sources.size(); ++s)
    for (int k = 0; k < 3; ++k) {
      std::ostringstream at, fem, meg;
      at << sources[s][0] << " " << sources[s][1] << " " << sources[s][2];
      fem << 'd' << s << k;
      meg << 'b' << s << k;
      const std::string pos = at.str(), id = fem.str(), mid = meg.str();
      net.addModule("AssembleFEMPoisson", id);
      net.setParameterText(id, "conductivities", kMegSigma);
      net.setParameterText(id, "boundary_condition", "dipole");
      net.setParameterText(id, "dipole_position", pos);
      net.setParameterText(id, "dipole_moment", axes[k]);
      net.setParameterText(id, "tolerance", "1e-12");
      net.setParameterText(id, "condition_numbers", "false");
      net.setParameterText(id, "source_model", model);
      net.connect("cl", 0, id, 0);
      net.addModule("ComputeMEG", mid);
      net.setParameterText(mid, "conductivities", kMegSigma);
      net.setParameterText(mid, "sensors_file", dir.file("sensors.txt"));
      net.setParameterText(mid, "dipole_position", pos);
      net.setParameterText(mid, "dipole_moment", axes[k]);
      net.connect(id, 0, mid, 0);
    }
}
} // namespace

TEST(MegModules, LeadFieldEqualsDirectSolvesAndComputeMEG) {
  test::TempDir dir;
  ModuleRegistry reg;
  registerStandardModules(reg);
  Network net(reg);
  addLeadFieldAndDirectSolves(net, dir, {{0, 0, 5}, {4, -3, 2}, {-6, 2, -4}}, "partial_integration");
  net.setParameterText("lf", "filename", dir.file("lf.npy"));
  Executor exec;
  const auto sum = exec.execute(net);
  ASSERT_TRUE(sum.success) << exec.state("lf")->error << exec.state("b00")->error;
  const Eigen::MatrixXd& L = matrixOut(exec, "lf");
  ASSERT_EQ(L.rows(), 17);
  ASSERT_EQ(L.cols(), 9);
  EXPECT_EQ(exec.state("lf")->report.number("solves"), 17);
  EXPECT_EQ(exec.state("lf")->report.number("coils"), 18);
  double worst = 0;
  for (int s = 0; s < 3; ++s)
    for (int k = 0; k < 3; ++k) {
      char mid[32];
      std::snprintf(mid, sizeof mid, "b%d%d", s, k);
      const Eigen::MatrixXd& B = matrixOut(exec, mid);
      ASSERT_EQ(B.rows(), 17);
      ASSERT_EQ(B.cols(), 3);
      EXPECT_LT((B.col(0) - B.col(1) - B.col(2)).norm(), 1e-12 * B.norm());
      worst = std::max(worst, (L.col(3 * s + k) - B.col(0)).norm() / B.col(2).norm());
      // The report compares with Sarvas (accuracy: Testing/Algorithms/FEM/MegTest.cpp), except for
      // the dipole at (0, 0, 5) along z, which is radial: no field outside, no RDM.
      const Report& rep = exec.state(mid)->report;
      EXPECT_EQ(rep.has("rdm"), !(s == 0 && k == 2)) << mid;
      if (rep.has("rdm")) {
        EXPECT_GT(rep.number("rdm"), 0.0);
      }
    }
  EXPECT_LT(worst, 1e-7);
  // The .npy: shape (17, 3, 3), data after the 64-byte aligned header.
  const auto bytes = readFileBytes(dir.file("lf.npy"));
  const std::string head(bytes.begin(), bytes.begin() + 128);
  EXPECT_NE(head.find("'shape': (17, 3, 3)"), std::string::npos);
  const size_t off = bytes.size() - 17 * 9 * 8;
  EXPECT_EQ(off % 64, 0u);
  double v;
  std::memcpy(&v, bytes.data() + off + 8 * (9 * 4 + 3 * 1 + 2), 8);
  EXPECT_EQ(v, L(4, 5));
  EXPECT_FALSE(readFileBytes(dir.file("lf.npy.sensors.csv")).empty());
}

// The MEG lead field with source_model venant equals ComputeMEG on direct Venant solves.
TEST(MegModules, VenantLeadFieldEqualsDirectVenantSolves) {
  test::TempDir dir;
  ModuleRegistry reg;
  registerStandardModules(reg);
  Network net(reg);
  addLeadFieldAndDirectSolves(net, dir, {{4, -3, 2}, {-6, 2, -4}}, "venant");
  Executor exec;
  ASSERT_TRUE(exec.execute(net).success) << exec.state("lf")->error;
  const Eigen::MatrixXd& L = matrixOut(exec, "lf");
  double worst = 0;
  for (int s = 0; s < 2; ++s)
    for (int k = 0; k < 3; ++k) {
      char mid[32];
      std::snprintf(mid, sizeof mid, "b%d%d", s, k);
      const Eigen::MatrixXd& B = matrixOut(exec, mid);
      worst = std::max(worst, (L.col(3 * s + k) - B.col(0)).norm() / B.col(2).norm());
    }
  EXPECT_LT(worst, 1e-7);
}

TEST(MegModules, ErrorsNameTheSensorFileAndTheMissingPotential) {
  test::TempDir dir;
  test::writeBytes(dir.file("bad.csv"), "A 0 0 30 0 0 1\nB 0 0 30 0 0\n");
  ModuleRegistry reg;
  registerStandardModules(reg);
  Network net(reg);
  addSmallHead(net);
  net.addModule("ComputeMegLeadField", "lf");
  net.setParameterText("lf", "sensors_file", dir.file("bad.csv"));
  net.setParameterText("lf", "source_labels", "4");
  net.connect("cl", 0, "lf", 0);
  net.addModule("ComputeMEG", "meg");
  test::writeBytes(dir.file("good.csv"), "A 0 0 30 0 0 1\n");
  net.setParameterText("meg", "sensors_file", dir.file("good.csv"));
  net.connect("cl", 0, "meg", 0);
  Executor exec;
  const auto sum = exec.execute(net);
  EXPECT_FALSE(sum.success);
  const std::string e1 = exec.state("lf")->error, e2 = exec.state("meg")->error;
  EXPECT_NE(e1.find(dir.file("bad.csv") + ", line 2: expected 7 or 8 fields"), std::string::npos) << e1;
  EXPECT_NE(e2.find("no point field 'potential'"), std::string::npos) << e2;
}

// A potential solved with the subtraction model is refused by ComputeMEG (its volume currents
// would need the singular part's), and the MEG lead field does not offer subtraction.
TEST(MegModules, SubtractionPotentialsAreRefusedByName) {
  test::TempDir dir;
  test::writeBytes(dir.file("s.csv"), "A 0 0 30 0 0 1\n");
  ModuleRegistry reg;
  registerStandardModules(reg);
  Network net(reg);
  addSmallHead(net);
  net.addModule("AssembleFEMPoisson", "fem");
  net.setParameterText("fem", "conductivities", kMegSigma);
  net.setParameterText("fem", "conductivity_by_name", "false");
  net.setParameterText("fem", "boundary_condition", "dipole");
  net.setParameterText("fem", "dipole_position", "0 0 5");
  net.setParameterText("fem", "source_model", "subtraction");
  net.setParameterText("fem", "condition_numbers", "false");
  net.connect("cl", 0, "fem", 0);
  net.addModule("ComputeMEG", "meg");
  net.setParameterText("meg", "sensors_file", dir.file("s.csv"));
  net.setParameterText("meg", "dipole_position", "0 0 5");
  net.connect("fem", 0, "meg", 0);
  Executor exec;
  EXPECT_FALSE(exec.execute(net).success);
  EXPECT_EQ(exec.state("fem")->status, ModuleStatus::Done) << exec.state("fem")->error;
  const std::string e = exec.state("meg")->error;
  EXPECT_NE(e.find("source_model subtraction (point field singular_potential)"), std::string::npos) << e;
  net.addModule("ComputeMegLeadField", "mlf");
  EXPECT_THROW(net.setParameterText("mlf", "source_model", "subtraction"), InputError);
  net.addModule("ComputeLeadField", "lf");
  EXPECT_NO_THROW(net.setParameterText("lf", "source_model", "subtraction"));
}
