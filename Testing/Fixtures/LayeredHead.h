#pragma once
// A realistic layered head label volume (1 mm, 182 x 218 x 182, MNI152 space) built from two
// public atlases of Debian's package mricron-data (installed by scripts/setup.sh):
//   HarvardOxford-cort-maxprob-thr0-1mm.nii.gz   cortical gyri (48 labels), gives folds and grid
//   JHU-WhiteMatter-labels-1mm.nii.gz            white-matter tracts (48 labels), always white
// Labels: 0 air (outside, and the enclosed cavities inside), 1 scalp, 2 skull, 3 CSF, 4 grey
// matter, 5 white matter. What is built, and why, is commented step by step in LayeredHead.cpp.
// Deterministic for a given (variant, voxel): fixed seeds, std::mt19937 with explicit arithmetic.
// Output grid: identity axes (LPS), voxel centres at MNI positions (x = -(origin_x + i), ...).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "Algorithms/Core/Volume.h"

namespace tetflow {

enum LayeredHeadLabel : int32_t {
  kHeadAir = 0, kHeadScalp = 1, kHeadSkull = 2, kHeadCsf = 3, kHeadGrey = 4, kHeadWhite = 5
};

struct LayeredHeadParams {
  int variant = 0;                          // 0, 1, 2: seeds the thickness fields and specks
  int voxel = 1;                            // 1 = 1 mm; 2 = 2 mm, 4 = 4 mm (most frequent label of each
                                            // 2x2x2 / 4x4x4 block, ties to the lower label)
  double csfMin = 1.0, csfMax = 3.0;        // outer CSF shell (mm); 1 = one voxel
  double skullMin = 4.0, skullMax = 7.0;    // skull (mm); the temples go towards skullMin
  double scalpMin = 4.0, scalpMax = 7.0;    // scalp (mm)
  double greyMin = 2.5, greyMax = 3.0;      // cortex: brain within this of CSF is grey (mm)
  double sulcusMin = 10.0, sulcusMax = 15.0; // sulci reach this deep below the brain surface (mm)
  bool cavities = true;                     // frontal sinus, mastoid cells, ear canals
  bool specks = true;                       // 1-3 voxel islands (8 of them)
  bool parcels = false;                     // 1 mm only: the brain alone (0 around it), its grey
                                            // matter split into HarvardOxford's cortical labels
                                            // per hemisphere (labels 6-101)
};

// Landmarks of what was placed, in voxel indices of the 1 mm grid (for tests and reports).
struct LayeredHeadInfo {
  std::array<std::array<int, 3>, 2> earCanal{};  // outer end of each canal (on its axis)
  std::array<int, 3> frontalSinus{};             // centre
  std::array<std::array<int, 3>, 2> mastoid{};   // centres
  std::vector<std::array<int, 4>> specks;        // i, j, k, label
  int64_t ventricleVoxels = 0, sulcusVoxels = 0;
};

// "/usr/share/mricron/templates", or $TETFLOW_MRICRON_DIR when set and not empty.
std::string mricronTemplatesDir();
// True when both atlases are readable files in `templatesDir`; else false and, when `why` is
// given, a message naming the missing file and the package that provides it (for GTEST_SKIP).
bool mricronAtlasesPresent(const std::string& templatesDir, std::string* why = nullptr);

// Throws InputError for missing atlases, unexpected atlas grids or bad parameters.
LabelVolume makeLayeredHead(const std::string& templatesDir, const LayeredHeadParams& p = {},
                            LayeredHeadInfo* info = nullptr);

// Exact Euclidean distance (voxels) of every voxel to the nearest voxel with mask != 0 (0 there;
// +infinity everywhere when the mask is empty). Separable, through euclideanFeatureTransform.
std::vector<float> distanceToMask(const std::array<int64_t, 3>& dims, const std::vector<uint8_t>& mask);

} // namespace tetflow
