#pragma once
// Analytic EEG forward solution of the concentric multi-shell sphere (the reference for FEM
// dipole validation) and the standard forward error measures.
//
// Model: N >= 1 concentric shells with isotropic conductivities; shell i (0-based) is
// radii[i-1] < r < radii[i] (radii[-1] = 0), the outer surface r = radii.back() is insulated.
// A current dipole (moment m at r0, |r0| < radii[0]) lies in the innermost shell.
//
// Formula: the potential on the outer surface R = radii.back() of a point current source I at
// r0 (|r0| = a) is, per Legendre degree l (Legendre series with the transfer recursion for the
// radial coefficients; de Munck & Peters 1993, IEEE TBME 40:1166; Zhang 1995, Phys Med Biol
// 40:335):
//   V(r) = I sum_{l>=1} k_l (a/R1)^l P_l(cos g),  cos g = rhat . r0hat,  R1 = radii[0],
//   k_l = T_l / (4 pi sigma_1 R1)  (spherePointSourceCoefficient: k_l (a/R1)^l).
// T_l = 1 + (l+1)/l = (2l+1)/l for one shell. For N shells it follows from A r^l + B r^-(l+1)
// in each shell: starting from sigma dV/dr = 0 at R, the outward admittance Y = sigma r V'/V and
// the ratio g = V(R)/V(r) are carried inwards across the shells and interfaces (V, sigma V'
// continuous); only ratios (r_in/r_out)^(l+1) <= 1 occur, so no power overflows for any l.
// In shell 1 the r^-(l+1) part is the infinite-medium source term a^l / r^(l+1) / (4 pi sigma_1),
// giving T_l = g (2l+1) / (l - Y/sigma_1). The l = 0 term (a constant) is dropped: the dipole
// has none, and the result is the natural zero-mean convention (mean over the outer sphere 0).
// The dipole potential is m . grad_r0 of the point-source series:
//   V = sum_{l>=1} k_l / R1 (a/R1)^(l-1) [ l P_l(x) m_r + P_l'(x) (m_t . rhat) ],  x = cos g,
// with m_r = m . r0hat, m_t = m - m_r r0hat. At r0 = 0 only l = 1 survives:
// V = k_1 / R1 (m . rhat) (= 3 m . rhat / (4 pi sigma R^2) for one shell).
//
// Units (consistent, as in PoissonProblem.h): lengths mm, sigma S/m (= mS/mm), moment mA mm,
// current mA, potential V (mA / mS).
//
// Electrodes: each electrode position is projected radially onto r = radii.back() (only its
// direction is used); the origin has no direction and is an InputError.
//
// Convergence: terms l = 1, 2, ... are added until, for 3 consecutive l, the tail estimated from
// a bound B_l on the term (|P_l| <= 1, |P_l'| <= l(l+1)/2) and its decay ratio q (B_l/(1-q)) is
// below tol x sum|terms| (the scale of the result; cancellation below it is not resolvable).
// The terms decay like l^2 (a/R)^l: on the 4-shell head model (R1/R = 78/92) an eccentricity
// 0.95 needs ~ 160 terms, a single shell ~ 800 (0.99: ~ 4200). Not converging within maxTerms is a
// ProcessingError (raise maxTerms or tol). termsUsed (optional) receives the last l summed
// (the largest over the electrodes for the vector version).
//
// Errors (InputError): empty or mismatched radii / conductivities, non-positive, non-finite or
// non-ascending radii, non-positive or non-finite conductivity, a dipole not strictly inside the
// innermost sphere, a non-finite moment, an electrode at the centre, maxTerms < 1, tol <= 0.
//
// Forward error measures (Meijs et al. 1989, IEEE TBME 36:950; Wolters et al.; Lew et al. 2009,
// Appl Numer Math 59:1970): u (numerical) and v (analytic) are first referenced to their average
// (mean subtracted), then
//   RDM   = || u/||u|| - v/||v|| ||_2   (0..2, topography error; 0 = identical shape)
//   MAG   = ||u|| / ||v||               (1 = identical magnitude),  lnMAG = ln(MAG).
// Empty, different-length, non-finite or constant (zero after referencing) vectors: InputError.
#include <vector>

#include "Algorithms/Core/Geometry.h"

namespace tetflow {

struct SphereShells {
  std::vector<double> radii;          // mm, ascending, innermost (brain) .. outermost (scalp)
  std::vector<double> conductivities; // S/m, one per shell
};

// Legendre coefficient of the outer-surface potential (V per mA) of a point current source at
// radius a (0 <= a < radii[0]): k_l (a/R1)^l above. l >= 1.
double spherePointSourceCoefficient(const SphereShells& shells, int l, double a);

// Potential (V) at the electrode (projected onto the outer surface) of the dipole.
double sphereDipolePotential(const SphereShells& shells, const Vec3& dipolePos, const Vec3& moment,
                             const Vec3& electrode, int maxTerms = 10000, double tol = 1e-12,
                             int* termsUsed = nullptr);

// The same for many electrodes (the radial coefficients are computed once).
std::vector<double> sphereDipolePotentials(const SphereShells& shells, const Vec3& dipolePos,
                                           const Vec3& moment, const std::vector<Vec3>& electrodes,
                                           int maxTerms = 10000, double tol = 1e-12,
                                           int* termsUsed = nullptr);

struct ForwardErrors {
  double rdm = 0.0;   // relative difference measure, 0..2
  double mag = 1.0;   // magnitude ratio ||u|| / ||v||
  double lnMag = 0.0; // ln(mag)
};

// numerical = u, analytic = v, both average-referenced here.
ForwardErrors compareToAnalytic(const std::vector<double>& numerical,
                                const std::vector<double>& analytic);

} // namespace tetflow
