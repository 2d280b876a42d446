#include "Materials.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "Algorithms/Core/Errors.h"

namespace tetflow {

namespace {
Mat3 transpose(const Mat3& m) {
  Mat3 t;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) t[r][c] = m[c][r];
  return t;
}
// Continuous index coordinates of physical point p.
Vec3 toIndex(const GridGeometry& g, const Mat3& inv, const Vec3& p) {
  const Vec3 local = mul(inv, p - g.origin);
  return {local[0] / g.spacing[0], local[1] / g.spacing[1], local[2] / g.spacing[2]};
}
} // namespace

LabelMaterials::LabelMaterials(std::shared_ptr<const LabelVolume> volume, double blendSigma)
    : volume_(std::move(volume)), sigma_(blendSigma) {
  if (!volume_ || volume_->data.empty()) throw InputError("materials: the label volume is empty");
  if (!(blendSigma > 0.0) || !std::isfinite(blendSigma) || blendSigma > 10.0)
    throw InputError("blend_sigma must be in (0, 10] voxels");
  grid_ = volume_->grid;
  grid_.validate("materials");
  radius_ = 2.5 * sigma_;
  // The kernel must reach at least the nearest voxels in every direction.
  radius_ = std::max(radius_, 1.0);
  inverse_ = transpose(grid_.direction);
  const auto counts = labelCounts(*volume_);
  for (const auto& [label, n] : counts) {
    labels_.push_back(label);
    inputVolumes_.push_back(double(n) * grid_.voxelVolume());
  }
}

int32_t LabelMaterials::denseIndex(int32_t label) const {
  return static_cast<int32_t>(std::lower_bound(labels_.begin(), labels_.end(), label) - labels_.begin());
}

void LabelMaterials::sample(const Vec3& p, std::vector<MaterialSample>& out) const {
  out.clear();
  const GridGeometry& g = grid_;
  Vec3 u = toIndex(g, inverse_, p);
  int64_t lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    // Clamp the query into the volume: outside, the boundary values continue.
    u[a] = std::clamp(u[a], 0.0, double(g.dims[a] - 1));
    lo[a] = static_cast<int64_t>(std::ceil(u[a] - radius_));
    hi[a] = static_cast<int64_t>(std::floor(u[a] + radius_));
  }
  // Homogeneous neighbourhood (most queries): one material with value 1, exactly what the sums
  // below give when every weighted voxel has the same label.
  {
    const int32_t first = volume_->at(std::clamp<int64_t>(lo[0], 0, g.dims[0] - 1),
                                      std::clamp<int64_t>(lo[1], 0, g.dims[1] - 1),
                                      std::clamp<int64_t>(lo[2], 0, g.dims[2] - 1));
    bool uniform = true;
    for (int64_t k = lo[2]; k <= hi[2] && uniform; ++k) {
      const int64_t kk = std::clamp<int64_t>(k, 0, g.dims[2] - 1);
      for (int64_t j = lo[1]; j <= hi[1] && uniform; ++j) {
        const int64_t jj = std::clamp<int64_t>(j, 0, g.dims[1] - 1);
        const int32_t* row = volume_->data.data() + g.dims[0] * (jj + g.dims[1] * kk);
        for (int64_t i = lo[0]; i <= hi[0]; ++i)
          if (row[std::clamp<int64_t>(i, 0, g.dims[0] - 1)] != first) {
            uniform = false;
            break;
          }
      }
    }
    if (uniform) {
      out.push_back({denseIndex(first), 1.0f});
      return;
    }
  }
  const double inv2s2 = 1.0 / (2.0 * sigma_ * sigma_);
  const double invR2 = 1.0 / (radius_ * radius_);
  // The Gaussian factor is separable: one exp per axis offset instead of one per voxel.
  double gx[64], gy[64], gz[64];
  const bool separable = hi[0] - lo[0] < 64 && hi[1] - lo[1] < 64 && hi[2] - lo[2] < 64;
  if (separable) {
    for (int64_t i = lo[0]; i <= hi[0]; ++i) gx[i - lo[0]] = std::exp(-(double(i) - u[0]) * (double(i) - u[0]) * inv2s2);
    for (int64_t j = lo[1]; j <= hi[1]; ++j) gy[j - lo[1]] = std::exp(-(double(j) - u[1]) * (double(j) - u[1]) * inv2s2);
    for (int64_t k = lo[2]; k <= hi[2]; ++k) gz[k - lo[2]] = std::exp(-(double(k) - u[2]) * (double(k) - u[2]) * inv2s2);
  }
  double total = 0.0;
  // Small linear map label -> accumulated weight (few labels meet at any point).
  int32_t labs[16];
  double wsum[16];
  int nl = 0;
  std::vector<std::pair<int32_t, double>> overflow;
  for (int64_t k = lo[2]; k <= hi[2]; ++k) {
    const double dz = double(k) - u[2];
    const int64_t kk = std::clamp<int64_t>(k, 0, g.dims[2] - 1);
    for (int64_t j = lo[1]; j <= hi[1]; ++j) {
      const double dy = double(j) - u[1];
      const int64_t jj = std::clamp<int64_t>(j, 0, g.dims[1] - 1);
      const int32_t* row = volume_->data.data() + g.dims[0] * (jj + g.dims[1] * kk);
      for (int64_t i = lo[0]; i <= hi[0]; ++i) {
        const double dx = double(i) - u[0];
        const double d2 = dx * dx + dy * dy + dz * dz;
        if (d2 >= radius_ * radius_) continue;
        const double taper = 1.0 - d2 * invR2;
        const double gauss = separable ? gx[i - lo[0]] * gy[j - lo[1]] * gz[k - lo[2]] : std::exp(-d2 * inv2s2);
        const double w = gauss * taper * taper;
        const int32_t l = row[std::clamp<int64_t>(i, 0, g.dims[0] - 1)];
        total += w;
        int s = 0;
        while (s < nl && labs[s] != l) ++s;
        if (s < nl) {
          wsum[s] += w;
        } else if (nl < 16) {
          labs[nl] = l;
          wsum[nl] = w;
          ++nl;
        } else {
          auto it = std::find_if(overflow.begin(), overflow.end(), [&](auto& e) { return e.first == l; });
          if (it == overflow.end()) overflow.emplace_back(l, w);
          else it->second += w;
        }
      }
    }
  }
  if (total <= 0.0) { // cannot happen with radius >= 1, but stay defined
    const int64_t i = std::clamp<int64_t>(std::llround(u[0]), 0, g.dims[0] - 1);
    const int64_t j = std::clamp<int64_t>(std::llround(u[1]), 0, g.dims[1] - 1);
    const int64_t k = std::clamp<int64_t>(std::llround(u[2]), 0, g.dims[2] - 1);
    out.push_back({denseIndex(volume_->at(i, j, k)), 1.0f});
    return;
  }
  for (int s = 0; s < nl; ++s) out.push_back({denseIndex(labs[s]), float(wsum[s] / total)});
  for (const auto& [l, w] : overflow) out.push_back({denseIndex(l), float(w / total)});
  std::sort(out.begin(), out.end(), [](const MaterialSample& a, const MaterialSample& b) {
    return a.material < b.material;
  });
}

std::string LabelMaterials::describe() const {
  std::ostringstream s;
  s << labels_.size() << " materials from labels, blend sigma " << sigma_ << " voxels";
  return s.str();
}

IndicatorMaterials::IndicatorMaterials(std::vector<ScalarVolume> volumes, std::vector<int32_t> labels)
    : volumes_(std::move(volumes)) {
  if (volumes_.empty()) throw InputError("materials: no indicator functions given");
  grid_ = volumes_[0].grid;
  grid_.validate("indicator function 1");
  for (size_t m = 1; m < volumes_.size(); ++m) {
    const GridGeometry& g = volumes_[m].grid;
    bool same = g.dims == grid_.dims;
    for (int a = 0; a < 3 && same; ++a)
      same = std::abs(g.spacing[a] - grid_.spacing[a]) <= 1e-6 * grid_.spacing[a] &&
             std::abs(g.origin[a] - grid_.origin[a]) <= 1e-6 * (1.0 + std::abs(grid_.origin[a]));
    if (!same) {
      std::ostringstream m2;
      m2 << "indicator function " << m + 1 << " is on a different grid than the first "
         << "(dims, spacing and origin must match)";
      throw InputError(m2.str());
    }
  }
  if (labels.empty())
    for (size_t m = 0; m < volumes_.size(); ++m) labels.push_back(static_cast<int32_t>(m));
  if (labels.size() != volumes_.size())
    throw InputError("materials: " + std::to_string(labels.size()) + " labels for " +
                     std::to_string(volumes_.size()) + " indicator functions");
  std::vector<int32_t> sorted = labels;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end())
    throw InputError("materials: labels of indicator functions must be unique");
  labels_ = labels;
  inverse_ = transpose(grid_.direction);
  // Input volume per material: voxels where it is the maximum (ties to the lower index).
  inputVolumes_.assign(volumes_.size(), 0.0);
  const size_t n = volumes_[0].data.size();
  std::vector<int64_t> counts(volumes_.size(), 0);
  for (size_t i = 0; i < n; ++i) ++counts[dominantAt(i)];
  for (size_t m = 0; m < counts.size(); ++m) inputVolumes_[m] = double(counts[m]) * grid_.voxelVolume();
}

void IndicatorMaterials::sample(const Vec3& p, std::vector<MaterialSample>& out) const {
  out.clear();
  const GridGeometry& g = grid_;
  const Vec3 u = toIndex(g, inverse_, p);
  int64_t i0[3];
  double f[3];
  for (int a = 0; a < 3; ++a) {
    const double c = std::clamp(u[a], 0.0, double(g.dims[a] - 1));
    i0[a] = std::min<int64_t>(static_cast<int64_t>(std::floor(c)), std::max<int64_t>(g.dims[a] - 2, 0));
    f[a] = g.dims[a] > 1 ? c - double(i0[a]) : 0.0;
  }
  auto idx = [&](int64_t i, int64_t j, int64_t k) {
    i = std::min(i, g.dims[0] - 1);
    j = std::min(j, g.dims[1] - 1);
    k = std::min(k, g.dims[2] - 1);
    return static_cast<size_t>(i + g.dims[0] * (j + g.dims[1] * k));
  };
  for (size_t m = 0; m < volumes_.size(); ++m) {
    const auto& d = volumes_[m].data;
    double v = 0.0;
    for (int c = 0; c < 8; ++c) {
      const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
      const double w = (dx ? f[0] : 1 - f[0]) * (dy ? f[1] : 1 - f[1]) * (dz ? f[2] : 1 - f[2]);
      if (w != 0.0) v += w * d[idx(i0[0] + dx, i0[1] + dy, i0[2] + dz)];
    }
    out.push_back({static_cast<int32_t>(m), static_cast<float>(v)});
  }
}

LabelVolume IndicatorMaterials::dominantLabels() const {
  LabelVolume v;
  v.grid = grid_;
  v.data.resize(volumes_[0].data.size());
  const int64_t n = static_cast<int64_t>(v.data.size());
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) v.data[size_t(i)] = labels_[dominantAt(size_t(i))];
  return v;
}

std::string IndicatorMaterials::describe() const {
  return std::to_string(volumes_.size()) + " materials from indicator functions";
}

} // namespace tetflow
