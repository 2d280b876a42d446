// AssembleFEMPoisson as a module: phantom -> background -> cleave -> FEM.
#include <gtest/gtest.h>

#include <cmath>

#include "Dataflow/Executor.h"
#include "Modules/StandardModules.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {
struct FemPipeline {
  ModuleRegistry reg;
  Network net{reg};
  Executor exec;
  FemPipeline() {
    registerStandardModules(reg);
    net.addModule("CreatePhantom", "p");
    net.setParameterText("p", "kind", "head");
    net.setParameterText("p", "voxel_size", "1");
    net.setParameterText("p", "radius", "20");
    net.setParameterText("p", "skull_radius", "17");
    net.setParameterText("p", "csf_radius", "14");
    net.setParameterText("p", "brain_radius", "12");
    net.setParameterText("p", "margin", "2");
    net.addModule("GenerateBackgroundMesh", "bg");
    net.setParameterText("bg", "cell_size", "3");
    net.addModule("CleaveMesh", "cl");
    net.setParameterText("cl", "strip_exterior", "0");
    net.addModule("AssembleFEMPoisson", "fem");
    net.setParameterText("fem", "conductivities", "1:0.33; 2:0.0042; 3:1.79; 4:0.33");
    net.connect("p", 0, "bg", 0);
    net.connect("p", 0, "cl", 0);
    net.connect("bg", 0, "cl", 1);
    net.connect("cl", 0, "fem", 0);
  }
  const ModuleState& fem() { return *exec.state("fem"); }
  const Report& report() { return fem().report; }
};
} // namespace

TEST(AssembleFEMPoissonModule, DipoleInTheHeadPhantom) {
  FemPipeline p;
  p.net.setParameterText("fem", "boundary_condition", "dipole");
  p.net.setParameterText("fem", "dipole_position", "0 0 5");
  p.net.setParameterText("fem", "dipole_moment", "0 0 10");
  const auto sum = p.exec.execute(p.net);
  ASSERT_TRUE(sum.success) << p.fem().error;
  const Report& r = p.report();
  EXPECT_EQ(std::get<bool>(*r.find("converged")), true);
  EXPECT_EQ(std::get<std::string>(*r.find("boundary_condition")), "dipole");
  EXPECT_EQ(std::get<std::string>(*r.find("materials")), "1 2 3 4");
  EXPECT_EQ(r.number("reference_vertices"), 1);
  EXPECT_LE(r.number("relative_residual"), 1e-8);
  EXPECT_LT(r.number("true_residual"), 1e-5);
  EXPECT_GT(r.number("kappa"), r.number("kappa_jacobi")); // skull contrast: scaling helps
  EXPECT_NE(std::get<std::string>(*r.find("kappa_method")).find("Spectra"), std::string::npos);
  for (const char* key : {"dofs", "nnz", "kappa", "iterations", "relative_residual", "converged",
                          "assemble_seconds", "solve_seconds", "condition_seconds"})
    EXPECT_TRUE(r.has(key)) << key;
  // Outputs: mesh with fields, the reduced matrix, the report.
  const auto& outs = p.fem().outputs;
  ASSERT_EQ(outs.size(), 3u);
  const TetMesh& mesh = dynamic_cast<const TetMeshData&>(*outs[0]).value;
  ASSERT_TRUE(mesh.pointFields.count("potential"));
  ASSERT_TRUE(mesh.cellFields.count("grad_magnitude"));
  ASSERT_TRUE(mesh.cellFields.count("current_density"));
  EXPECT_EQ(mesh.pointFields.at("potential").values.size(), mesh.numPoints());
  EXPECT_EQ(mesh.cellFields.at("current_density").values.size(), mesh.numTets());
  const auto& K = dynamic_cast<const MatrixData&>(*outs[1]).value;
  ASSERT_TRUE(K);
  EXPECT_EQ(K->rows(), int64_t(r.number("dofs")));
  EXPECT_EQ(K->nonZeros(), int64_t(r.number("nnz")));
  EXPECT_NE(outs[1]->summary().find("Matrix"), std::string::npos);
  EXPECT_EQ(dynamic_cast<const ReportData&>(*outs[2]).value.entries().size(), r.entries().size());
  // The moment points up: the scalp above the dipole is at a higher potential than below.
  const auto& u = mesh.pointFields.at("potential").values;
  double top = -1e300, bottom = -1e300;
  for (size_t v = 0; v < mesh.numPoints(); ++v) {
    if (mesh.points[v][2] > 15) top = std::max(top, u[v]);
    if (mesh.points[v][2] < -15) bottom = std::max(bottom, u[v]);
  }
  EXPECT_GT(top, bottom);
  std::vector<std::string> stages;
  for (const auto& s : p.fem().stages) stages.push_back(s.name);
  EXPECT_EQ(stages, (std::vector<std::string>{"assemble", "boundary conditions", "solve", "condition", "fields"}));
}

TEST(AssembleFEMPoissonModule, ElectrodesWithCgAndLanczosEstimates) {
  FemPipeline p;
  p.net.setParameterText("fem", "boundary_condition", "electrodes");
  p.net.setParameterText("fem", "electrode_axis", "z");
  p.net.setParameterText("fem", "solver", "cg");
  p.net.setParameterText("fem", "estimate_condition", "false");
  ASSERT_TRUE(p.exec.execute(p.net).success) << p.fem().error;
  const Report& r = p.report();
  EXPECT_EQ(std::get<bool>(*r.find("converged")), true);
  EXPECT_NE(std::get<std::string>(*r.find("kappa_method")).find("Lanczos"), std::string::npos);
  EXPECT_NE(std::get<std::string>(*r.find("kappa_jacobi_method")).find("CG on M^-1 K"), std::string::npos);
  EXPECT_NEAR(r.number("potential_max"), 1.0, 1e-12);
  EXPECT_NEAR(r.number("potential_min"), 0.0, 1e-12);
  // Current in at the 1 V end equals current out at the 0 V end.
  EXPECT_NEAR(r.number("electrode_min_current"), -r.number("electrode_max_current"),
              1e-5 * std::abs(r.number("electrode_min_current")));
  EXPECT_GT(r.number("resistance"), 0.0);

  // Not converging: a status in the report, the module still succeeds.
  p.net.setParameterText("fem", "max_iterations", "3");
  ASSERT_TRUE(p.exec.execute(p.net).success) << p.fem().error;
  EXPECT_EQ(std::get<bool>(*p.report().find("converged")), false);
  ASSERT_FALSE(p.fem().messages.empty());
  EXPECT_NE(p.fem().messages.back().find("did not converge"), std::string::npos);
}

TEST(AssembleFEMPoissonModule, BadParametersAreReportedAgainstTheModule) {
  FemPipeline p;
  p.net.setParameterText("fem", "conductivities", "1:0.33; 7:1");
  p.exec.execute(p.net);
  EXPECT_EQ(p.fem().status, ModuleStatus::Error);
  EXPECT_EQ(p.fem().errorKind, "input");
  EXPECT_NE(p.fem().error.find("fem"), std::string::npos) << p.fem().error;
  EXPECT_NE(p.fem().error.find("label 7 does not occur"), std::string::npos) << p.fem().error;
  p.net.setParameterText("fem", "conductivities", "grey matter:0.33");
  p.exec.execute(p.net);
  EXPECT_NE(p.fem().error.find("no tissue called 'grey matter'; its tissues are scalp (1), skull (2), CSF (3), brain (4)"),
            std::string::npos)
      << p.fem().error;
  p.net.setParameterText("fem", "conductivities", "1:0.33; 2.5:1");
  p.exec.execute(p.net);
  EXPECT_NE(p.fem().error.find("'2.5' is not an integer"), std::string::npos) << p.fem().error;
  p.net.setParameterText("fem", "conductivities", "");
  p.net.setParameterText("fem", "boundary_condition", "material_electrodes");
  p.net.setParameterText("fem", "electrode_potentials", "");
  p.exec.execute(p.net);
  EXPECT_NE(p.fem().error.find("electrode_potentials"), std::string::npos) << p.fem().error;
  p.net.setParameterText("fem", "boundary_condition", "dipole");
  p.net.setParameterText("fem", "dipole_position", "0 0");
  p.exec.execute(p.net);
  EXPECT_NE(p.fem().error.find("dipole_position"), std::string::npos) << p.fem().error;
  // Enum values are checked when set.
  EXPECT_THROW(p.net.setParameterText("fem", "boundary_condition", "neumann"), InputError);
  EXPECT_THROW(p.net.setParameterText("fem", "solver", "gmres"), InputError);
}

TEST(AssembleFEMPoissonModule, MaterialElectrodesOnThePhantom) {
  FemPipeline p;
  p.net.setParameterText("fem", "boundary_condition", "material_electrodes");
  p.net.setParameterText("fem", "electrode_potentials", "4:1; 1:0"); // brain at 1 V, scalp at 0 V
  ASSERT_TRUE(p.exec.execute(p.net).success) << p.fem().error;
  const Report& r = p.report();
  EXPECT_EQ(std::get<bool>(*r.find("converged")), true);
  EXPECT_GT(r.number("electrode_label_4_current"), 0.0);
  EXPECT_NEAR(r.number("electrode_label_4_current"), -r.number("electrode_label_1_current"),
              1e-5 * r.number("electrode_label_4_current"));
  EXPECT_NE(std::get<std::string>(*r.find("kappa_method")).find("Spectra"), std::string::npos);

  // Above max_eigen_dofs the eigen solves are skipped, and the report and log say so.
  p.net.setParameterText("fem", "max_eigen_dofs", "100");
  ASSERT_TRUE(p.exec.execute(p.net).success) << p.fem().error;
  const std::string method = std::get<std::string>(*p.report().find("kappa_method"));
  EXPECT_NE(method.find("eigen solves skipped"), std::string::npos) << method;
  EXPECT_NE(method.find("Lanczos"), std::string::npos) << method;
  ASSERT_FALSE(p.fem().messages.empty());
  EXPECT_NE(p.fem().messages.back().find("max_eigen_dofs 100"), std::string::npos);
}
