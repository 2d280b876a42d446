#pragma once
// Unstructured adaptive background mesh from an electrostatic particle system (seed §5.4),
// tetrahedralized by TetGen and freed of slivers (seed §5.6 notes that the particle mesh "may
// produce low volume elements"; here they are removed before cleaving).
//
// Frame. Everything is computed in the volume grid's own frame (local coordinates, as for the
// octree: the box spans the voxel cells plus `padding`, lo = -spacing/2 - padding), then mapped to
// physical space with the grid's origin and axes. The target spacing at a point is
// l(x) = size_scale * sizing(x) (trilinear interpolation of the sizing volume, constant beyond its
// outer sample centres), clamped to [min_size, max_size] when those are given.
//
// Stages (named, timed, reported through Progress):
//   boundary   particles on the box first, so the mesh tiles the box exactly: its 8 corners; on
//              each of its 12 edges, points at equal steps of the integral of 1/l along the edge
//              (round(integral) segments, so spacing follows l exactly in 1-D); on each of its 6
//              faces, round(integral of 2/(sqrt(3) l^2) - perimeter points / 2) points (the
//              density of equilateral triangles of edge l) seeded in proportion to that density and
//              relaxed in the face's plane, with the edge points fixed, by a short-range repulsion
//              between points closer than 1.2 times their mean l (DistMesh-style springs).
//   potential  the background charge (seed §5.4.1): density rho = sqrt(2) / l^3, the number
//              density of a close packing with nearest-neighbour distance l, sampled at the nodes of
//              a Poisson grid (poisson_samples nodes along the box's longest axis), scaled so the
//              box's background charge equals the particles' total charge. Boundary particles carry
//              the share of a lattice site the box keeps (1/2 on a face, 1/4 on an edge, 1/8 at a
//              corner), interior ones 1, so the system is neutral and the boundary layers neutralise
//              half a layer's worth of background, as in a lattice. The background potential
//              (seed §5.4.2) solves the 7-point finite-difference Poisson equation
//              lap(phi) = 4 pi rho (Gaussian units, the background negative) by conjugate gradients,
//              with Dirichlet values on the box equal to the free-space potential of the same
//              charges (Barnes-Hut, theta 0.3). Its field -grad(phi) (central differences at the
//              nodes) is interpolated trilinearly, so the force is continuous everywhere.
//   relax      (seed §5.4.3) interior particles are seeded in proportion to rho and moved by the
//              force of all particles (Barnes-Hut tree, opening ratio `theta`) plus the background
//              field, overdamped: a particle moves by step * F / k with k = (4 pi / 3) rho(x) (the
//              restoring force per unit displacement of a charge in its background), by at most
//              0.3 l(x), and stays at least 0.2 l(x) inside the box. The step starts at 0.5, shrinks
//              (x 0.7) when the system's electrostatic energy rose and grows (x 1.05, up to 1) when it
//              fell. The run stops when the largest move is below move_tolerance * l, when the
//              energy has not reached a new minimum for 15 iterations, or after max_iterations.
//              Every particle's force is computed independently, in parallel; the result does not
//              depend on the number of threads.
//   delaunay   TetGen (plain Delaunay of all particles; its hull is the box).
//   slivers    the mesh improvement of Algorithms/MeshImprovement (one material, so vertices move
//              freely inside the box and within its faces and edges, flips re-tile freely) with the
//              targets min_angle / max_angle.
// Result: positively oriented tets tiling the box, material 0 everywhere.
#include <cstdint>
#include <string>
#include <vector>

#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Report.h"
#include "Algorithms/Core/Volume.h"
#include "Algorithms/MeshImprovement/MeshImprovement.h"
#include "BccLattice.h"

namespace tetflow {

struct ParticleParams {
  double padding = 0.0;        // mm added around the volume's box on every side (>= 0)
  double min_size = 0.0;       // mm, lower clamp of the spacing; 0 = none
  double max_size = 0.0;       // mm, upper clamp of the spacing; 0 = none
  double size_scale = 1.0;     // spacing = size_scale * sizing field, > 0
  int max_iterations = 200;    // relaxation iterations at most, >= 0
  double theta = 0.5;          // Barnes-Hut opening ratio (cell edge / distance), in [0, 1.5]
  double move_tolerance = 0.01; // stop when every particle moves less than this * l, > 0
  int poisson_samples = 64;    // Poisson grid nodes along the box's longest axis, in [8, 512]
  double min_angle = 15.0;     // sliver removal targets [deg] (the mesh improvement's)
  double max_angle = 150.0;
  int improve_passes = 8;
  uint32_t seed = 1;           // seeds the initial placement (the run is deterministic)
};

struct ParticleStats {
  int64_t corners = 0, edgeParticles = 0, faceParticles = 0, interiorParticles = 0;
  double backgroundCharge = 0.0;  // integral of sqrt(2)/l^3 over the box (the ideal count)
  int faceIterations = 0;
  int poissonNodes = 0, poissonIterations = 0;
  double poissonResidual = 0.0;
  int iterations = 0;             // relaxation iterations run
  std::string stopReason;
  double secondsPerIteration = 0.0;
  double energyFirst = 0.0, energyLast = 0.0; // electrostatic energy (Gaussian units, mm^-1)
  double lastMaxMove = 0.0;       // largest move of the last iteration / l
  int64_t delaunayTets = 0, flatTets = 0;
  // Sliver removal; its minBefore / maxBefore are the Delaunay mesh's dihedral range, minAfter /
  // maxAfter the result's.
  ImproveStats improve;
  // Spacing: at every vertex, the mean length of its edges / l there.
  double spacingMedian = 0.0, spacingP05 = 0.0, spacingP95 = 0.0;
};

struct ParticleMeshResult {
  BackgroundMesh background; // kind empty (unstructured), cells = 0
  ParticleStats stats;
};

// `sizing`: element sizes in mm (ComputeSizingField), any grid, every value finite and > 0.
// Throws InputError naming the culprit (parameter, bad sizing value, more than 2^28 particles) and
// Cancelled when cancelled.
ParticleMeshResult generateParticleMesh(const GridGeometry& grid, const ScalarVolume& sizing,
                                        const ParticleParams& params, Progress& progress);

void reportParticleMesh(const ParticleStats& stats, Report& report);

} // namespace tetflow
