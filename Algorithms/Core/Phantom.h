#pragma once
// Analytic phantoms: exactly known label volumes for defaults and tests.
//
// Every phantom is a list of spheres painted in order onto a background label (later spheres win),
// centred at the physical origin (0,0,0). A voxel gets the label of the last sphere containing its
// centre (centre sampling). The analytic volume of each label is known exactly
// (analyticVolumes), so fidelity can be measured against it; the voxel volume converges to it at
// first order in voxel size.
//
// Kinds (values are stable; names are the CreatePhantom `kind` enum):
//   head        four concentric layers: 1 scalp, 2 skull, 3 CSF, 4 brain, background 0 (air);
//               the volume carries these names (Volume::labelNames)
//   sphere      one sphere (label 1) in a box of background 0
//   two_spheres two spheres of equal radius touching at the origin: label 1 (x<0), label 2 (x>0)
//   shell       a thin shell (label 1, `shell_thickness` thick) around a core (label 2)
//   blob        a sphere (label 1) and, away from it, a tiny isolated blob (label 2): the voxel
//               nearest (0.55 R, 0, 0) plus its 6 face neighbours (7 voxels)
#include <string>
#include <vector>
#include <map>

#include "Volume.h"

namespace tetflow {

enum class PhantomKind : int { Head = 0, Sphere = 1, TwoSpheres = 2, Shell = 3, Blob = 4 };
const char* phantomKindName(PhantomKind k);
PhantomKind phantomKindFromName(const std::string& name); // InputError lists the valid names

struct PhantomParams {
  PhantomKind kind = PhantomKind::Head;
  double voxel_size = 2.0;     // mm, isotropic voxel edge
  double radius = 92.0;        // mm: outer radius (head: scalp; sphere/shell/blob: the sphere;
                               //     two_spheres: each sphere)
  // head only: outer radii of skull, CSF and brain (mm); must satisfy
  //   radius > skull_radius > csf_radius > brain_radius > 0.
  double skull_radius = 86.0;
  double csf_radius = 80.0;
  double brain_radius = 78.0;
  double shell_thickness = 3.0; // mm, shell only (must be < radius)
  double margin = 4.0;          // mm of background between the shapes and the box
  int dims = 0;                 // voxels per axis; 0 = just enough for the shapes + margin
};

struct PhantomSphere {
  Vec3 center;
  double radius;
  int32_t label;
};

// Axis-aligned box [lo, hi) painted after the spheres (the blob's voxel cells).
struct PhantomBox {
  Vec3 lo, hi;
  int32_t label;
};

struct Phantom {
  PhantomParams params;
  int32_t background = 0;
  std::vector<PhantomSphere> spheres; // painted in order
  std::vector<PhantomBox> boxes;      // painted after the spheres
  LabelVolume volume;

  // Label of the analytic phantom at physical point p (same rule as the voxels).
  int32_t labelAt(const Vec3& p) const;
  // Exact volume (mm^3) of each non-background label in the analytic phantom. For `blob`, label 2
  // is the union of 7 voxel cells (a 3-D cross), so its volume is exactly 7 voxel volumes.
  std::map<int32_t, double> analyticVolumes() const;
};

// Throws InputError naming the parameter when a value is out of range.
Phantom makePhantom(const PhantomParams& params);

} // namespace tetflow
