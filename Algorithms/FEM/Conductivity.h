#pragma once
// Conductivity table of the FEM problem -div(sigma grad u) = f (DESIGN §6 "FEM problem").
//
// Units: sigma in S/m. Mesh coordinates are in mm, so the stiffness entries
// K_ij = sum_T vol_T grad(phi_i)^T sigma_T grad(phi_j) come out in S/m * mm = mS; with u in V,
// K u is a current in mA (see PoissonProblem.h for the whole unit system).
//
// sigma is constant per tet and chosen by the tet's material label: an isotropic value or a
// symmetric positive definite tensor given by its 6 entries in the order xx yy zz xy yz xz.
// Labels not listed get the default (isotropic) conductivity.
//
// Text form (the AssembleFEMPoisson `conductivities` parameter, a ';'-separated list):
//   "1:0.33; 2:0.0042"                  isotropic, label:sigma
//   "5:0.1 0.1 1.0 0 0 0"               anisotropic, label:xx yy zz xy yz xz (spaces or commas)
// Labels are decimal integers (any sign); values must be finite. Errors are InputErrors naming
// the entry and what is wrong: a label that is not an integer, a missing ':', a value that is
// not a number, 2..5 or more than 6 values, sigma <= 0, a tensor that is not positive definite,
// a label listed twice.
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "Algorithms/Core/Geometry.h"

namespace tetflow {

// Symmetric 3x3 tensor as (xx, yy, zz, xy, yz, xz).
using SymTensor6 = std::array<double, 6>;

inline SymTensor6 isotropicTensor(double sigma) { return {sigma, sigma, sigma, 0.0, 0.0, 0.0}; }
inline Mat3 tensorMatrix(const SymTensor6& s) {
  return {{{s[0], s[3], s[5]}, {s[3], s[1], s[4]}, {s[5], s[4], s[2]}}};
}
// True when all entries are finite and the tensor is positive definite (leading minors > 0).
bool isPositiveDefinite(const SymTensor6& s);

struct ConductivityTable {
  double defaultSigma = 1.0;                  // S/m, for labels not in byLabel (> 0)
  std::map<int32_t, SymTensor6> byLabel;      // label -> tensor (S/m)

  void set(int32_t label, double sigma) { byLabel[label] = isotropicTensor(sigma); }
  void set(int32_t label, const SymTensor6& tensor) { byLabel[label] = tensor; }
  SymTensor6 tensor(int32_t label) const;
  bool isotropic(int32_t label) const; // off-diagonals 0 and equal diagonal
  // Throws InputError when the default is not a finite number > 0 or a tensor is not SPD.
  void validate() const;
};

// Parse list items ("label:sigma" or "label:xx yy zz xy yz xz"); `defaultSigma` in S/m.
ConductivityTable parseConductivities(const std::vector<std::string>& items, double defaultSigma);

// Parse list items "label:value" (e.g. electrode potentials "5:1; 6:0"). `what` names the
// parameter in messages. Duplicate labels, non-integer labels and non-finite values are
// InputErrors.
std::map<int32_t, double> parseLabelValues(const std::vector<std::string>& items, const std::string& what);

// Any count of numbers separated by spaces and/or commas; InputError naming `what` and the token.
std::vector<double> parseNumbers(const std::string& text, const std::string& what);
// List items that are integer labels (e.g. "4"); InputError naming `what` and the item.
std::vector<int32_t> parseLabels(const std::vector<std::string>& items, const std::string& what);

// Parse three numbers "x y z" (spaces and/or commas). InputError naming `what` otherwise.
Vec3 parseVec3(const std::string& text, const std::string& what);

} // namespace tetflow
