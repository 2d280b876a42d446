// Quality -> conditioning -> iterations (issue "quality guarantee", item 3): the head phantom and
// Cleaver's spheres, cleaved at several lattice sizes in five ways
//   stencil   plain stencilling: alpha_short = alpha_long = 0 (no snapping or warping), no angle
//             optimisation, no improvement: the slivers cleaving exists to avoid;
//   stencil+  that, then the label-preserving mesh improvement;
//   raw       cleaving with the default alphas, the cleaver's angle optimisation off;
//   cleaver   with the cleaver's angle optimisation (TetFlow's default before mesh improvement);
//   improved  that plus the mesh improvement (CleaveMesh's default),
// and for each mesh: tets, min / max dihedral angle, tets below 10 deg / above 160 deg, kappa(K)
// and kappa(D^-1/2 K D^-1/2), and Jacobi-MINRES iterations (tolerance 1e-8) of the `boundary`
// (u = 0 on the boundary, f = 1) and `dipole` problems. Condition numbers come from Spectra's
// eigen solves up to 60 000 unknowns and from Lanczos estimates above (the method is printed).
//
//   quality_benchmark [RESULTS_FILE] [head|spheres]   (default: both)
#include <omp.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/Cleaving/Cleaver.h"
#include "Algorithms/Cleaving/LabelRepair.h"
#include "Algorithms/Core/Phantom.h"
#include "Algorithms/FEM/PoissonProblem.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Algorithms/MeshImprovement/MeshImprovement.h"
#include "Algorithms/Quality/MeshQuality.h"
#include "Algorithms/Quality/TetQuality.h"

using namespace tetflow;

namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct Input {
  std::string name;
  const MaterialSet* mats;
  GridGeometry grid;
  std::optional<int32_t> strip;
  ConductivityTable sigma;
  Vec3 dipole;
  bool repair;
};

void runCase(const Input& in, double cell, std::ostream& out) {
  NullProgress np;
  const BackgroundMesh bg = generateRegularBcc(in.grid, BccParams{cell, 0.0}, np);
  for (int variant = 0; variant < 5; ++variant) {
    CleaveParams cp;
    cp.strip_exterior = in.strip;
    cp.optimize_angles = variant > 2;
    if (variant < 2) cp.alpha_short = cp.alpha_long = 0.0;
    const double t0 = now();
    CleaveResult r = cleave(bg, *in.mats, cp, np);
    if (in.repair) repairLabels(r.mesh, *in.mats, LabelRepairParams{}, np);
    const double t1 = now();
    ImproveStats is;
    const ImproveParams ip;
    if (variant == 1 || variant == 4) is = improveMesh(r.mesh, ip, np);
    const double t2 = now();
    QualityParams qp;
    const QualityResult q = evaluateQuality(r.mesh, qp, np);
    int64_t below = 0, above = 0;
    for (size_t t = 0; t < r.mesh.numTets(); ++t) {
      const auto& c = r.mesh.tets[t];
      const auto& P = r.mesh.points;
      below += minDihedral(P[c[0]], P[c[1]], P[c[2]], P[c[3]]) < 10.0;
      above += maxDihedral(P[c[0]], P[c[1]], P[c[2]], P[c[3]]) > 160.0;
    }
    PoissonParams pp;
    pp.conductivities = in.sigma;
    pp.solver.tolerance = 1e-8;
    pp.solver.max_iterations = 20000;
    pp.condition.max_dofs = 60000;
    pp.boundary = BoundaryCondition::Boundary;
    const PoissonResult b = solvePoisson(r.mesh, pp, np);
    pp.boundary = BoundaryCondition::Dipole;
    pp.dipole_position = in.dipole;
    pp.dipole_moment = {0, 0, 0.01};
    pp.estimate_condition = false; // same matrix up to the Dirichlet set: kappa from `boundary`
    const PoissonResult d = solvePoisson(r.mesh, pp, np);
    const char* names[] = {"stencil", "stencil+", "raw", "cleaver", "improved"};
    char line[640];
    std::snprintf(line, sizeof line,
                  "%-8s %5.2f %-8s %9zu  %6.2f %7.2f %6lld %6lld  %10.4g %10.4g  %6lld %6lld  cleave %.2f s, improve %.3f s"
                  " (%lld left, dV %.4f %%, %lld iflips)%s  [kappa: %s; jacobi: %s]\n",
                  in.name.c_str(), cell, names[variant], r.mesh.numTets(), q.minDihedral, q.maxDihedral,
                  (long long)below, (long long)above, b.kappa.kappa, b.kappaJacobi.kappa, (long long)b.iterations,
                  (long long)d.iterations, t1 - t0, t2 - t1, (long long)is.unfixedCount, is.maxVolumeChangePercent(), (long long)is.interfaceFlips,
                  (b.converged && d.converged) ? "" : "  NOT CONVERGED", b.kappa.method.c_str(),
                  b.kappaJacobi.method.c_str());
    out << line;
    std::cout << line << std::flush;
  }
}

} // namespace

int main(int argc, char** argv) {
  const std::string resultsFile = argc > 1 ? argv[1] : "quality.txt";
  const std::string only = argc > 2 ? argv[2] : "";
  std::ostringstream out;
  out << "# quality_benchmark on " << std::thread::hardware_concurrency() << " hardware threads (OpenMP "
      << omp_get_max_threads() << ")\n"
      << "# input   cell  variant      tets   min_dih max_dih  <10deg >160deg  kappa(K)  kappa(DKD)  "
         "it_bnd it_dip\n";
  std::cout << out.str();

  // Head phantom (2 mm voxels; radii 92/86/80/78 mm), the default net's indicator smoothing and
  // label repair, air removed, conductivities of Nets/head_dipole.srn, dipole 40 mm above the centre.
  PhantomParams php;
  const Phantom ph = makePhantom(php);
  auto vol = std::make_shared<const LabelVolume>(ph.volume);
  LabelMaterials head(vol, 0.3);
  Input h{"head", &head, vol->grid, 0,
          parseConductivities({"1:0.33", "2:0.0042", "3:1.79", "4:0.33"}, 1.0), {0, 0, 40}, true};
  if (only.empty() || only == "head")
    for (double cell : {7.0, 5.0, 4.0}) runCase(h, cell, out);

  // Cleaver's spheres (28^3 indicator functions, four materials, unit conductivity), the box's
  // centre for the dipole; cell sizes in voxels.
  std::vector<ScalarVolume> v;
  for (int i = 1; i <= 4; ++i)
    v.push_back(readScalarVolume(std::string(TETFLOW_TEST_DATA) + "/spheres" + std::to_string(i) + ".nrrd"));
  IndicatorMaterials spheres(std::move(v));
  const GridGeometry& g = spheres.grid();
  Vec3 centre;
  for (int a = 0; a < 3; ++a) centre[a] = g.origin[a] + 0.5 * double(g.dims[a] - 1) * g.spacing[a];
  Input s{"spheres", &spheres, g, std::nullopt, parseConductivities({}, 1.0), centre, false};
  if (only.empty() || only == "spheres")
    for (double cell : {3.0, 2.0, 1.5, 1.0, 0.75}) runCase(s, cell, out);

  std::ofstream f(resultsFile);
  f << out.str();
  if (!f) {
    std::cerr << "cannot write " << resultsFile << "\n";
    return 1;
  }
  std::cout << "written to " << resultsFile << "\n";
  return 0;
}
