// Tests for Algorithms/Cleaving/VolumeCalibration: a one-voxel shell's volume comes back on a lattice
// finer than the shell and on one as coarse as it; more rounds never make the worst error worse;
// the topology stays exact; bad rounds are refused.
#include "Algorithms/Cleaving/VolumeCalibration.h"

#include <gtest/gtest.h>

#include <cmath>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/Core/Errors.h"
#include "Algorithms/Quality/Certificate.h"
#include "Algorithms/Quality/MeshQuality.h"
#include "TestUtil.h"

namespace tetflow {
namespace {

// Label 1: voxel centres with 9 <= r < 9 + t around a core (2) in 32^3 voxels of 1 mm.
std::shared_ptr<const LabelVolume> calibrationShell(double t) {
  auto v = std::make_shared<LabelVolume>();
  GridGeometry g;
  g.dims = {32, 32, 32};
  v->allocate(g, 0);
  const double c = 15.5;
  for (int k = 0; k < 32; ++k)
    for (int j = 0; j < 32; ++j)
      for (int i = 0; i < 32; ++i) {
        const double r = std::sqrt((i - c) * (i - c) + (j - c) * (j - c) + (k - c) * (k - c));
        v->at(i, j, k) = r < 9 ? 2 : (r < 9 + t ? 1 : 0);
      }
  return v;
}

struct CalibrationOutcome {
  double worst = 0.0, shellError = 0.0, minDihedral = 0.0;
  VolumeCalibration calibration;
};

CalibrationOutcome calibrate(const std::shared_ptr<const LabelVolume>& vol, double cell, int rounds) {
  NullProgress np;
  const LabelMaterials mats(vol, 0.5);
  const BackgroundMesh bg = generateRegularBcc(mats.grid(), BccParams{cell, 0.0}, np);
  const LabelRepairParams rp;
  CalibrationOutcome o;
  std::unique_ptr<OffsetMaterials> calibrated;
  // The seed's linear interpolation of the cuts: the case calibration was made for (with exact
  // interfaces the shell loses 4 %, not 7.5 %; CleaveMesh corrects volumes instead).
  CleaveParams cp;
  cp.interface_points = CleaveParams::InterfacePoints::Linear;
  CleaveResult r = cleaveCalibrated(bg, mats, cp, rounds, &rp, np, o.calibration, calibrated);
  repairLabels(r.mesh, *calibrated, rp, np);
  const QualityResult q = evaluateQuality(r.mesh, QualityParams{}, np);
  EXPECT_TRUE(q.valid);
  o.minDihedral = q.minDihedral;
  const CertificateResult c = certifyMesh(r.mesh, *vol, np);
  EXPECT_EQ(c.lost + c.split + c.merged + c.spurious, 0);
  EXPECT_TRUE(c.spuriousContacts.empty());
  for (const auto& lc : c.labels) {
    o.worst = std::max(o.worst, std::abs(lc.relError));
    if (lc.label == 1) o.shellError = lc.relError;
  }
  // The final mesh is the best trial's: the report's calibrated errors are the certificate's.
  for (size_t m = 0; m < o.calibration.errorsBest.size(); ++m)
    for (const auto& lc : c.labels)
      if (lc.label == mats.labels()[m]) {
        EXPECT_NEAR(lc.relError, o.calibration.errorsBest[m], 1e-9);
      }
  return o;
}

TEST(VolumeCalibration, AOneVoxelShellOnAFinerLatticeGetsItsVolumeBack) {
  const auto v = calibrationShell(1.0);
  const CalibrationOutcome before = calibrate(v, 1.0, 0);
  const CalibrationOutcome after = calibrate(v, 1.0, 1);
  EXPECT_LT(before.shellError, -0.07); // measured -7.5 %
  EXPECT_LT(std::abs(after.shellError), 0.01); // measured +0.2 %
  EXPECT_GT(after.calibration.offsets[1], 0.0);  // the shell's indicator went up
  EXPECT_NEAR(after.calibration.errorsBefore[1], before.shellError, 1e-9);
  EXPECT_GE(after.minDihedral, 15.0); // measured 19.4 (21.6 without)
}

TEST(VolumeCalibration, MoreRoundsNeverMakeTheWorstErrorWorse) {
  // On a lattice as coarse as the shell the response is slow and can be erratic; the best trial is
  // kept.
  const auto v = calibrationShell(1.0);
  double previous = calibrate(v, 2.0, 0).worst; // measured 35.3 %
  for (int rounds = 1; rounds <= 3; ++rounds) {
    const CalibrationOutcome o = calibrate(v, 2.0, rounds);
    EXPECT_LE(o.worst, previous + 1e-12) << rounds << " rounds";
    previous = o.worst;
  }
  // Measured: the shell -35.3 % -> -24.4 % -> -13.6 %, then its offset is at the clamp.
  EXPECT_LT(previous, 0.15);
}

TEST(VolumeCalibration, BadRoundsAreRefused) {
  NullProgress np;
  const auto v = calibrationShell(2.0);
  const LabelMaterials mats(v, 0.5);
  const BackgroundMesh bg = generateRegularBcc(mats.grid(), BccParams{2.0, 0.0}, np);
  VolumeCalibration c;
  std::unique_ptr<OffsetMaterials> om;
  EXPECT_THROW_MSG(cleaveCalibrated(bg, mats, CleaveParams{}, 11, nullptr, np, c, om), InputError,
                   "volume_calibration");
}

} // namespace
} // namespace tetflow
