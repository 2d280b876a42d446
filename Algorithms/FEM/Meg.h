#pragma once
// MEG forward problem: the magnetic flux density at sensors outside the head from the P1 FEM
// solution of the EEG forward problem (PoissonProblem.h, boundary condition `dipole`), the MEG
// lead field for many sources by a transfer matrix, and the closed form of Sarvas (1987) for a
// spherically symmetric conductor that validates both.
//
// Units (as in PoissonProblem.h): lengths mm, sigma S/m, potential V, dipole moment mA mm,
// current density sigma grad u in mA/mm^2. Fields are in fT. With mu0/4pi = 1e-7 T m/A:
//   (mA mm) / mm^2 = 1e-6 A m / 1e-6 m^2 = 1 A/m,  and  1e-7 T m/A x 1 A/m = 1e-7 T = 1e8 fT,
// so B[fT] = kMegFemtoTesla x (the same expression evaluated in mm, mA mm, mA/mm^2, mm^3).
// (A 10 nA m = 0.01 mA mm dipole at 40 mm gives 0.01/1600 x 1e8 = 625 fT.)
//
// Total field of the current J = Jp - sigma grad u (Biot-Savart):
//   B(r) = B0(r) + Bv(r),  B0(r) = mu0/4pi Q x (r - r0) / |r - r0|^3  (primary, point dipole)
//   Bv(r) = -mu0/4pi int sigma grad u(r') x (r - r') / |r - r'|^3 dV'  (volume currents)
//
// Method for Bv: Biot-Savart over the tets, not Geselowitz' surface integral. Reasons:
//  - it uses exactly the current of the FEM solution (sigma grad u, constant on each tet), so it
//    needs no interface surfaces, and holds for anisotropic sigma and any number of materials;
//  - it is linear in u, so the transfer-matrix lead field below equals direct solves exactly;
//  - the integral of the kernel over a tet is done exactly, not by quadrature (no rule to choose,
//    no accuracy loss for sensors near the scalp): (r - r')/|r - r'|^3 = grad_r' 1/|r - r'|, so
//      G_T(r) = int_T (r - r')/|r - r'|^3 dV' = sum_{faces f of T} n_f int_f 1/|r - r'| dS'
//    (n_f the outward unit normal), and the integral of 1/R over a flat triangle has a closed form
//    (Wilton et al. 1984; Graglia 1993):
//      int_f 1/R dS = sum_{edges i} t_i L_i - |d| Omega,
//    t_i the signed distance from the projection of r to edge i's line (positive inside), L_i =
//    int_edge 1/R ds = ln((R+ + l+)/(R- + l-)) (evaluated without cancellation for l < 0), d the
//    height of r over the face's plane and Omega the solid angle the triangle subtends at r (van
//    Oosterom & Strackee 1983). The only error left in Bv is the FEM's own.
//    Rounding: the edge terms cancel down to the result; the relative rounding error grows like
//    eps (R/h)^2 per face and (R/h) more in the sum over a tet's faces (R the distance, h the tet
//    size): ~1e-12 for 1 mm tets 100 mm away.
// Geselowitz' formula (B = B0 - mu0/4pi sum_interfaces (sigma_in - sigma_out) int u n x grad' 1/R)
// gives the same number on a continuous P1 potential with isotropic sigma (sigma grad u x grad 1/R
// = curl(sigma u grad 1/R) in each tet, and the faces inside a material cancel), but it needs the
// interface surfaces of every conductivity jump, oriented, and does not cover anisotropy. So the
// accuracy of Bv is that of the FEM potential on the interfaces, as for EEG.
//
// Cost: one exact kernel per (tet, coil): 6 logarithms, 4 arctangents; ~0.2 us. Parallel over the
// tets (OpenMP); sums are taken in tet order, so results do not depend on the thread count.
//
// Sensors (readMegSensors): a text file (.csv, .tsv, .txt or any other name), one coil per line:
//     name  x  y  z  nx  ny  nz  [weight]
//   fields separated by commas, semicolons, tabs or blanks (so names hold none of these);
//   position in mm (times unitScale when > 0), orientation (nx, ny, nz) any non-zero length
//   (normalised), weight default 1. Consecutive lines with the same name are the coils (or
//   integration points) of one sensor, whose signal is sum_c weight_c B(r_c) . n_c:
//     magnetometer:           MAG1 0 0 115 0 0 1
//     axial gradiometer:      GRA1 0 0 115 0 0 1 1
//                             GRA1 0 0 165 0 0 1 -1        (B_z(115) - B_z(165), fT)
//     planar gradiometer:     PG1 -8 0 115 0 0 1 0.0625     (weights +-1/baseline: fT/mm)
//                             PG1  8 0 115 0 0 1 -0.0625
//   Blank lines and lines starting with '#' are skipped; the first other line is a header, and
//   skipped, when none of its fields 2..7 is a number ("name,x,y,z,nx,ny,nz,weight"). A UTF-8 BOM
//   and CRLF line ends are accepted.
//   Errors (InputError "<path>, line <n>: ..."): a missing or unreadable file, not 7 or 8 fields,
//   a field that is not a finite number, a zero orientation, a zero weight, a sensor whose coils
//   are not on consecutive lines (both lines named), a file without sensors, a non-finite or
//   negative unitScale.
//
// Signals are in fT per sensor (weights dimensionless), or fT/mm for gradiometer weights in 1/mm.
#include <Eigen/Core>

#include <string>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/TetMesh.h"
#include "Conductivity.h"
#include "IterativeSolver.h"
#include "SourceModels.h"

namespace tetflow {

// mu0 / 4 pi in fT per (A/m): B[fT] = kMegFemtoTesla x (mA mm / mm^2).
constexpr double kMegFemtoTesla = 1e8;

struct MegCoil {
  Vec3 position{0, 0, 0}; // mm
  Vec3 normal{0, 0, 1};   // unit
  double weight = 1.0;
  int line = 0;           // 1-based line in the file (0 when made in code)
};

struct MegSensor {
  std::string name;
  std::vector<MegCoil> coils;
};

std::vector<MegSensor> readMegSensors(const std::string& path, double unitScale = 0.0);

// Primary field (fT) at r of a point dipole q (mA mm) at r0 (mm), infinite homogeneous medium.
Vec3 megPrimaryField(const Vec3& r, const Vec3& r0, const Vec3& q);

// Sarvas (1987, Phys Med Biol 32:11, eq. 25): the total field (fT) at r outside any spherically
// symmetric conductor centred at `center` of a dipole q at r0 inside it (independent of the
// conductivities and radii):
//   B = mu0 / (4 pi F^2) (F q x r0 - (q x r0 . r) grad F),  a = r - r0, a = |a|, r = |r|,
//   F = a (r a + r^2 - r0 . r),
//   grad F = (a^2/r + a.r/a + 2a + 2r) r - (a + 2r + a.r/a) r0    (r, r0 relative to the centre).
// Radial dipoles (q parallel to r0 - center) and dipoles at the centre give B = 0. InputError if
// r is at the centre or F = 0 (r on the dipole's ray at or inside its radius).
Vec3 sarvasField(const Vec3& r, const Vec3& r0, const Vec3& q, const Vec3& center = {0, 0, 0});

// sum over the sensor's coils of weight B(r_c) . n_c for a field function B(r).
template <class FieldFn>
double sensorSignal(const MegSensor& s, const FieldFn& field) {
  double v = 0;
  for (const MegCoil& c : s.coils) v += c.weight * dot(field(c.position), c.normal);
  return v;
}

// int over the triangle (a, b, c) of 1 / |r - r'| dS' (mm), exact (closed form above).
double triangleInverseDistanceIntegral(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& r);

// G_T(r) = int_T (r - r') / |r - r'|^3 dV' (kernel 1/mm^2 times mm^3: mm), exact, for a tet of
// either orientation and r not on its boundary.
Vec3 tetBiotSavartKernel(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, const Vec3& r);

// Per tet H_T = sum_coils weight G_T(r_c) x n_c (mm), so that the volume-current signal of a
// current density J (constant J_T per tet, mA/mm^2) is  -kMegFemtoTesla sum_T J_T . H_T  (fT).
// Parallel over the tets; checks cancellation.
std::vector<Vec3> megSensorKernels(const TetMesh& mesh, const MegSensor& sensor, Progress& progress);

// The MEG of one solved potential (point field of AssembleFEMPoisson) and its dipole.
struct MegParams {
  ConductivityTable conductivities;
  std::vector<MegSensor> sensors;
  Vec3 dipolePosition{0, 0, 0}; // mm
  Vec3 dipoleMoment{0, 0, 0};   // mA mm
};
struct MegResult {
  std::vector<double> primary, volume, total; // per sensor, fT
  int64_t coilsInsideMesh = 0;                // coils located inside a tet (noted)
  double seconds = 0;
  std::vector<std::string> notes;
};
// `potential` per mesh vertex (V). InputError for a wrong length, a non-finite value, no sensors,
// an inverted tet or bad conductivities.
MegResult computeMeg(const TetMesh& mesh, const std::vector<double>& potential, const MegParams& params,
                     Progress& progress);

// The MEG lead field by a transfer matrix. The volume-current signal of sensor s is linear in
// the P1 potential: Bv_s(u) = c_s^T u with c_s,a = -kMegFemtoTesla sum_{T containing a}
// (sigma_T grad l_a) . H_T (sum_a c_s,a = 0 on every tet, so c_s is a compatible Neumann load).
// One solve K x_s = c_s per sensor on the stiffness matrix of AssembleFEMPoisson (one vertex per
// connected piece held at 0; the gauge does not matter since both loads sum to zero) gives, for
// the partial-integration dipole load b = m . grad l_a on the source's tet (Assembly.h addDipole),
//   Bv_s = c_s^T K^-1 b = x_s^T b = m . grad x_s|_T,
// the same number as a direct dipole solve followed by computeMeg, to the solver tolerance. Plus
// the primary field of the unit dipole along each axis. Sources: as LeadField.h (tet centroids of
// sourceLabels, or sourcePoints located in their tets).
struct MegLeadFieldParams {
  ConductivityTable conductivities;
  std::vector<MegSensor> sensors;
  std::vector<int32_t> sourceLabels;
  std::vector<Vec3> sourcePoints;
  SolverParams solver;
  SourceModel sourceModel = SourceModel::PartialIntegration; // of the volume currents: partial integration or Venant
};
struct MegLeadFieldResult {
  std::vector<std::string> names;  // sensors (rows)
  std::vector<Vec3> sources;       // mm
  std::vector<int64_t> sourceTets;
  Eigen::MatrixXd matrix;          // sensors x (3 sources), fT per mA mm; column 3 s + k = axis k
  Eigen::MatrixXd primary;         // the primary-field part of `matrix`
  int64_t dofs = 0, nnz = 0, solves = 0, iterationsTotal = 0, iterationsMax = 0, ranks = 1;
  int64_t coilsInsideMesh = 0;
  bool converged = true;
  std::string solverUsed; // the solver that ran (auto: the one it chose)
  double assembleSeconds = 0, setupSeconds = 0, kernelSeconds = 0, solveSeconds = 0, matrixSeconds = 0; // setup: cholesky's factorisation
  std::vector<std::string> notes;
};
MegLeadFieldResult computeMegLeadField(const TetMesh& mesh, const MegLeadFieldParams& params, Progress& progress);

// Writes the matrix atomically by extension: .npy (float64, shape (sensors, sources, 3)) or .csv
// (header "sensor,s0_x,...", one row per sensor); beside it PATH.sensors.csv (name, coils, first
// coil x y z nx ny nz) and PATH.sources.csv (index, x y z, tet). InputError for another extension.
void writeMegLeadField(const MegLeadFieldResult& r, const std::vector<MegSensor>& sensors, const std::string& path);

// Errors against a reference without re-referencing (MEG has no reference):
//   RDM = || u/||u|| - v/||v|| ||, MAG = ||u|| / ||v||. InputError for empty, unequal-length,
// non-finite or zero vectors.
struct MegErrors {
  double rdm = 0, mag = 1, lnMag = 0;
};
MegErrors compareMeg(const std::vector<double>& numerical, const std::vector<double>& reference);

} // namespace tetflow
