#include "AnalyticSphere.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "Algorithms/Core/Errors.h"

namespace tetflow {

namespace {

std::string str(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}

void checkShells(const SphereShells& s) {
  if (s.radii.empty())
    throw InputError("sphere model: no shells (radii and conductivities are empty)");
  if (s.radii.size() != s.conductivities.size())
    throw InputError("sphere model: " + std::to_string(s.radii.size()) + " radii but " +
                     std::to_string(s.conductivities.size()) +
                     " conductivities (one conductivity per shell)");
  for (size_t i = 0; i < s.radii.size(); ++i) {
    const double r = s.radii[i], sigma = s.conductivities[i];
    if (!std::isfinite(r) || r <= 0)
      throw InputError("sphere model: radius " + std::to_string(i) + " = " + str(r) +
                       " mm must be positive and finite");
    if (i > 0 && r <= s.radii[i - 1])
      throw InputError("sphere model: radii must ascend from the innermost shell, but radius " +
                       std::to_string(i) + " = " + str(r) + " mm <= radius " +
                       std::to_string(i - 1) + " = " + str(s.radii[i - 1]) + " mm");
    if (!std::isfinite(sigma) || sigma <= 0)
      throw InputError("sphere model: conductivity of shell " + std::to_string(i) + " = " +
                       str(sigma) + " S/m must be positive and finite");
  }
}

void checkDipole(const SphereShells& s, const Vec3& pos, const Vec3& moment) {
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(pos[i]) || !std::isfinite(moment[i]))
      throw InputError("sphere model: dipole position and moment must be finite");
  if (norm(pos) >= s.radii[0])
    throw InputError("sphere model: the dipole at distance " + str(norm(pos)) +
                     " mm from the centre is not strictly inside the innermost sphere (radius " +
                     str(s.radii[0]) + " mm)");
}

// T_l of the header: outer potential of the l-th harmonic per unit infinite-medium source term
// at R1. Carries Y = sigma r V'/V and g = V(R)/V(r) from the insulated surface inwards.
double transfer(const SphereShells& s, int l) {
  const double L = l, twoL1 = 2.0 * l + 1.0;
  double Y = 0.0, g = 1.0;
  for (size_t j = s.radii.size() - 1; j > 0; --j) {
    const double sigma = s.conductivities[j], rho = s.radii[j - 1] / s.radii[j];
    const double p = (L + 1.0 + Y / sigma) / twoL1, q = (L - Y / sigma) / twoL1; // V(R_j) = 1
    const double f = std::pow(rho, twoL1);
    const double u = p * f + q; // V(R_{j-1}) rho^(l+1) >= min(1, q) > 0
    Y = sigma * (L * p * f - (L + 1.0) * q) / u;
    g *= std::pow(rho, L + 1.0) / u;
  }
  return g * twoL1 / (L - Y / s.conductivities[0]);
}

// k_l / R1 of the header, cached and extended on demand (shared by all electrodes).
struct Coefficients {
  const SphereShells& s;
  std::vector<double> k{0.0};
  double at(int l) {
    while (int(k.size()) <= l) {
      const double R1 = s.radii[0];
      k.push_back(transfer(s, int(k.size())) /
                  (4.0 * std::numbers::pi * s.conductivities[0] * R1 * R1));
    }
    return k[size_t(l)];
  }
};

double dipoleSeries(Coefficients& c, const Vec3& pos, const Vec3& moment, const Vec3& electrode,
                    int maxTerms, double tol, int& terms) {
  const double rn = norm(electrode);
  if (!(rn > 0) || !std::isfinite(rn))
    throw InputError("sphere model: an electrode at the centre (or non-finite) has no direction "
                     "to project it onto the outer surface");
  const Vec3 rhat = (1.0 / rn) * electrode;
  const double a = norm(pos), e = a / c.s.radii[0];
  // Radial / tangential split; at the centre every moment is "tangential" (only l = 1 remains).
  const Vec3 ahat = a > 0 ? (1.0 / a) * pos : Vec3{0, 0, 0};
  const double mr = dot(moment, ahat), mtr = dot(moment, rhat) - mr * dot(ahat, rhat);
  const double x = std::clamp(dot(ahat, rhat), -1.0, 1.0);
  double P0 = 1.0, P1 = x, dP1 = 1.0; // P_{l-1}, P_l, P_l'
  double sum = 0.0, scale = 0.0, prevBound = 0.0, epow = 1.0; // epow = e^(l-1)
  int quiet = 0;
  for (int l = 1;; ++l) {
    if (l > 1) { // advance the Legendre recursions to degree l
      const double P2 = ((2.0 * l - 1.0) * x * P1 - (l - 1.0) * P0) / l;
      dP1 = x * dP1 + l * P1;
      P0 = P1;
      P1 = P2;
      epow *= e;
    }
    const double kl = c.at(l) * epow;
    const double term = kl * (l * P1 * mr + dP1 * mtr);
    sum += term;
    scale += std::abs(term);
    terms = l;
    if (e == 0.0) break; // dipole at the centre: exactly the l = 1 term
    const double bound = std::abs(kl) * (l * std::abs(mr) + 0.5 * l * (l + 1.0) * std::abs(mtr));
    const double ratio = prevBound > 0 ? bound / prevBound : 0.0;
    prevBound = bound;
    quiet = bound <= tol * scale * std::max(0.0, 1.0 - ratio) ? quiet + 1 : 0; // tail B/(1-q)
    if (quiet >= 3) break;
    if (l >= maxTerms)
      throw ProcessingError("sphere model: the dipole series did not converge within " +
                            std::to_string(maxTerms) + " terms (eccentricity " + str(e) +
                            "); raise maxTerms or tol");
  }
  return sum;
}

void checkSeries(int maxTerms, double tol) {
  if (maxTerms < 1)
    throw InputError("sphere model: maxTerms = " + std::to_string(maxTerms) + " must be >= 1");
  if (!(tol > 0))
    throw InputError("sphere model: tol = " + str(tol) + " must be positive");
}

} // namespace

double spherePointSourceCoefficient(const SphereShells& shells, int l, double a) {
  checkShells(shells);
  if (l < 1) throw InputError("sphere model: Legendre degree l = " + std::to_string(l) + " < 1");
  if (!(a >= 0) || a >= shells.radii[0])
    throw InputError("sphere model: source radius " + str(a) +
                     " mm is not in [0, innermost radius " + str(shells.radii[0]) + " mm)");
  const double R1 = shells.radii[0];
  return transfer(shells, l) / (4.0 * std::numbers::pi * shells.conductivities[0] * R1) *
         std::pow(a / R1, l);
}

std::vector<double> sphereDipolePotentials(const SphereShells& shells, const Vec3& dipolePos,
                                           const Vec3& moment, const std::vector<Vec3>& electrodes,
                                           int maxTerms, double tol, int* termsUsed) {
  checkShells(shells);
  checkDipole(shells, dipolePos, moment);
  checkSeries(maxTerms, tol);
  Coefficients c{shells};
  std::vector<double> v;
  v.reserve(electrodes.size());
  int most = 0;
  for (const Vec3& el : electrodes) {
    int terms = 0;
    v.push_back(dipoleSeries(c, dipolePos, moment, el, maxTerms, tol, terms));
    most = std::max(most, terms);
  }
  if (termsUsed) *termsUsed = most;
  return v;
}

double sphereDipolePotential(const SphereShells& shells, const Vec3& dipolePos, const Vec3& moment,
                             const Vec3& electrode, int maxTerms, double tol, int* termsUsed) {
  return sphereDipolePotentials(shells, dipolePos, moment, {electrode}, maxTerms, tol, termsUsed)[0];
}

ForwardErrors compareToAnalytic(const std::vector<double>& numerical,
                                const std::vector<double>& analytic) {
  if (numerical.empty() || numerical.size() != analytic.size())
    throw InputError("forward errors: numerical (" + std::to_string(numerical.size()) +
                     ") and analytic (" + std::to_string(analytic.size()) +
                     ") potentials must be non-empty and of equal length");
  auto reference = [](std::vector<double> u, const char* name) {
    double mean = 0.0;
    for (double x : u) {
      if (!std::isfinite(x)) throw InputError(std::string("forward errors: ") + name +
                                              " potentials contain a non-finite value");
      mean += x;
    }
    mean /= double(u.size());
    double n2 = 0.0;
    for (double& x : u) {
      x -= mean;
      n2 += x * x;
    }
    if (!(n2 > 0))
      throw InputError(std::string("forward errors: ") + name +
                       " potentials are constant (zero after average referencing)");
    return std::make_pair(u, std::sqrt(n2));
  };
  const auto [u, nu] = reference(numerical, "numerical");
  const auto [v, nv] = reference(analytic, "analytic");
  double d2 = 0.0;
  for (size_t i = 0; i < u.size(); ++i) {
    const double d = u[i] / nu - v[i] / nv;
    d2 += d * d;
  }
  return {std::sqrt(d2), nu / nv, std::log(nu / nv)};
}

} // namespace tetflow
