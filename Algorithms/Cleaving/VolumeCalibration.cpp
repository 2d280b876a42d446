#include "VolumeCalibration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Quality/LabelTopology.h"

namespace tetflow {

OffsetMaterials::OffsetMaterials(const MaterialSet& base, std::vector<float> offsets)
    : base_(base), offsets_(std::move(offsets)) {
  labels_ = base.labels();
  grid_ = base.grid();
  inputVolumes_ = base.inputVolumes();
  offsets_.resize(labels_.size(), 0.0f);
}

void OffsetMaterials::sample(const Vec3& p, std::vector<MaterialSample>& out) const {
  base_.sample(p, out);
  for (auto& s : out) s.value += offsets_[size_t(s.material)];
}

std::string OffsetMaterials::describe() const {
  std::ostringstream o;
  o << base_.describe() << ", with volume-calibration offsets";
  return o.str();
}

namespace {

size_t denseIndex(const std::vector<int32_t>& labels, int32_t label) {
  return size_t(std::find(labels.begin(), labels.end(), label) - labels.begin());
}

// Relative volume error per material (dense index).
std::vector<double> volumeErrors(const TetMesh& mesh, const MaterialSet& mats) {
  const auto& labels = mats.labels();
  const std::vector<MaterialTally> tally = tallyMaterials(mesh, labels);
  std::vector<double> err(labels.size(), 0.0);
  for (size_t m = 0; m < labels.size(); ++m) {
    const double input = mats.inputVolumes()[m];
    err[m] = input > 0 ? (tally[m].volume - input) / input : 0.0;
  }
  return err;
}

// Per material: interface area [mm^2] and the median slope of f_L - f_M across its faces [1/mm]
// (central differences a quarter voxel either side of each face centroid), on a cleaved mesh.
void interfaceAreaAndSlope(const TetMesh& mesh, const MaterialSet& mats, Progress& progress, std::vector<double>& area,
                           std::vector<double>& slope) {
  const std::vector<int32_t> nb = tetFaceNeighbours(mesh, progress);
  const auto& labels = mats.labels();
  const auto& sp = mats.grid().spacing;
  const double h = 0.25 * std::min({sp[0], sp[1], sp[2]});
  const int64_t n = static_cast<int64_t>(mesh.numTets());
  // Per tet face; written by the loop below (pairA = -1 where the face is not an interface), so
  // not zeroed first: the loop's threads touch the pages, not one thread up front.
  const size_t nf = size_t(4 * n);
  const auto faceArea = std::make_unique_for_overwrite<double[]>(nf);
  const auto faceSlope = std::make_unique_for_overwrite<double[]>(nf);
  const auto pairA = std::make_unique_for_overwrite<int32_t[]>(nf);
  const auto pairB = std::make_unique_for_overwrite<int32_t[]>(nf);
  progress.checkCancel();
  LoopCancel cancel(progress);
#pragma omp parallel
  {
    std::vector<MaterialSample> lo, hi;
#pragma omp for schedule(dynamic, 4096)
    for (int64_t t = 0; t < n; ++t) {
      if (cancel.skip(t)) continue;
      for (int f = 0; f < 4; ++f) {
        pairA[size_t(4 * t + f)] = -1;
        const int32_t o = nb[size_t(4 * t + f)];
        if (o <= t || mesh.materials[size_t(o)] == mesh.materials[size_t(t)]) continue;
        const int32_t a = int32_t(denseIndex(labels, mesh.materials[size_t(t)]));
        const int32_t b = int32_t(denseIndex(labels, mesh.materials[size_t(o)]));
        if (a >= int32_t(labels.size()) || b >= int32_t(labels.size())) continue;
        const auto& q = mesh.tets[size_t(t)];
        const Vec3& p0 = mesh.points[size_t(q[kTetFaceVertices[f][0]])];
        const Vec3& p1 = mesh.points[size_t(q[kTetFaceVertices[f][1]])];
        const Vec3& p2 = mesh.points[size_t(q[kTetFaceVertices[f][2]])];
        Vec3 nrm = cross(p1 - p0, p2 - p0);
        const double len = norm(nrm);
        if (len <= 0) continue;
        nrm = (1.0 / len) * nrm;
        const Vec3 c = (1.0 / 3.0) * (p0 + p1 + p2);
        if (dot(nrm, mesh.points[size_t(q[f])] - c) > 0) nrm = (-1.0) * nrm; // from t towards o
        auto diff = [&](const std::vector<MaterialSample>& s) {
          double fa = mats.absentValue(), fb = mats.absentValue();
          for (const auto& x : s) {
            if (x.material == a) fa = x.value;
            if (x.material == b) fb = x.value;
          }
          return fa - fb;
        };
        mats.sample(c - h * nrm, lo);
        mats.sample(c + h * nrm, hi);
        const size_t i = size_t(4 * t + f);
        faceArea[i] = 0.5 * len;
        faceSlope[i] = (diff(lo) - diff(hi)) / (2 * h);
        pairA[i] = a;
        pairB[i] = b;
      }
    }
  }
  cancel.rethrow();
  area.assign(labels.size(), 0.0);
  std::vector<std::vector<double>> slopes(labels.size());
  for (size_t i = 0; i < nf; ++i)
    if (pairA[i] >= 0)
      for (int32_t m : {pairA[i], pairB[i]}) {
        area[size_t(m)] += faceArea[i];
        if (faceSlope[i] > 1e-6) slopes[size_t(m)].push_back(faceSlope[i]);
      }
  slope.assign(labels.size(), 0.0);
  for (size_t m = 0; m < labels.size(); ++m) {
    auto& v = slopes[m];
    if (v.empty()) continue;
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
    slope[m] = v[v.size() / 2];
  }
}

} // namespace

CleaveResult cleaveCalibrated(const BackgroundMesh& background, const MaterialSet& materials,
                              const CleaveParams& params, int rounds, const LabelRepairParams* repair,
                              Progress& progress, VolumeCalibration& calibration,
                              std::unique_ptr<OffsetMaterials>& offsetMaterials) {
  if (rounds < 0 || rounds > 10) throw InputError("volume_calibration must be 0..10 rounds");
  const size_t k = materials.labels().size();
  std::vector<float> offsets(k, 0.0f), best = offsets;
  std::vector<double> prevOffset(k, 0.0), prevError(k, 0.0);
  double bestWorst = std::numeric_limits<double>::infinity();
  calibration = VolumeCalibration{};
  // Trials keep every material (the stripped one's interfaces count too).
  CleaveParams inner = params;
  inner.strip_exterior.reset();
  for (int r = 0; r <= rounds; ++r) {
    OffsetMaterials mats(materials, offsets);
    CleaveResult trial = cleave(background, mats, inner, progress);
    // Round 1's model step: slopes where cleaving put the interfaces, areas after the repair.
    std::vector<double> area, slope, unused;
    progress.beginStage("calibrate volumes");
    if (r == 0) interfaceAreaAndSlope(trial.mesh, mats, progress, area, slope);
    if (repair) repairLabels(trial.mesh, mats, *repair, progress);
    progress.beginStage("calibrate volumes");
    if (r == 0 && repair) interfaceAreaAndSlope(trial.mesh, mats, progress, area, unused);
    const std::vector<double> err = volumeErrors(trial.mesh, materials);
    if (r == 0) calibration.errorsBefore = err;
    double worst = 0.0;
    for (size_t m = 0; m < k; ++m)
      if (materials.inputVolumes()[m] > 0) worst = std::max(worst, std::abs(err[m]));
    if (worst < bestWorst) { // the best trial so far (ties keep the earlier one)
      bestWorst = worst;
      best = offsets;
      calibration.errorsBest = err;
      calibration.bestRound = r;
    }
    if (r == rounds) break;
    // Only the materials off by at least half the worst error move: a large material a percent
    // off, moved as well, would push into the thin layer next to it.
    const double threshold = std::max(kCalibrationTolerance, 0.5 * worst);
    bool changed = false;
    for (size_t m = 0; m < k; ++m) {
      const double input = materials.inputVolumes()[m];
      if (input <= 0 || std::abs(err[m]) <= threshold) continue;
      double next = offsets[m];
      if (r == 0) {
        if (area[m] > 0 && slope[m] > 0) next = -err[m] * input / area[m] * slope[m];
      } else if (err[m] != prevError[m]) {
        next = offsets[m] - err[m] * (offsets[m] - prevOffset[m]) / (err[m] - prevError[m]);
      }
      next = std::clamp(next, -kMaxCalibrationOffset, kMaxCalibrationOffset);
      prevOffset[m] = offsets[m];
      prevError[m] = err[m];
      changed = changed || float(next) != offsets[m];
      offsets[m] = float(next);
    }
    ++calibration.rounds;
    if (!changed) break;
  }
  calibration.offsets.assign(best.begin(), best.end());
  offsetMaterials = std::make_unique<OffsetMaterials>(materials, best);
  return cleave(background, *offsetMaterials, params, progress);
}

void writeVolumeCalibrationReport(const VolumeCalibration& c, const std::vector<int32_t>& labels, Report& report) {
  report.set("calibration_rounds", c.rounds);
  report.set("calibration_best_round", c.bestRound);
  for (size_t m = 0; m < labels.size() && m < c.offsets.size(); ++m) {
    const std::string k = "calibration_material_" + std::to_string(labels[m]) + "_";
    report.set(k + "offset", c.offsets[m]);
    if (m < c.errorsBefore.size()) report.set(k + "error_before", c.errorsBefore[m]);
    if (m < c.errorsBest.size()) report.set(k + "error_calibrated", c.errorsBest[m]);
  }
}

} // namespace tetflow
