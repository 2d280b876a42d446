#pragma once
// Materials as smooth indicator functions (seed §4.3): material i is present at x when
// f_i(x) > f_j(x) for all j != i. Cleaving queries them at background-mesh vertices only.
//
// Two sources:
//  - LabelMaterials: a label volume (any label values). f_i(x) is the fraction of label i under
//    a smooth, compactly supported kernel centred at x (a Gaussian of standard deviation
//    `blend_sigma` voxels, tapered to zero at 2.5 sigma). Values are in [0,1] and sum to 1; the
//    0.5 level between two labels sits on the voxel faces between them. Computed on demand at
//    the query point: memory does not grow with (labels x voxels).
//  - IndicatorMaterials: one scalar volume per material on a common grid, trilinearly
//    interpolated (outside the grid the nearest boundary value is used).
//
// Material indices are dense 0..K-1; labels() maps them to the label values users know.
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "Algorithms/Core/Volume.h"

namespace tetflow {

struct MaterialSample {
  int32_t material; // dense index
  float value;
};

// The material present at a sampled point: the largest value, ties to the lower material index
// (entries are sorted by material); 0 for an empty sample. Cleaving, the sizing field and the
// octree's uniform_interfaces all label points this way.
inline int32_t dominantMaterial(const std::vector<MaterialSample>& s) {
  int32_t best = s.empty() ? 0 : s[0].material;
  float bestV = s.empty() ? 0.0f : s[0].value;
  for (const auto& x : s)
    if (x.value > bestV) { // strict: ties keep the lower material index
      best = x.material;
      bestV = x.value;
    }
  return best;
}

class MaterialSet {
public:
  virtual ~MaterialSet() = default;
  int numMaterials() const { return static_cast<int>(labels_.size()); }
  const std::vector<int32_t>& labels() const { return labels_; }
  // Sampling grid: its voxel cells define the domain box.
  const GridGeometry& grid() const { return grid_; }
  // Voxel volume (mm^3) of each material in the input (argmax per voxel for indicators).
  const std::vector<double>& inputVolumes() const { return inputVolumes_; }
  // Values at p (physical, mm): entries sorted by material; materials not listed have value
  // absentValue(). `out` is cleared first.
  virtual void sample(const Vec3& p, std::vector<MaterialSample>& out) const = 0;
  virtual float absentValue() const { return 0.0f; }
  virtual std::string describe() const = 0;
  // The input as labels on grid(): the label volume itself for LabelMaterials; for indicator
  // functions the label of the largest one per voxel (ties to the lower material index).
  virtual LabelVolume dominantLabels() const = 0;
  // The same, shared: the label volume itself for LabelMaterials (no copy of a volume that may be
  // hundreds of megabytes), computed for the others.
  virtual std::shared_ptr<const LabelVolume> sharedDominantLabels() const {
    return std::make_shared<const LabelVolume>(dominantLabels());
  }

protected:
  std::vector<int32_t> labels_;
  GridGeometry grid_;
  std::vector<double> inputVolumes_;
};

// The smoothing every module uses by default (voxels): small enough that a one-voxel layer keeps
// its thickness where the functions cross (its interfaces lie within 0.1 % of a voxel of the voxel
// faces), large enough that the functions are smooth between voxel centres.
inline constexpr double kDefaultBlendSigma = 0.3;

class LabelMaterials : public MaterialSet {
public:
  // blendSigma in voxels (> 0). Throws InputError for an empty volume or bad sigma.
  LabelMaterials(std::shared_ptr<const LabelVolume> volume, double blendSigma);
  void sample(const Vec3& p, std::vector<MaterialSample>& out) const override;
  std::string describe() const override;
  LabelVolume dominantLabels() const override { return *volume_; }
  std::shared_ptr<const LabelVolume> sharedDominantLabels() const override { return volume_; }
  double blendSigma() const { return sigma_; }

private:
  std::shared_ptr<const LabelVolume> volume_;
  std::vector<int32_t> dense_; // label value -> dense index, via sorted labels_ (binary search)
  double sigma_;
  double radius_; // kernel support in voxels
  Mat3 inverse_;  // physical -> index-space rotation (transpose of direction)
  int32_t denseIndex(int32_t label) const;
};

class IndicatorMaterials : public MaterialSet {
public:
  // One volume per material, same grid; labels default to 0..K-1. InputError when grids differ,
  // fewer than one volume, or labels are not unique / of the wrong count.
  IndicatorMaterials(std::vector<ScalarVolume> volumes, std::vector<int32_t> labels = {});
  void sample(const Vec3& p, std::vector<MaterialSample>& out) const override;
  float absentValue() const override { return -1e30f; } // never used: all are listed
  std::string describe() const override;
  LabelVolume dominantLabels() const override;

private:
  // Dense index of the largest indicator at voxel i (ties to the lower index).
  size_t dominantAt(size_t i) const {
    size_t best = 0;
    for (size_t m = 1; m < volumes_.size(); ++m)
      if (volumes_[m].data[i] > volumes_[best].data[i]) best = m;
    return best;
  }

  std::vector<ScalarVolume> volumes_;
  Mat3 inverse_;
};

} // namespace tetflow
