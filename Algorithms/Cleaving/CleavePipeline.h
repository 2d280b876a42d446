#pragma once
// What CleaveMesh runs, as one call: cleaving (Cleaver.h, or volume calibration around it:
// VolumeCalibration.h), the label repair (LabelRepair.h), stripping the exterior (Stripping.h) and
// the volume correction (VolumeCorrection.h), in that order:
//  - the repair sees every label (a fragment in the air becomes air and is stripped with it);
//  - stripping removes the exterior of one label and keeps its cavities (unless strip_cavities);
//    the label's target volume becomes its cavities' voxels;
//  - the correction brings every material to its voxels' volume (the stripped label to its
//    cavities', or none).
// The label-preserving improvement (MeshImprovement) comes after, in the module. Per-material
// figures (CleaveResult::materials) are those after the last step.
#include <memory>
#include <optional>

#include "Algorithms/Quality/LabelTopology.h"

#include "Cleaver.h"
#include "LabelRepair.h"
#include "Stripping.h"
#include "VolumeCalibration.h"
#include "VolumeCorrection.h"

namespace tetflow {

inline LabelRepairParams withPointContacts() {
  LabelRepairParams p;
  p.points = true;
  return p;
}

struct CleavePipelineParams {
  CleaveParams cleave;              // its strip_exterior is not used: see `strip`
  int calibration_rounds = 0;       // VolumeCalibration (0 = off)
  bool repair = true;
  LabelRepairParams repairParams = withPointContacts(); // CleaveMesh's defaults
  std::optional<int32_t> strip;     // label whose exterior is removed
  bool stripCavities = false;
  // With `strip`: the background tets deep in the label's exterior are left out of the cleave
  // (CleaveParams::cull_exterior); the repair and the stripping see the pieces around them as
  // joined through them, and the stripping counts them as stripped. The mesh is the one without
  // culling (on lattices: identical; the tests compare), made in less time and memory.
  bool cull = true;
  bool correct = true;
  VolumeCorrectionParams correction;
};

struct CleavePipelineResult {
  CleaveResult cleaved;
  VolumeCalibration calibration;
  LabelRepairStats repair;
  StripStats strip;
  VolumeCorrectionStats correction;
  std::unique_ptr<OffsetMaterials> calibrated; // the materials the calibrated cleave used
  // The image's components and contacts (of materials.dominantLabels()), computed once for the
  // repair and the stripping; finishLabels uses it again.
  std::shared_ptr<const LabelImageTopology> image;
  // The mesh's face neighbours (tetFaceNeighbours) as the last step that needed them left them
  // (empty when none did): valid while the tets stay as they are (vertex moves leave them so).
  std::vector<int32_t> faceNeighbours;
};

// After steps that move vertices or change tets (the improvement): pieces that became fragments (a
// tet's centroid moved off its label's voxels) are dissolved as the repair's last step does.
// Returns the pieces relabelled. r.faceNeighbours must be the mesh's or empty: a caller that changed
// the tets since cleavePipeline carries them (improveMesh does) or clears them. Used when not empty,
// computed otherwise; freed either way.
int64_t finishLabels(TetMesh& mesh, const MaterialSet& materials, CleavePipelineResult& r, Progress& progress);

CleavePipelineResult cleavePipeline(const BackgroundMesh& background, const MaterialSet& materials,
                                    const CleavePipelineParams& params, Progress& progress);

// The Report of every step that ran (writeCleaveReport, repair_*, strip_*, volume_correction_*,
// calibration).
void writeCleavePipelineReport(const CleavePipelineResult& r, const CleavePipelineParams& p,
                               const std::vector<int32_t>& labels, Report& report);

} // namespace tetflow
