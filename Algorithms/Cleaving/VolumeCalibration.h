#pragma once
// Volume calibration of cleaving (CleaveMesh `volume_calibration`, off by default): per-material
// offsets added to the indicator functions so that each material's volume after cleaving and label
// repair matches its input volume (the voxels of a label volume, the argmax voxels of indicator
// functions).
//
// Why: a layer about as thin as the background cells (the head's one-voxel CSF) comes out thinner
// than its voxels, because cleaving cuts the corners of its staircase on both sides. Raising that
// material's indicator by a constant moves all its interfaces outward by about
// offset / |grad(f_L - f_M)|; its neighbours give up that volume.
//
// How, with R rounds (R >= 1; the cost is R + 2 cleaves, each but the last followed by the label
// repair when one is given):
//  - trial 0: cleave with no offsets; e_L = relative volume error of material L. Only materials
//    with |e_L| above kCalibrationTolerance and above half the worst |e| move (a large material a
//    percent off would otherwise push into the thin layer beside it). For them a model step: the offset that
//    would move L's interfaces (area A_L, after the repair) by e_L V_L / A_L, using the median
//    slope of f_L - f_M across the cleaved faces (before the repair, where they follow the
//    functions);
//  - trials 1..R: cleave with the current offsets; then (before trial R) a secant step per material
//    from its last two (offset, error) pairs (by the same selection; left alone when its error did
//    not change);
//  - the final cleave uses the offsets of the best trial (smallest worst |e_L|; trial 0 when none
//    is better), so calibration never makes the volumes worse; the caller repairs it, which gives
//    exactly that trial's labels when nothing is stripped (cleaving and repair are deterministic;
//    with strip_exterior the repair no longer sees the stripped material, a small difference).
// Offsets are clamped to [-kMaxCalibrationOffset, kMaxCalibrationOffset]. Sums run in face order,
// so the result does not depend on the thread count. The response is smooth on graded meshes with
// cells finer than the layer (head phantom, octree down to 4 mm: CSF -12 % -> +0.1 % in two
// rounds) and can be erratic when the layer is thinner than the cells, where the repair decides
// much of the layer: the best trial is kept, and the report gives the errors before and after and
// the offsets used. Moving interfaces can lower the smallest dihedral angle (octree transition tets
// are cut where they were not).
#include <memory>
#include <vector>

#include "Cleaver.h"
#include "LabelRepair.h"
#include "Materials.h"

namespace tetflow {

inline constexpr double kMaxCalibrationOffset = 0.25;
// Materials within this relative volume error keep their offset.
inline constexpr double kCalibrationTolerance = 0.01;

// `base` plus a constant per material (dense index), on the materials a sample lists.
class OffsetMaterials : public MaterialSet {
public:
  OffsetMaterials(const MaterialSet& base, std::vector<float> offsets);
  void sample(const Vec3& p, std::vector<MaterialSample>& out) const override;
  float absentValue() const override { return base_.absentValue(); }
  std::string describe() const override;
  LabelVolume dominantLabels() const override { return base_.dominantLabels(); }
  std::shared_ptr<const LabelVolume> sharedDominantLabels() const override { return base_.sharedDominantLabels(); }

private:
  const MaterialSet& base_;
  std::vector<float> offsets_;
};

struct VolumeCalibration {
  int rounds = 0;                   // offset updates made
  int bestRound = 0;                // the trial whose offsets the final cleave used (0: none)
  std::vector<double> offsets;      // per material (dense index), as the final cleave used them
  std::vector<double> errorsBefore; // relative volume error per material without offsets
  std::vector<double> errorsBest;   // relative volume error per material of that trial
};

// rounds 0..10 (0: one plain cleave). `offsetMaterials` receives the materials of the final cleave
// (`base` plus the offsets; it refers to `materials`, which must outlive it).
CleaveResult cleaveCalibrated(const BackgroundMesh& background, const MaterialSet& materials,
                              const CleaveParams& params, int rounds, const LabelRepairParams* repair,
                              Progress& progress, VolumeCalibration& calibration,
                              std::unique_ptr<OffsetMaterials>& offsetMaterials);

void writeVolumeCalibrationReport(const VolumeCalibration& c, const std::vector<int32_t>& labels, Report& report);

} // namespace tetflow
