#pragma once
// PSYS (seed chapter 3): particles that sample a CAD model's corners, curves and patches with an
// inferred sizing field, placed hierarchically and relaxed by an energy computed in 3-D world
// space with moves in each cell's parameter space.
//
//  - Energy between particles i, j at distance r (3.1): E = σ_ij [cot(π r / 2σ_ij) + π r / 2σ_ij − π/2]
//    for r < σ_ij = max(σ_i, σ_j), 0 beyond. Moves follow the forces −dE/dr (3.7), mapped to the
//    parameters by the pseudo-inverse of the Jacobian (3.8), each with its own step λ_i that is
//    cut tenfold when the energy does not fall (Algorithm 1).
//  - Splits and deletes (3.3–3.5): E* = E_i (1 + ε), ε uniform in [0, 0.2); split below 0.35
//    E_ideal, delete above 1.75 E_ideal; E_ideal = σ_i · 6 E(0.58) on patches (a hexagonal
//    neighbourhood, 3.6) and σ_i · 2 E(0.58) on curves (two neighbours). They are tried every
//    fifth iteration, a split particle placed at 0.58 σ from its parent; with the seed's
//    ε in [0, 1] every iteration a particle at its ideal energy was deleted one time in four.
//  - Sizing field (3.10): σ_i = max(σ_min, min(σ_max, σ_κ, s_τ σ_τ, σ_L)) with σ_κ = 1/(s_κ κ)
//    (κ: the largest absolute principal curvature of the patch; on a curve also the curve's own
//    and its patches'; on a corner those of its curves), σ_τ the distance to the nearest particle
//    on a cell that is not adjacent (gap size; curves: other curves outside the shared corners'
//    balls, patches: particles of patches and curves that do not touch it) and
//    σ_L = min_j (L |r_ij| + σ_j) over the neighbours (Lipschitz, 3.14).
//  - Phases (3.3.1): 1 curves with κ and L only (the corners' σ then fixes their corner balls);
//    2 curves with τ too; 3 patches. A phase ends when 99 % of its particles moved less than 1 %
//    of their σ and two rounds of splits and deletes changed at most 0.2 % of them, or at its
//    iteration limit; splits and deletes stop after 70 % of the limit so that it ends.
// Both cores: each iteration computes every particle's move and σ from the previous iteration's
// positions (OpenMP), so the result does not depend on the thread count.
#include <string>
#include <vector>

#include "Algorithms/SurfaceMeshing/CadSample.h"

namespace tetflow {

struct PsysParams {
  double sKappa = 2.0;    // s_κ: σ_κ = 1/(s_κ κ)
  double sTau = 0.5;      // s_τ: σ ≤ s_τ · gap size
  double lipschitz = 0.3; // L
  double minSize = 0;     // σ_min, mm (0: 1/1000 of the bounding-box diagonal)
  double maxSize = 0;     // σ_max, mm (0: 1/10 of the bounding-box diagonal)
  int maxIterations = 300; // per phase
  unsigned seed = 1;
};

struct PsysPhaseStats {
  std::string name;
  int iterations = 0;
  double firstEnergy = 0, lastEnergy = 0;
  int64_t splits = 0, deletes = 0;
  int64_t particles = 0; // at the end of the phase (on the phase's cells)
  double seconds = 0;
  bool converged = false;
};

struct PsysStats {
  std::vector<PsysPhaseStats> phases;
  double minSize = 0, maxSize = 0; // the σ bounds used
  double sigmaMin = 0, sigmaMax = 0; // the σ range of the final particles
};

// Samples the whole model. Throws InputError for parameters out of range (named).
CadSample sampleCadModel(const CadModel& model, const PsysParams& params, PsysStats* stats = nullptr);

// The pair energy (3.1) and its derivative dE/dr (3.2), 0 beyond σ.
double psysEnergy(double r, double sigma);
double psysEnergyDerivative(double r, double sigma);

} // namespace tetflow
