// The EEG forward problem as modules: FEM dipole potentials against the analytic four-shell sphere
// (AnalyticSphereEEG), lead fields by reciprocity (ComputeLeadField) against direct dipole solves.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <sys/wait.h>

#include "Algorithms/FEM/Petsc/PetscLinearSolver.h"
#include "Algorithms/IO/FileUtil.h"
#include "Dataflow/Executor.h"
#include "Dataflow/NetworkFile.h"
#include "Modules/StandardModules.h"
#include "Fixtures/PhantomNet.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {
const char* kSigma = "1:0.33; 2:0.0042; 3:1.79; 4:0.33";

// Head phantom (scalp 1, skull 2, CSF 3, brain 4) -> regular BCC lattice -> CleaveMesh.
void addHead(Network& net, const std::string& radii, double voxel, double cell) {
  test::addHeadPipeline(net, radii, voxel, cell);
}

void addDipole(Network& net, const std::string& id, const std::string& pos, const std::string& moment) {
  net.addModule("AssembleFEMPoisson", id);
  net.setParameterText(id, "conductivities", kSigma);
  net.setParameterText(id, "boundary_condition", "dipole");
  net.setParameterText(id, "dipole_position", pos);
  net.setParameterText(id, "dipole_moment", moment);
  net.setParameterText(id, "estimate_condition", "false");
  net.connect("cl", 0, id, 0);
}

struct SphereErrors {
  double rdm, lnMag;
};

// FEM on the head phantom (78/80/86/92 mm, 2 mm voxels) at lattice `cell`, radial and tangential
// dipoles at (0, 0, 40) mm, against the analytic series at every scalp vertex.
std::vector<SphereErrors> sphereErrors(double cell) {
  ModuleRegistry reg;
  registerStandardModules(reg);
  Network net(reg);
  addHead(net, "92 86 80 78", 2.0, cell);
  net.setParameterText("cl", "blend_sigma", "1"); // as Nets/head_dipole.srn and eeg_leadfield.srn
  const std::pair<const char*, const char*> dipoles[] = {{"radial", "0 0 0.01"}, {"tangential", "0.01 0 0"}};
  for (const auto& [name, moment] : dipoles) {
    addDipole(net, std::string("fem_") + name, "0 0 40", moment);
    net.addModule("AnalyticSphereEEG", std::string("an_") + name);
    net.setParameterText(std::string("an_") + name, "dipole_position", "0 0 40");
    net.setParameterText(std::string("an_") + name, "dipole_moment", moment);
    net.connect(std::string("fem_") + name, 0, std::string("an_") + name, 0);
  }
  Executor exec;
  const auto sum = exec.execute(net);
  EXPECT_TRUE(sum.success);
  std::vector<SphereErrors> out;
  for (const auto& [name, moment] : dipoles) {
    const Report& r = exec.state(std::string("an_") + name)->report;
    EXPECT_GT(r.number("electrodes"), 1000);
    out.push_back({r.number("rdm"), r.number("ln_mag")});
    std::printf("lattice %g mm, %s dipole: RDM %.4f, lnMAG %.4f (%g electrodes)\n", cell, name, r.number("rdm"),
                r.number("ln_mag"), r.number("electrodes"));
  }
  return out;
}

// Electrodes on a sphere of radius r (fixed directions, a few mm off the surface), as CSV.
std::string electrodeCsv(double r, int n) {
  std::ostringstream s;
  s << "name,x,y,z\n";
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - 1.6 * (i + 0.5) / n; // upper part of the head
    const double rho = std::sqrt(1 - z * z), phi = 2.399963 * i;
    s << "E" << i + 1 << "," << r * rho * std::cos(phi) << "," << r * rho * std::sin(phi) << "," << r * z << "\n";
  }
  return s.str();
}

std::vector<int32_t> snappedVertices(const std::string& sidecar) {
  std::ifstream in(sidecar);
  std::string line;
  std::getline(in, line); // header
  std::vector<int32_t> v;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string f;
    for (int i = 0; i < 5 && std::getline(s, f, ','); ++i)
      if (i == 4) v.push_back(std::stoi(f));
  }
  return v;
}

std::string dipoleId(int s, int k) { // "d<s><k>" (no "d" + to_string: GCC 12 -Wrestrict)
  char id[16];
  std::snprintf(id, sizeof id, "d%d%d", s, k);
  return id;
}

const Eigen::MatrixXd& leadField(Executor& exec, const std::string& id) {
  return *dynamic_cast<const DenseMatrixData&>(*exec.state(id)->outputs.at(0)).value;
}
} // namespace

// Measured (this VM; blend_sigma 1, regular BCC): 4 mm RDM 0.029 / 0.036, lnMAG 0.131 / 0.141
// (radial / tangential); 3 mm RDM 0.013 / 0.018, lnMAG 0.090 / 0.091. Bounds: the measured values
// plus ~20 %; both errors must fall from 4 mm to 3 mm. (|lnMAG| <= 0.05 at 3 mm, the issue's
// target, is not met: README "Validation against the four-shell sphere".)
// A study (Testing/Tiers.cmake): the 4 mm and the 3 mm lattices.
TEST(EegForward, FourShellSphereErrorsFallWithTheLattice) {
  const auto e4 = sphereErrors(4.0);
  const auto e3 = sphereErrors(3.0);
  ASSERT_EQ(e4.size(), 2u);
  ASSERT_EQ(e3.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    SCOPED_TRACE(i == 0 ? "radial" : "tangential");
    EXPECT_LT(e3[i].rdm, e4[i].rdm);
    EXPECT_LT(std::abs(e3[i].lnMag), std::abs(e4[i].lnMag));
    EXPECT_LE(e3[i].rdm, 0.022);
    EXPECT_LE(std::abs(e3[i].lnMag), 0.11);
    EXPECT_LE(e4[i].rdm, 0.044);
    EXPECT_LE(std::abs(e4[i].lnMag), 0.17);
  }
}

// In CI: the 4 mm lattice's bounds.
TEST(EegForward, FourShellSphereErrorsAtA4mmLatticeStayWithinTheirBounds) {
  const auto e4 = sphereErrors(4.0);
  ASSERT_EQ(e4.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    SCOPED_TRACE(i == 0 ? "radial" : "tangential");
    EXPECT_LE(e4[i].rdm, 0.044);
    EXPECT_LE(std::abs(e4[i].lnMag), 0.17);
  }
}

// The St. Venant source model (source_model venant) against partial integration on a coarse
// lattice refined at the thin layers (GenerateBackgroundMesh's default; blend_sigma 1 as
// sphere_validation.sh), a dipole at eccentricity 0.77: Venant's topography error is a fraction
// of partial integration's, and its magnitude no worse (README "Source models").
namespace {
void expectVenantBeatsPartialIntegration(const std::string& radii, double cell, const std::string& position) {
  ModuleRegistry reg;
  registerStandardModules(reg);
  Network net(reg);
  addHead(net, radii, 2.0, cell);
  net.setParameterText("bg", "refine_thin_layers", "separating");
  net.setParameterText("cl", "blend_sigma", "1");
  const std::pair<const char*, const char*> dipoles[] = {{"radial", "0 0 0.01"}, {"tangential", "0.01 0 0"}};
  for (const auto& [name, moment] : dipoles)
    for (const char* model : {"partial_integration", "venant"}) {
      const std::string f = std::string("fem_") + model + "_" + name, a = std::string("an_") + model + "_" + name;
      addDipole(net, f, position, moment);
      net.setParameterText(f, "source_model", model);
      net.addModule("AnalyticSphereEEG", a);
      net.setParameterText(a, "dipole_position", position);
      net.setParameterText(a, "dipole_moment", moment);
      net.connect(f, 0, a, 0);
    }
  Executor exec;
  ASSERT_TRUE(exec.execute(net).success);
  for (const auto& [name, moment] : dipoles) {
    SCOPED_TRACE(name);
    const Report& pi = exec.state(std::string("an_partial_integration_") + name)->report;
    const Report& ve = exec.state(std::string("an_venant_") + name)->report;
    std::printf("%g mm lattice, head %s, %s dipole at (%s) mm: partial integration RDM %.4f lnMAG %+.4f, Venant RDM "
                "%.4f lnMAG %+.4f\n",
                cell, radii.c_str(), name, position.c_str(), pi.number("rdm"), pi.number("ln_mag"), ve.number("rdm"),
                ve.number("ln_mag"));
    EXPECT_LT(ve.number("rdm"), 0.5 * pi.number("rdm"));
    EXPECT_LT(std::abs(ve.number("ln_mag")), std::abs(pi.number("ln_mag")) + 0.01);
  }
}
} // namespace

// The 92 mm head on a 5 mm lattice, the dipole at z = 60 mm (measured RDM 0.035 / 0.035 -> 0.008 /
// 0.007, radial / tangential). A smaller head on 2 mm voxels is no smaller version of this: its
// voxel staircase dominates both models' errors (lnMAG +0.4 at brain radius 46 mm).
TEST(EegForward, VenantBeatsPartialIntegrationAtHighEccentricity) {
  expectVenantBeatsPartialIntegration("92 86 80 78", 5.0, "0 0 60");
}

// Reciprocity holds for the St. Venant source model too: ComputeLeadField with source_model venant
// equals AssembleFEMPoisson's direct Venant solves at the electrodes.
// Reciprocity for the other source models: the lead field of ComputeLeadField equals direct
// AssembleFEMPoisson solves with the same model (Venant: the loads of unit moments; subtraction:
// the singular potential's difference plus the correction's loads against each electrode's
// solution).
// With `solver` = cholesky both the lead field and the direct solves factorise (AssembleFEMPoisson
// once per dipole, ComputeLeadField once for every electrode).
static void leadFieldEqualsDirectSolves(const char* model, const char* solver = "minres",
                                        const char* preconditioner = "jacobi", const char* backend = "eigen") {
  test::TempDir dir;
  test::writeBytes(dir.file("el.csv"), electrodeCsv(20.5, 12));
  const char* sources[] = {"0 0 5", "4 -3 2", "-6 2 -4"};
  test::writeBytes(dir.file("src.csv"), "x,y,z\n0,0,5\n4,-3,2\n-6,2,-4\n");
  ModuleRegistry reg;
  registerStandardModules(reg);
  Network net(reg);
  addHead(net, "20 17 14 12", 1.0, 3.0);
  net.addModule("ComputeLeadField", "lf");
  net.setParameterText("lf", "conductivities", kSigma);
  net.setParameterText("lf", "electrodes_file", dir.file("el.csv"));
  net.setParameterText("lf", "sources_file", dir.file("src.csv"));
  net.setParameterText("lf", "tolerance", "1e-12");
  net.setParameterText("lf", "source_model", model);
  net.setParameterText("lf", "solver", solver);
  net.setParameterText("lf", "preconditioner", preconditioner);
  net.setParameterText("lf", "solver_backend", backend);
  net.setParameterText("lf", "filename", dir.file("lf.npy"));
  net.connect("cl", 0, "lf", 0);
  const char* axes[] = {"1 0 0", "0 1 0", "0 0 1"};
  for (int s = 0; s < 3; ++s)
    for (int k = 0; k < 3; ++k) {
      const std::string id = dipoleId(s, k);
      addDipole(net, id, sources[s], axes[k]);
      net.setParameterText(id, "tolerance", "1e-12");
      net.setParameterText(id, "source_model", model);
      net.setParameterText(id, "solver", solver);
      net.setParameterText(id, "preconditioner", preconditioner);
      net.setParameterText(id, "solver_backend", backend);
    }
  Executor exec;
  ASSERT_TRUE(exec.execute(net).success) << exec.state("lf")->error;
  EXPECT_EQ(std::get<std::string>(*exec.state("lf")->report.find("source_model")), model);
  EXPECT_EQ(std::get<std::string>(*exec.state("lf")->report.find("solver")), solver);
  if (std::string(solver) == "cholesky") {
    EXPECT_GT(exec.state("lf")->report.number("setup_seconds"), 0.0);
    EXPECT_EQ(exec.state("lf")->report.number("iterations_total"), 0);
    EXPECT_EQ(exec.state("lf")->report.number("solves"), 11);
  }
  const Eigen::MatrixXd& L = leadField(exec, "lf");
  const std::vector<int32_t> vertex = snappedVertices(dir.file("lf.npy.electrodes.csv"));
  ASSERT_EQ(vertex.size(), 12u);
  double worst = 0, largest = 0;
  for (int s = 0; s < 3; ++s)
    for (int k = 0; k < 3; ++k) {
      const TetMesh& m = dynamic_cast<const TetMeshData&>(*exec.state(dipoleId(s, k))->outputs.at(0)).value;
      const auto& u = m.pointFields.at("potential").values;
      Eigen::VectorXd direct(12);
      for (int e = 0; e < 12; ++e) direct[e] = u[size_t(vertex[size_t(e)])];
      direct.array() -= direct.mean();
      worst = std::max(worst, (L.col(3 * s + k) - direct).norm() / direct.norm());
      largest = std::max(largest, direct.norm());
    }
  EXPECT_GT(largest, 0.0);
  EXPECT_LT(worst, 1e-7) << model << " lead field vs direct solves, largest relative difference";
}

TEST(EegForward, VenantLeadFieldEqualsDirectVenantSolves) { leadFieldEqualsDirectSolves("venant"); }

TEST(EegForward, SubtractionLeadFieldEqualsDirectSubtractionSolves) { leadFieldEqualsDirectSolves("subtraction"); }

TEST(EegForward, CholeskyLeadFieldsEqualDirectCholeskySolvesForEverySourceModel) {
  for (const char* model : {"partial_integration", "venant", "subtraction"}) leadFieldEqualsDirectSolves(model, "cholesky");
}

// CG + BoomerAMG (PETSc, one process; what auto picks for large systems) passes the same
// reciprocity checks: lead field = direct solves of the same method, every source model.
TEST(EegForward, AmgLeadFieldsEqualDirectAmgSolvesForEverySourceModel) {
  if (!petscAvailable()) GTEST_SKIP() << "built without PETSc";
  for (const char* model : {"partial_integration", "venant", "subtraction"})
    leadFieldEqualsDirectSolves(model, "cg", "hypre", "petsc");
}

// The node editor's re-run (issue 49 item 5): a dipole moved on an unchanged head re-runs only
// its module, and its solve takes the Cholesky factor kept from the first run; the lead field
// beside it (auto: cholesky here) keeps its own factor too. The dipole's 0 V reference is the
// boundary vertex farthest from it, part of K: this move keeps that vertex (asserted), a move
// that changes it changes K and factorises again.
TEST(EegForward, AMovedDipoleOnTheSameHeadIsSolvedWithTheKeptFactor) {
  test::TempDir dir;
  test::writeBytes(dir.file("el.csv"), electrodeCsv(20.5, 8));
  ModuleRegistry reg;
  registerStandardModules(reg);
  Network net(reg);
  addHead(net, "20 17 14 12", 1.0, 3.0);
  addDipole(net, "fem", "0 0 5", "0 0 1");
  net.setParameterText("fem", "solver", "cholesky");
  net.setParameterText("fem", "condition_numbers", "false");
  net.addModule("ComputeLeadField", "lf");
  net.setParameterText("lf", "conductivities", kSigma);
  net.setParameterText("lf", "electrodes_file", dir.file("el.csv"));
  net.setParameterText("lf", "sources_file", "");
  net.setParameterText("lf", "source_labels", "4");
  net.connect("cl", 0, "lf", 0);
  auto logged = [](const ModuleState& st, const std::string& what) {
    for (const auto& m : st.messages)
      if (m.find(what) != std::string::npos) return true;
    return false;
  };
  Executor exec;
  ASSERT_TRUE(exec.execute(net).success) << exec.state("fem")->error << exec.state("lf")->error;
  EXPECT_EQ(std::get<std::string>(*exec.state("lf")->report.find("solver")), "cholesky");
  EXPECT_EQ(std::get<std::string>(*exec.state("lf")->report.find("solver_requested")), "auto");
  EXPECT_FALSE(logged(*exec.state("fem"), "kept from an earlier solve"));
  const double v0 = exec.state("fem")->report.number("potential_max");
  const double ref0 = exec.state("fem")->report.number("reference_vertex");
  net.setParameterText("fem", "dipole_position", "0 0 3");
  ASSERT_TRUE(exec.execute(net).success) << exec.state("fem")->error;
  EXPECT_FALSE(exec.state("fem")->reused);
  EXPECT_TRUE(exec.state("lf")->reused);
  ASSERT_EQ(exec.state("fem")->report.number("reference_vertex"), ref0) << "the move changed the reference";
  EXPECT_TRUE(logged(*exec.state("fem"), "kept from an earlier solve")) << "no reuse noted";
  EXPECT_NE(exec.state("fem")->report.number("potential_max"), v0) << "the moved dipole was solved";
}

TEST(EegForward, LeadFieldEqualsDirectDipoleSolves) {
  test::TempDir dir;
  test::writeBytes(dir.file("el.csv"), electrodeCsv(20.5, 12));
  const char* sources[] = {"0 0 5", "4 -3 2", "-6 2 -4"};
  test::writeBytes(dir.file("src.csv"), "x,y,z\n0,0,5\n4,-3,2\n-6,2,-4\n");
  ModuleRegistry reg;
  registerStandardModules(reg);
  Network net(reg);
  addHead(net, "20 17 14 12", 1.0, 3.0);
  for (const char* ref : {"average", "E3"}) {
    const std::string id = std::string("lf_") + ref;
    net.addModule("ComputeLeadField", id);
    net.setParameterText(id, "conductivities", kSigma);
    net.setParameterText(id, "electrodes_file", dir.file("el.csv"));
    net.setParameterText(id, "sources_file", dir.file("src.csv"));
    net.setParameterText(id, "reference", ref);
    net.setParameterText(id, "tolerance", "1e-12");
    net.setParameterText(id, "filename", dir.file(id + ".npy"));
    net.connect("cl", 0, id, 0);
  }
  const char* axes[] = {"1 0 0", "0 1 0", "0 0 1"};
  for (int s = 0; s < 3; ++s)
    for (int k = 0; k < 3; ++k) {
      const std::string id = dipoleId(s, k);
      addDipole(net, id, sources[s], axes[k]);
      net.setParameterText(id, "tolerance", "1e-12");
    }
  Executor exec;
  const auto sum = exec.execute(net);
  ASSERT_TRUE(sum.success) << exec.state("lf_average")->error;
  const Eigen::MatrixXd& L = leadField(exec, "lf_average");
  ASSERT_EQ(L.rows(), 12);
  ASSERT_EQ(L.cols(), 9);
  const Report& rep = exec.state("lf_average")->report;
  EXPECT_EQ(rep.number("solves"), 11); // one per electrode but the ground
  EXPECT_EQ(rep.number("sources"), 3);
  EXPECT_GT(rep.number("snap_distance_max"), 0.0);
  EXPECT_LT(rep.number("snap_distance_max"), 3.0);
  const std::vector<int32_t> vertex = snappedVertices(dir.file("lf_average.npy.electrodes.csv"));
  ASSERT_EQ(vertex.size(), 12u);
  double worst = 0;
  for (int s = 0; s < 3; ++s)
    for (int k = 0; k < 3; ++k) {
      const std::string id = dipoleId(s, k);
      const TetMesh& m = dynamic_cast<const TetMeshData&>(*exec.state(id)->outputs.at(0)).value;
      const auto& u = m.pointFields.at("potential").values;
      Eigen::VectorXd direct(12);
      for (int e = 0; e < 12; ++e) direct[e] = u[size_t(vertex[size_t(e)])];
      direct.array() -= direct.mean();
      const Eigen::VectorXd col = L.col(3 * s + k);
      EXPECT_GT(col.norm(), 0.0);
      worst = std::max(worst, (col - direct).norm() / direct.norm());
    }
  EXPECT_LT(worst, 1e-7) << "lead field vs direct solves, largest relative difference";
  // Referenced to E3: row E3 is 0 and the rows differ from the average ones by E3's row.
  const Eigen::MatrixXd& L3 = leadField(exec, "lf_E3");
  EXPECT_EQ(L3.row(2).norm(), 0.0);
  Eigen::MatrixXd shifted = L.rowwise() - L.row(2);
  EXPECT_LT((L3 - shifted).norm(), 1e-9 * L.norm());
  // The .npy file: NumPy header, shape (12, 3, 3), the matrix in (electrode, source, axis) order.
  const auto bytes = readFileBytes(dir.file("lf_average.npy"));
  ASSERT_GT(bytes.size(), 10u);
  EXPECT_EQ(std::string(bytes.begin() + 1, bytes.begin() + 6), "NUMPY");
  const size_t headerLen = size_t(uint8_t(bytes[8])) | (size_t(uint8_t(bytes[9])) << 8);
  EXPECT_EQ((10 + headerLen) % 64, 0u);
  EXPECT_NE(std::string(bytes.begin() + 10, bytes.begin() + 10 + long(headerLen)).find("'shape': (12, 3, 3)"),
            std::string::npos);
  ASSERT_EQ(bytes.size(), 10 + headerLen + 12 * 9 * 8);
  for (int e = 0; e < 12; ++e)
    for (int c = 0; c < 9; ++c) {
      double v;
      std::memcpy(&v, bytes.data() + 10 + headerLen + 8 * size_t(9 * e + c), 8);
      EXPECT_EQ(v, L(e, c));
    }
}

TEST(EegForward, LeadFieldSourcesFromLabelsAndErrors) {
  test::TempDir dir;
  test::writeBytes(dir.file("el.csv"), electrodeCsv(20.5, 6));
  ModuleRegistry reg;
  registerStandardModules(reg);
  Network net(reg);
  addHead(net, "20 17 14 12", 1.0, 3.0);
  net.addModule("ComputeLeadField", "lf");
  net.setParameterText("lf", "conductivities", kSigma);
  net.setParameterText("lf", "electrodes_file", dir.file("el.csv"));
  net.setParameterText("lf", "source_labels", "4");
  net.setParameterText("lf", "filename", dir.file("lf.csv"));
  net.connect("cl", 0, "lf", 0);
  Executor exec;
  ASSERT_TRUE(exec.execute(net).success) << exec.state("lf")->error;
  const TetMesh& mesh = dynamic_cast<const TetMeshData&>(*exec.state("cl")->outputs.at(0)).value;
  int64_t brain = 0;
  for (int32_t l : mesh.materials) brain += l == 4;
  EXPECT_EQ(exec.state("lf")->report.number("sources"), brain);
  EXPECT_EQ(leadField(exec, "lf").cols(), 3 * brain);
  // Average reference: every column sums to zero.
  EXPECT_LT(leadField(exec, "lf").colwise().sum().cwiseAbs().maxCoeff(), 1e-12 * leadField(exec, "lf").norm());
  const auto text = readFileBytes(dir.file("lf.csv"));
  EXPECT_EQ(std::string(text.begin(), text.begin() + 25), "electrode,s0_x,s0_y,s0_z,");

  // Bad inputs name the culprit.
  auto fails = [&](const char* param, const std::string& value, const std::string& fragment) {
    net.setParameterText("lf", param, value);
    Executor e;
    EXPECT_FALSE(e.execute(net).success) << param;
    EXPECT_NE(e.state("lf")->error.find(fragment), std::string::npos) << e.state("lf")->error;
  };
  fails("source_labels", "9", "label 9 is not in the mesh");
  fails("source_labels", "brain", "'brain' is not an integer label");
  net.setParameterText("lf", "source_labels", "4");
  fails("reference", "Cz", "reference 'Cz' is not an electrode name");
  net.setParameterText("lf", "reference", "average");
  fails("electrodes_file", dir.file("missing.csv"), "missing.csv");
  fails("electrodes_file", "", "electrodes_file: give the electrode positions");
  net.setParameterText("lf", "electrodes_file", dir.file("el.csv"));
  fails("filename", dir.file("lf.mat"), "use .npy (binary) or .csv (text)");
  net.setParameterText("lf", "filename", "");
  fails("preconditioner", "gamg", "solver_backend = petsc");
}

// solver_backend = petsc in this process (one rank): the same iterations (within 1) and the same
// potentials as the Eigen path; CG with PETSc's AMG preconditioners converges in far fewer.
TEST(EegForward, PetscBackendMatchesEigen) {
  if (!petscAvailable()) GTEST_SKIP() << "built without PETSc (TETFLOW_WITH_PETSC=OFF): not tested";
  ModuleRegistry reg;
  registerStandardModules(reg);
  Network net(reg);
  addHead(net, "20 17 14 12", 1.0, 2.0);
  addDipole(net, "eigen", "0 0 5", "0 0 1");
  addDipole(net, "petsc", "0 0 5", "0 0 1");
  net.setParameterText("petsc", "solver_backend", "petsc");
  for (const char* pc : {"gamg", "hypre"}) {
    const std::string id = std::string("cg_") + pc;
    addDipole(net, id, "0 0 5", "0 0 1");
    net.setParameterText(id, "solver_backend", "petsc");
    net.setParameterText(id, "solver", "cg");
    net.setParameterText(id, "preconditioner", pc);
  }
  Executor exec;
  ASSERT_TRUE(exec.execute(net).success) << exec.state("petsc")->error;
  const Report& e = exec.state("eigen")->report;
  const Report& p = exec.state("petsc")->report;
  EXPECT_NEAR(p.number("iterations"), e.number("iterations"), 1.0);
  EXPECT_EQ(std::get<std::string>(*p.find("solver_backend")), "petsc");
  EXPECT_LE(p.number("relative_residual"), 1e-8);
  auto potential = [&](const char* id) {
    return dynamic_cast<const TetMeshData&>(*exec.state(id)->outputs.at(0)).value.pointFields.at("potential").values;
  };
  const auto ue = potential("eigen"), up = potential("petsc");
  double diff = 0, scale = 0;
  for (size_t i = 0; i < ue.size(); ++i) diff = std::max(diff, std::abs(ue[i] - up[i])), scale = std::max(scale, std::abs(ue[i]));
  EXPECT_LT(diff, 1e-6 * scale);
  for (const char* id : {"cg_gamg", "cg_hypre"}) {
    const Report& r = exec.state(id)->report;
    EXPECT_TRUE(std::get<bool>(*r.find("converged"))) << id;
    EXPECT_LT(r.number("iterations"), e.number("iterations") / 3) << id;
    // PETSc's CG estimates the AMG-preconditioned operator's condition: far below Jacobi's.
    const std::string method = std::get<std::string>(*r.find("kappa_lanczos_method"));
    EXPECT_NE(method.find("PETSc CG"), std::string::npos) << method;
    EXPECT_GE(r.number("kappa_lanczos"), 1.0) << id;
    EXPECT_LT(r.number("kappa_lanczos"), r.number("kappa_jacobi")) << id;
    const auto u = potential(id);
    double d = 0;
    for (size_t i = 0; i < ue.size(); ++i) d = std::max(d, std::abs(ue[i] - u[i]));
    EXPECT_LT(d, 1e-5 * scale) << id;
  }
}

#ifdef TETFLOW_MPIRUN
namespace {
tetflow::test::ShellResult shell(const std::string& cmd) { return tetflow::test::runShell(cmd + " 2>&1"); }
// OpenMPI refuses root unless told; --oversubscribe lets 2 ranks run on any core count. The
// variables of this process's own MPI (a singleton, when an in-process PETSc test ran first) are
// removed, or mpirun would take the job for a nested one.
std::string mpirun(int ranks) {
  std::string unset;
  for (char** e = environ; *e; ++e) {
    const std::string kv = *e;
    if (kv.rfind("OMPI_", 0) == 0 || kv.rfind("PMIX_", 0) == 0) unset += "-u " + kv.substr(0, kv.find('=')) + " ";
  }
  return "env " + unset + std::string("OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1 ") + TETFLOW_MPIRUN +
         " -n " + std::to_string(ranks) + " --oversubscribe --bind-to none " + TETFLOW_CLI;
}
using tetflow::test::reportNumber;
} // namespace

// `mpirun -n 2 tetflow run NET` with solver_backend = petsc: rank 0 reads, runs and writes; the
// solve is shared. Same iterations (within 1) and the same lead field as a one-process Eigen run.
TEST(EegForward, MpirunTwoRanksMatchesEigen) {
  if (!petscAvailable()) GTEST_SKIP() << "built without PETSc (TETFLOW_WITH_PETSC=OFF): not tested";
  test::TempDir dir;
  test::writeBytes(dir.file("el.csv"), electrodeCsv(20.5, 8));
  for (const char* backend : {"eigen", "petsc"}) {
    ModuleRegistry reg;
    registerStandardModules(reg);
    Network net(reg);
    addHead(net, "20 17 14 12", 1.0, 2.0);
    addDipole(net, "fem", "0 0 5", "0 0 1");
    net.setParameterText("fem", "solver_backend", backend);
    net.addModule("ComputeLeadField", "lf");
    net.setParameterText("lf", "conductivities", kSigma);
    net.setParameterText("lf", "electrodes_file", dir.file("el.csv"));
    net.setParameterText("lf", "source_labels", "4");
    net.setParameterText("lf", "solver_backend", backend);
    net.setParameterText("lf", "solver", "minres"); // the same method on both (auto would factorise on eigen)
    net.setParameterText("lf", "filename", "lf.npy");
    net.connect("cl", 0, "lf", 0);
    net.addModule("WriteMesh", "w");
    net.setParameterText("w", "filename", "fem.vtu");
    net.connect("fem", 0, "w", 0);
    saveNetwork(dir.file(std::string(backend) + ".srn"), net);
  }
  const std::string common = " --output-dir ";
  const auto e = shell(std::string(TETFLOW_CLI) + " run " + dir.file("eigen.srn") + common + dir.file("oe") +
                      " --report " + dir.file("e.json"));
  ASSERT_EQ(e.code, 0) << e.out;
  const auto p = shell(mpirun(2) + " run " + dir.file("petsc.srn") + common + dir.file("op") + " --report " +
                      dir.file("p.json"));
  ASSERT_EQ(p.code, 0) << p.out;
  // One summary line: only rank 0 reports.
  size_t summaries = 0;
  for (size_t at = p.out.find("petsc.srn: "); at != std::string::npos; at = p.out.find("petsc.srn: ", at + 1)) ++summaries;
  EXPECT_EQ(summaries, 1u) << p.out;
  const auto ej = readFileBytes(dir.file("e.json")), pj = readFileBytes(dir.file("p.json"));
  const std::string ejs(ej.begin(), ej.end()), pjs(pj.begin(), pj.end());
  EXPECT_EQ(reportNumber(pjs, "ranks"), 2);
  EXPECT_NEAR(reportNumber(pjs, "iterations"), reportNumber(ejs, "iterations"), 1.0);
  EXPECT_NEAR(reportNumber(pjs, "iterations_max"), reportNumber(ejs, "iterations_max"), 1.0);
  EXPECT_NEAR(reportNumber(pjs, "potential_max"), reportNumber(ejs, "potential_max"),
              1e-6 * std::abs(reportNumber(ejs, "potential_max")));
  // The lead fields agree entry by entry (to the solver tolerance).
  const auto a = readFileBytes(dir.file("oe/lf.npy")), b = readFileBytes(dir.file("op/lf.npy"));
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 128u);
  double diff = 0, scale = 0;
  for (size_t at = 128; at + 8 <= a.size(); at += 8) {
    double x, y;
    std::memcpy(&x, a.data() + at, 8);
    std::memcpy(&y, b.data() + at, 8);
    diff = std::max(diff, std::abs(x - y));
    scale = std::max(scale, std::abs(x));
  }
  EXPECT_LT(diff, 1e-6 * scale);
  // No file written twice or left behind as a temp file.
  size_t files = 0;
  for (const auto& f : std::filesystem::directory_iterator(dir.file("op"))) {
    ++files;
    EXPECT_EQ(f.path().string().find(".tmp"), std::string::npos) << f.path();
  }
  EXPECT_EQ(files, 4u); // fem.vtu, lf.npy and its two sidecars
}

// A failing net under mpirun: rank 0 names the culprit, every rank ends, the exit code is nonzero.
TEST(EegForward, MpirunFailureEndsEveryRank) {
  if (!petscAvailable()) GTEST_SKIP() << "built without PETSc (TETFLOW_WITH_PETSC=OFF): not tested";
  test::TempDir dir;
  ModuleRegistry reg;
  registerStandardModules(reg);
  Network net(reg);
  addHead(net, "20 17 14 12", 1.0, 3.0);
  addDipole(net, "fem", "0 0 50", "0 0 1"); // outside the head
  net.setParameterText("fem", "solver_backend", "petsc");
  saveNetwork(dir.file("bad.srn"), net);
  const auto r = shell("timeout 120 " + mpirun(2) + " run " + dir.file("bad.srn") + " --output-dir " + dir.file("o"));
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.code, 124) << "timed out: a rank hung\n" << r.out;
  EXPECT_NE(r.out.find("outside the mesh"), std::string::npos) << r.out;
}
#endif

// tDCS: an injected current between two electrode materials (here the brain and the scalp of the
// phantom): the potentials are scaled to it, and the current through every layer in between is
// the injected current (all of it crosses the CSF and the skull).
TEST(EegForward, InjectedCurrentAndCurrentThroughEachMaterial) {
  ModuleRegistry reg;
  registerStandardModules(reg);
  Network net(reg);
  addHead(net, "20 17 14 12", 1.0, 2.0);
  for (const char* mA : {"2", "4"}) {
    const std::string id = std::string("tdcs_") + mA;
    net.addModule("AssembleFEMPoisson", id);
    net.setParameterText(id, "conductivities", kSigma);
    net.setParameterText(id, "boundary_condition", "material_electrodes");
    net.setParameterText(id, "electrode_potentials", "4:1; 1:0");
    net.setParameterText(id, "injected_current", mA);
    net.setParameterText(id, "condition_numbers", "false");
    net.connect("cl", 0, id, 0);
  }
  Executor exec;
  ASSERT_TRUE(exec.execute(net).success) << exec.state("tdcs_2")->error;
  const Report& r = exec.state("tdcs_2")->report;
  EXPECT_NEAR(r.number("electrode_label_4_current"), 2.0, 1e-9);
  EXPECT_NEAR(r.number("electrode_label_1_current"), -2.0, 1e-5);
  EXPECT_NEAR(r.number("electrode_label_4_potential"), r.number("injection_scale"), 1e-12);
  EXPECT_EQ(r.number("electrode_label_1_potential"), 0.0);
  EXPECT_GT(r.number("electrode_label_4_potential"), 0.0);
  for (const char* layer : {"material_2_current", "material_3_current"}) {
    SCOPED_TRACE(layer);
    // One-sided P1 face fluxes, not conservative: they move with the mesh of a layer one or two
    // elements thick. Measured skull 1.78 (-11 %; 1.58 and 1.76 on earlier meshes), CSF 2.33
    // (+17 %; 1.93 and 2.25 on earlier meshes, the last change being cuts kept at a one-voxel
    // layer's near face when its vertex is warped onto the far one). A conservative flux would be
    // exact; this asserts only that every layer carries the injected current to within 25 %.
    EXPECT_NEAR(r.number(layer), 2.0, 0.5);
    std::printf("%s %.4f\n", layer, r.number(layer));
  }
  EXPECT_NEAR(r.number("material_4_current"), 2.0, 1e-9); // electrode: the exact reaction
  EXPECT_TRUE(std::isnan(r.number("kappa"))); // condition_numbers = false
  // Linear: twice the current, twice every potential.
  const Report& r4 = exec.state("tdcs_4")->report;
  EXPECT_NEAR(r4.number("electrode_label_4_potential"), 2 * r.number("electrode_label_4_potential"), 1e-9);
  EXPECT_NEAR(r4.number("material_2_current"), 2 * r.number("material_2_current"), 1e-9);
  // Three electrode materials, or one: an error that says what to give.
  net.setParameterText("tdcs_2", "electrode_potentials", "4:1");
  Executor e;
  EXPECT_FALSE(e.execute(net).success);
  EXPECT_NE(e.state("tdcs_2")->error.find("exactly two electrode materials"), std::string::npos)
      << e.state("tdcs_2")->error;
}
