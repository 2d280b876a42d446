#pragma once
// The subtraction source model (Bertrand et al. 1991; Wolters et al. 2007, "Numerical
// mathematics of the subtraction method for the modeling of a current dipole in EEG source
// reconstruction using finite element head models"; Drechsler et al. 2009, "A full subtraction
// approach").
//
// The potential u of a current dipole (moment M, mA mm, at x0) in a conductor whose conductivity
// near x0 is the isotropic sigma_inf (S/m) is split into u = u_inf + w, with u_inf the dipole's
// potential in an unbounded homogeneous medium of conductivity sigma_inf,
//   u_inf(x) = M . (x - x0) / (4 pi sigma_inf |x - x0|^3)       (V; x, x0 in mm),
// which carries the singularity exactly, and the correction w, smooth near x0, the solution of
//   -div(sigma grad w) = div((sigma - sigma_inf) grad u_inf)  in the conductor,
//   sigma dw/dn = -sigma du_inf/dn                             on its boundary.
// Its P1 load (the weak form, tested against every vertex function phi_i) is
//   f_i = sum_T grad(phi_i) . (sigma_inf - sigma_T) int_T grad(u_inf)
//         - sigma_inf int_boundary (grad(u_inf) . n) phi_i,
// where the sum runs over the tets whose conductivity differs from sigma_inf only (in a head:
// the layers outside the brain), so no integral comes near the singularity unless a layer does.
// int_T grad(u_inf) is computed as the flux sum_faces n_F int_F u_inf (divergence theorem), and
// every face integral by a degree-5 seven-point rule on triangles that are subdivided (up to 6
// levels) until each is smaller than a quarter of its distance to x0. The boundary term's sum (the
// flux of grad u_inf out of the conductor, 0 exactly) is 0 to about 1e-6 of the load by quadrature;
// that rest is taken out evenly over the boundary (by area), so that the load carries no net
// current and the solution does not depend on the vertex that holds the reference.
//
// Compared with partial integration and Venant (SourceModels.h), nothing of the singularity is
// left to the mesh: the error no longer depends on where the dipole sits among the vertices, and
// it stays small up to a few elements from a conductivity jump. Closer than that (eccentricity
// 0.95 on the four-shell sphere at 3 mm, docs/eeg-meg-tdcs.md) the correction's forcing in the nearby layer is
// too steep for P1 elements and Venant does better. It costs a pass over the tets of the other
// layers per dipole.
#include <Eigen/Core>

#include <cstdint>
#include <vector>

#include "Algorithms/Core/TetMesh.h"
#include "Conductivity.h"
#include "TetLocator.h"

namespace tetflow {

class SubtractionSources {
public:
  // The mesh's conductivities per tet and its boundary faces, built once for many dipoles.
  SubtractionSources(const TetMesh& mesh, const ConductivityTable& sigma);

  // The conductivity at x0 (that of its tet). InputError when x0 lies outside the mesh or the
  // conductivity there is anisotropic (the closed form of u_inf here is the isotropic one).
  double sigmaAt(const Vec3& x0) const;
  // Adds the correction's load f (mA, indexed by mesh vertex) of the dipole to b.
  void addLoad(const Vec3& x0, const Vec3& moment, Eigen::VectorXd& b) const;
  // The loads of unit moments along x, y and z at x0 (columns; the load of M is F M, since u_inf
  // is linear in M). For lead fields: u_e^T F is an electrode's row for this source.
  Eigen::MatrixX3d unitLoads(const Vec3& x0) const;
  // u_inf at every mesh vertex (V); 0 at a vertex closer than 1e-9 mm to x0.
  std::vector<double> singularPotential(const Vec3& x0, const Vec3& moment) const;
  static double singularPotential(const Vec3& x0, const Vec3& moment, double sigmaInf, const Vec3& x);

private:
  const TetMesh& mesh_;
  TetLocator locator_;
  std::vector<SymTensor6> sigma_;             // per tet
  std::vector<std::array<int32_t, 3>> faces_; // boundary faces, counter-clockwise seen from outside
  std::vector<std::pair<int32_t, double>> boundaryShare_; // boundary vertex, its share of the area
};

} // namespace tetflow
