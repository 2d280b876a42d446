// Sizing field (seed §5.3): the sampling grid, the exact transforms it is built from, and the field
// itself on analytic shapes (spheres, slabs, planes) with known feature sizes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <queue>
#include <random>

#include "Algorithms/Core/Phantom.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Algorithms/SizingField/SizingField.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {

template <class F>
std::shared_ptr<const LabelVolume> labels(std::array<int64_t, 3> dims, Vec3 spacing, F label) {
  auto v = std::make_shared<LabelVolume>();
  GridGeometry g;
  g.dims = dims;
  g.spacing = spacing;
  v->allocate(g, 0);
  for (int64_t k = 0; k < dims[2]; ++k)
    for (int64_t j = 0; j < dims[1]; ++j)
      for (int64_t i = 0; i < dims[0]; ++i) v->at(i, j, k) = label(i, j, k);
  return v;
}

// Two indicator functions from a level set: material 1 where phi > 0, material 0 where phi < 0.
template <class F>
IndicatorMaterials twoMaterials(const GridGeometry& g, F phi) {
  ScalarVolume a, b;
  a.allocate(g);
  b.allocate(g);
  for (int64_t k = 0; k < g.dims[2]; ++k)
    for (int64_t j = 0; j < g.dims[1]; ++j)
      for (int64_t i = 0; i < g.dims[0]; ++i) {
        const float v = static_cast<float>(phi(g.indexToPhysical(double(i), double(j), double(k))));
        a.at(i, j, k) = -v;
        b.at(i, j, k) = v;
      }
  std::vector<ScalarVolume> vs;
  vs.push_back(std::move(a));
  vs.push_back(std::move(b));
  return IndicatorMaterials(std::move(vs));
}

SizingFieldResult sizingOf(const MaterialSet& m, const SizingFieldParams& p = {}) {
  NullProgress np;
  return computeSizingField(m, p, np);
}

SizingFieldResult runLabels(const std::shared_ptr<const LabelVolume>& v, const SizingFieldParams& p = {}) {
  LabelMaterials m(v, 1.0);
  return sizingOf(m, p);
}

// Samples of a label volume with a 6-neighbour of another label (the interface samples when the
// sizing grid is the label grid).
template <class Visit>
void forInterfaceVoxels(const LabelVolume& v, Visit visit) {
  const auto& d = v.grid.dims;
  for (int64_t k = 0; k < d[2]; ++k)
    for (int64_t j = 0; j < d[1]; ++j)
      for (int64_t i = 0; i < d[0]; ++i) {
        const int64_t c[3] = {i, j, k};
        bool iface = false;
        for (int a = 0; a < 3 && !iface; ++a)
          for (int s = -1; s <= 1 && !iface; s += 2) {
            int64_t n[3] = {i, j, k};
            n[a] += s;
            if (n[a] < 0 || n[a] >= d[a]) continue;
            iface = v.at(n[0], n[1], n[2]) != v.at(c[0], c[1], c[2]);
          }
        if (iface) visit(i, j, k);
      }
}

// Largest violation of s(x) <= s(n) + L |x - n| over all pairs of 26-neighbours, relative to s(x).
double worstLipschitzViolation(const ScalarVolume& f, double L) {
  const auto& d = f.grid.dims;
  const Vec3& h = f.grid.spacing;
  double worst = 0.0;
  for (int64_t k = 0; k < d[2]; ++k)
    for (int64_t j = 0; j < d[1]; ++j)
      for (int64_t i = 0; i < d[0]; ++i)
        for (int dk = -1; dk <= 1; ++dk)
          for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di) {
              const int64_t ii = i + di, jj = j + dj, kk = k + dk;
              if ((di | dj | dk) == 0 || ii < 0 || jj < 0 || kk < 0 || ii >= d[0] || jj >= d[1] || kk >= d[2])
                continue;
              const double len = std::sqrt(di * di * h[0] * h[0] + dj * dj * h[1] * h[1] + dk * dk * h[2] * h[2]);
              const double sx = f.at(i, j, k), sn = f.at(ii, jj, kk);
              worst = std::max(worst, (sx - (sn + L * len)) / sx);
            }
  return worst;
}

} // namespace

// ---- sampling grid ----

TEST(SizingFieldGrid, RateOneIsTheMaterialsGrid) {
  GridGeometry g;
  g.dims = {17, 9, 4};
  g.spacing = {0.7, 1.1, 2.5};
  g.origin = {-3, 4, 100};
  EXPECT_EQ(sizingGrid(g, 1.0, 0), g);
}

TEST(SizingFieldGrid, RatesAndPaddingKeepTheBox) {
  GridGeometry g;
  g.dims = {40, 30, 97};
  g.spacing = {1.0, 0.5, 2.0};
  g.origin = {10, -5, 3};
  auto boxLo = [](const GridGeometry& q, int a) { return q.origin[a] - 0.5 * q.spacing[a]; };
  auto boxHi = [](const GridGeometry& q, int a) {
    return q.origin[a] + (double(q.dims[a]) - 0.5) * q.spacing[a];
  };
  const GridGeometry half = sizingGrid(g, 0.5, 0);
  EXPECT_EQ(half.dims, (std::array<int64_t, 3>{20, 15, 49})); // round(48.5) = 49
  EXPECT_DOUBLE_EQ(half.spacing[0], 2.0);
  EXPECT_DOUBLE_EQ(half.spacing[1], 1.0);
  EXPECT_DOUBLE_EQ(half.spacing[2], 97 * 2.0 / 49); // not a whole number of voxels: box kept
  const GridGeometry twice = sizingGrid(g, 2.0, 0);
  EXPECT_EQ(twice.dims, (std::array<int64_t, 3>{80, 60, 194}));
  EXPECT_DOUBLE_EQ(twice.spacing[1], 0.25);
  for (const GridGeometry* q : {&half, &twice})
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(boxLo(*q, a), boxLo(g, a), 1e-9);
      EXPECT_NEAR(boxHi(*q, a), boxHi(g, a), 1e-9);
    }
  // Tiny rates keep one sample per axis.
  EXPECT_EQ(sizingGrid(g, 0.001, 0).dims, (std::array<int64_t, 3>{1, 1, 1}));
  // Padding: whole samples on every side, the box grows by padding samples per side.
  const GridGeometry pad = sizingGrid(g, 0.5, 3);
  EXPECT_EQ(pad.dims, (std::array<int64_t, 3>{26, 21, 55}));
  for (int a = 0; a < 3; ++a) {
    EXPECT_DOUBLE_EQ(pad.spacing[a], half.spacing[a]);
    EXPECT_NEAR(pad.origin[a], half.origin[a] - 3 * half.spacing[a], 1e-9);
  }
  // A rotated grid keeps its direction; the origin moves along the rotated axes.
  GridGeometry r = g;
  r.direction = {{{0, -1, 0}, {1, 0, 0}, {0, 0, 1}}};
  const GridGeometry rp = sizingGrid(r, 1.0, 2);
  EXPECT_EQ(rp.direction, r.direction);
  const Vec3 want = r.indexToPhysical(-2, -2, -2);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(rp.origin[a], want[a], 1e-9);
}

// ---- building blocks ----

TEST(SizingFieldTransforms, FeatureTransformIsExact) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 12; ++trial) {
    std::uniform_int_distribution<int> dim(1, 14);
    std::uniform_real_distribution<double> sp(0.3, 2.5);
    const std::array<int64_t, 3> dims{dim(rng), dim(rng), dim(rng)};
    const Vec3 h{sp(rng), sp(rng), sp(rng)};
    const int64_t n = dims[0] * dims[1] * dims[2];
    std::vector<int32_t> ft(static_cast<size_t>(n), -1);
    std::vector<std::array<int32_t, 3>> seeds;
    std::uniform_int_distribution<int> pick(0, 99);
    const int density = trial % 3 == 0 ? 2 : 15; // sparse and dense seeds
    for (int64_t k = 0; k < dims[2]; ++k)
      for (int64_t j = 0; j < dims[1]; ++j)
        for (int64_t i = 0; i < dims[0]; ++i)
          if (pick(rng) < density) {
            ft[static_cast<size_t>(i + dims[0] * (j + dims[1] * k))] = static_cast<int32_t>(seeds.size());
            seeds.push_back({int32_t(i), int32_t(j), int32_t(k)});
          }
    euclideanFeatureTransform(dims, h, seeds, ft);
    auto d2 = [&](int64_t i, int64_t j, int64_t k, const std::array<int32_t, 3>& s) {
      const double x = (s[0] - i) * h[0], y = (s[1] - j) * h[1], z = (s[2] - k) * h[2];
      return x * x + y * y + z * z;
    };
    for (int64_t k = 0; k < dims[2]; ++k)
      for (int64_t j = 0; j < dims[1]; ++j)
        for (int64_t i = 0; i < dims[0]; ++i) {
          const int32_t got = ft[static_cast<size_t>(i + dims[0] * (j + dims[1] * k))];
          if (seeds.empty()) {
            EXPECT_EQ(got, -1);
            continue;
          }
          ASSERT_GE(got, 0);
          double best = std::numeric_limits<double>::infinity();
          for (const auto& s : seeds) best = std::min(best, d2(i, j, k, s));
          EXPECT_NEAR(d2(i, j, k, seeds[static_cast<size_t>(got)]), best, 1e-9 * (1 + best))
              << "trial " << trial << " at " << i << "," << j << "," << k;
        }
  }
}

TEST(SizingFieldTransforms, LipschitzExtensionIsTheShortestPathOverThe26Neighbourhood) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 8; ++trial) {
    std::uniform_int_distribution<int> dim(1, 11);
    std::uniform_real_distribution<double> sp(0.4, 2.0), val(0.5, 20.0);
    const std::array<int64_t, 3> dims{dim(rng), dim(rng), dim(rng)};
    const Vec3 h{sp(rng), sp(rng), sp(rng)};
    const double L = trial % 2 ? 0.2 : 1.3;
    const int64_t n = dims[0] * dims[1] * dims[2];
    std::vector<float> v(static_cast<size_t>(n), std::numeric_limits<float>::infinity());
    std::uniform_int_distribution<int> pick(0, 99);
    for (auto& x : v)
      if (pick(rng) < 6) x = static_cast<float>(val(rng));
    v[static_cast<size_t>(n / 2)] = 3.0f; // at least one source
    // Reference: Dijkstra on the 26-neighbour graph.
    std::vector<double> ref(v.begin(), v.end());
    using Item = std::pair<double, int64_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<>> pq;
    for (int64_t x = 0; x < n; ++x)
      if (std::isfinite(ref[static_cast<size_t>(x)])) pq.push({ref[static_cast<size_t>(x)], x});
    while (!pq.empty()) {
      const auto [dv, x] = pq.top();
      pq.pop();
      if (dv > ref[static_cast<size_t>(x)]) continue;
      const int64_t i = x % dims[0], j = (x / dims[0]) % dims[1], k = x / (dims[0] * dims[1]);
      for (int dk = -1; dk <= 1; ++dk)
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) {
            const int64_t ii = i + di, jj = j + dj, kk = k + dk;
            if ((di | dj | dk) == 0 || ii < 0 || jj < 0 || kk < 0 || ii >= dims[0] || jj >= dims[1] || kk >= dims[2])
              continue;
            const double w = L * std::sqrt(di * di * h[0] * h[0] + dj * dj * h[1] * h[1] + dk * dk * h[2] * h[2]);
            const int64_t y = ii + dims[0] * (jj + dims[1] * kk);
            if (dv + w < ref[static_cast<size_t>(y)]) {
              ref[static_cast<size_t>(y)] = dv + w;
              pq.push({dv + w, y});
            }
          }
    }
    lipschitzExtension(dims, h, L, v);
    for (int64_t x = 0; x < n; ++x)
      ASSERT_NEAR(v[static_cast<size_t>(x)], ref[static_cast<size_t>(x)], 1e-5 * ref[static_cast<size_t>(x)])
          << "trial " << trial << " sample " << x;
  }
}

// ---- the field on analytic shapes ----

TEST(SizingField, SphereFeatureSizeIsTheRadius) {
  PhantomParams pp;
  pp.kind = PhantomKind::Sphere;
  pp.radius = 10.0;
  pp.voxel_size = 1.0;
  const Phantom ph = makePhantom(pp);
  const auto vol = std::make_shared<const LabelVolume>(ph.volume);
  for (double scaling : {1.0, 0.5}) {
    SizingFieldParams p;
    p.feature_scaling = scaling;
    const SizingFieldResult r = runLabels(vol, p);
    SCOPED_TRACE(scaling);
    EXPECT_EQ(r.field.grid, vol->grid);
    EXPECT_GT(r.interfaceSamples, 1000);
    EXPECT_GE(r.medialSamples, 1); // around the centre only
    EXPECT_LE(r.medialSamples, 8);
    // Interface samples: the sphere's radius (its distance to the centre), within 2 voxels.
    int64_t count = 0;
    forInterfaceVoxels(*vol, [&](int64_t i, int64_t j, int64_t k) {
      EXPECT_NEAR(r.field.at(i, j, k), scaling * 10.0, 2.0 * scaling);
      ++count;
    });
    EXPECT_GT(count, 1000);
    EXPECT_NEAR(r.minFeatureSize, scaling * 10.0, 2.0 * scaling);
    EXPECT_NEAR(r.maxFeatureSize, scaling * 10.0, 2.0 * scaling);
  }
}

TEST(SizingField, SphereFromIndicatorFunctionsAtRandomCentres) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> off(-0.5, 0.5), rad(4.0, 12.0);
  GridGeometry g;
  g.dims = {33, 33, 33};
  for (int trial = 0; trial < 5; ++trial) {
    const double R = rad(rng);
    const Vec3 c{16 + off(rng), 16 + off(rng), 16 + off(rng)};
    const IndicatorMaterials m = twoMaterials(g, [&](const Vec3& p) { return R - norm(p - c); });
    const SizingFieldResult r = sizingOf(m);
    SCOPED_TRACE(R);
    EXPECT_GE(r.medialSamples, 1);
    EXPECT_NEAR(r.minFeatureSize, R, 2.0);
    EXPECT_NEAR(r.maxFeatureSize, R, 1.0);
  }
}

TEST(SizingField, SlabFeatureSizeIsHalfTheThickness) {
  for (int T : {2, 3, 4, 7}) {
    for (bool threeMaterials : {false, true}) {
      const auto vol = labels({10, 9, 30}, {1, 1, 1}, [&](int64_t, int64_t, int64_t k) {
        if (k >= 10 && k < 10 + T) return 1;
        return (threeMaterials && k >= 10 + T) ? 2 : 0;
      });
      const SizingFieldResult r = runLabels(vol);
      SCOPED_TRACE(std::to_string(T) + (threeMaterials ? " between two materials" : ""));
      EXPECT_EQ(r.interfaceSamples, 4 * 10 * 9);
      EXPECT_GT(r.medialSamples, 0);
      EXPECT_NEAR(r.minFeatureSize, T / 2.0, 0.02);
      EXPECT_NEAR(r.maxFeatureSize, T / 2.0, 0.02);
      forInterfaceVoxels(*vol, [&](int64_t i, int64_t j, int64_t k) {
        EXPECT_NEAR(r.field.at(i, j, k), T / 2.0, 0.02);
      });
    }
  }
}

TEST(SizingField, LayersOneSampleThickGetHalfASample) {
  // A layer 1 mm thick is one sample thick at sampling_rate 1: the divergence test cannot see its
  // medial surface, the one-sample rule does (its samples are medial), so the feature size is half
  // its thickness, as at rate 2 where the layer is two samples thick.
  GridGeometry g;
  g.dims = {8, 8, 20};
  const IndicatorMaterials m = twoMaterials(g, [](const Vec3& p) { return 0.5 - std::abs(p[2] - 10.0); });
  const SizingFieldResult coarse = sizingOf(m);
  EXPECT_EQ(coarse.interfaceSamples, 3 * 64);
  EXPECT_EQ(coarse.medialSamples, 64); // the layer itself
  EXPECT_NEAR(coarse.minFeatureSize, 0.5, 1e-3);
  EXPECT_NEAR(coarse.maxFeatureSize, 0.5, 1e-3);
  SizingFieldParams p;
  p.sampling_rate = 2.0;
  const SizingFieldResult fine = sizingOf(m, p);
  EXPECT_EQ(fine.field.grid.dims, (std::array<int64_t, 3>{16, 16, 40}));
  EXPECT_EQ(fine.interfaceSamples, 4 * 256);
  EXPECT_GT(fine.medialSamples, 0);
  EXPECT_NEAR(fine.minFeatureSize, 0.5, 1e-3);
  EXPECT_NEAR(fine.maxFeatureSize, 0.5, 1e-3);
  // A layer two samples thick is left to the divergence test (no sample has other materials on
  // both sides): still half its thickness.
  const IndicatorMaterials two = twoMaterials(g, [](const Vec3& p) { return 1.0 - std::abs(p[2] - 10.5); });
  const SizingFieldResult r2 = sizingOf(two);
  EXPECT_NEAR(r2.minFeatureSize, 1.0, 0.02);
  EXPECT_NEAR(r2.maxFeatureSize, 1.0, 0.02);
}

TEST(SizingField, GapBetweenTwoSpheresSetsTheFeatureSize) {
  // Two spheres of radius 6 with a 4 mm gap: the medial plane between them is 2 mm from the
  // facing points, the spheres' centres 6 mm from every point.
  GridGeometry g;
  g.dims = {40, 24, 24};
  const Vec3 c1{10.2, 11.6, 11.3}, c2{26.2, 11.6, 11.3};
  const IndicatorMaterials m = twoMaterials(g, [&](const Vec3& p) {
    return std::max(6.0 - norm(p - c1), 6.0 - norm(p - c2));
  });
  const SizingFieldResult r = sizingOf(m);
  EXPECT_NEAR(r.minFeatureSize, 2.0, 0.5);
  EXPECT_NEAR(r.maxFeatureSize, 6.0, 1.0);
}

TEST(SizingField, GrowthAwayFromTheSurfaceFollowsLipschitz) {
  const auto vol = labels({6, 6, 60}, {1, 1, 1}, [](int64_t, int64_t, int64_t k) { return (k >= 20 && k < 24) ? 1 : 0; });
  for (double L : {0.1, 0.2, 0.5}) {
    SizingFieldParams p;
    p.lipschitz = L;
    const SizingFieldResult r = runLabels(vol, p);
    // Interface samples: k = 19, 20 (lower face) and 23, 24 (upper face), all with the feature
    // size T/2 = 2; elsewhere the size grows by L per mm of distance to them, up to the box side.
    const double lfs = r.field.at(0, 0, 19);
    EXPECT_NEAR(lfs, 2.0, 0.02);
    for (int64_t k = 0; k < 60; ++k) {
      const int64_t dist = k <= 19 ? 19 - k : (k >= 24 ? k - 24 : std::min(k - 20, 23 - k));
      const double want = std::min(lfs + L * double(dist), r.unboundedSize);
      for (int64_t j = 0; j < 6; ++j)
        for (int64_t i = 0; i < 6; ++i)
          ASSERT_NEAR(r.field.at(i, j, k), want, 1e-5 * want) << "L " << L << " k " << k;
    }
    EXPECT_DOUBLE_EQ(r.unboundedSize, 60.0);
  }
}

TEST(SizingField, DiscreteLipschitzHoldsBetweenAllNeighbours) {
  // Random smooth blobs, anisotropic spacing, several Lipschitz constants and rates.
  std::mt19937 rng(19);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 4; ++trial) {
    GridGeometry g;
    g.dims = {22, 18, 14};
    g.spacing = {0.8, 1.0, 1.6};
    std::vector<std::pair<Vec3, double>> blobs;
    for (int b = 0; b < 5; ++b)
      blobs.push_back({{u(rng) * 17, u(rng) * 17, u(rng) * 21}, 2.0 + 4.0 * u(rng)});
    const IndicatorMaterials m = twoMaterials(g, [&](const Vec3& p) {
      double v = -1e9;
      for (const auto& [c, R] : blobs) v = std::max(v, R - norm(p - c));
      return v;
    });
    SizingFieldParams p;
    p.lipschitz = trial % 2 ? 0.2 : 0.7;
    p.sampling_rate = trial < 2 ? 1.0 : 1.5;
    const SizingFieldResult r = sizingOf(m, p);
    SCOPED_TRACE(trial);
    EXPECT_GT(r.interfaceSamples, 0);
    EXPECT_LE(worstLipschitzViolation(r.field, p.lipschitz), 1e-6);
    for (float s : r.field.data) ASSERT_TRUE(std::isfinite(s) && s > 0.0f);
  }
}

TEST(SizingField, ClampsHoldExactly) {
  PhantomParams pp;
  pp.kind = PhantomKind::Sphere;
  pp.radius = 8.0;
  pp.voxel_size = 1.0;
  const auto vol = std::make_shared<const LabelVolume>(makePhantom(pp).volume);
  const SizingFieldResult free = runLabels(vol);
  ASSERT_LT(free.minSize, 8.5);
  ASSERT_GT(free.maxSize, 10.0);
  SizingFieldParams p;
  p.min_size = 8.5;
  p.max_size = 10.0;
  const SizingFieldResult r = runLabels(vol, p);
  int64_t below = 0, above = 0;
  for (size_t x = 0; x < r.field.data.size(); ++x) {
    const float s = r.field.data[x], s0 = free.field.data[x];
    ASSERT_GE(s, 8.5f);
    ASSERT_LE(s, 10.0f);
    if (s0 < 8.5f) {
      EXPECT_EQ(s, 8.5f);
      ++below;
    } else if (s0 > 10.0f) {
      EXPECT_EQ(s, 10.0f);
      ++above;
    } else {
      EXPECT_EQ(s, s0);
    }
  }
  EXPECT_EQ(r.clampedToMin, below);
  EXPECT_GT(below, 0);
  EXPECT_GT(above, 0);
  EXPECT_EQ(r.minSize, 8.5);
  EXPECT_EQ(r.maxSize, 10.0);
  EXPECT_EQ(r.unboundedSize, 10.0);
  // The clamps keep the Lipschitz bound.
  EXPECT_LE(worstLipschitzViolation(r.field, p.lipschitz), 1e-6);
}

TEST(SizingField, SamplingRateChangesTheGridNotTheSizes) {
  PhantomParams pp;
  pp.kind = PhantomKind::Sphere;
  pp.radius = 10.0;
  pp.voxel_size = 1.0;
  const auto vol = std::make_shared<const LabelVolume>(makePhantom(pp).volume);
  const auto& d = vol->grid.dims;
  for (double rate : {0.5, 2.0}) {
    SizingFieldParams p;
    p.sampling_rate = rate;
    const SizingFieldResult r = runLabels(vol, p);
    SCOPED_TRACE(rate);
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(r.field.grid.dims[a], std::max<int64_t>(1, std::llround(double(d[a]) * rate)));
      EXPECT_NEAR(r.field.grid.spacing[a] * double(r.field.grid.dims[a]), double(d[a]), 1e-9);
    }
    const double h = r.field.grid.spacing[0];
    EXPECT_NEAR(r.minFeatureSize, 10.0, 2.0 * std::max(h, 1.0));
    EXPECT_NEAR(r.maxFeatureSize, 10.0, 2.0 * std::max(h, 1.0));
  }
}

TEST(SizingField, PaddingAddsSamplesAndKeepsTheCore) {
  PhantomParams pp;
  pp.kind = PhantomKind::Sphere;
  pp.radius = 6.0;
  pp.voxel_size = 1.0;
  const auto vol = std::make_shared<const LabelVolume>(makePhantom(pp).volume);
  const SizingFieldResult plain = runLabels(vol);
  SizingFieldParams p;
  p.padding = 3;
  const SizingFieldResult padded = runLabels(vol, p);
  const auto& d = vol->grid.dims;
  ASSERT_EQ(padded.field.grid.dims, (std::array<int64_t, 3>{d[0] + 6, d[1] + 6, d[2] + 6}));
  for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(padded.field.grid.origin[a], vol->grid.origin[a] - 3.0);
  EXPECT_EQ(padded.interfaceSamples, plain.interfaceSamples); // the sphere does not reach the box
  // Shortest paths between core samples never need the padding: the core is unchanged (up to
  // float rounding).
  for (int64_t k = 0; k < d[2]; ++k)
    for (int64_t j = 0; j < d[1]; ++j)
      for (int64_t i = 0; i < d[0]; ++i)
        ASSERT_NEAR(padded.field.at(i + 3, j + 3, k + 3), plain.field.at(i, j, k), 1e-5 * plain.field.at(i, j, k));
  EXPECT_LE(worstLipschitzViolation(padded.field, p.lipschitz), 1e-6);
  // An interface reaching the box continues through the padding (materials extended constantly).
  const auto slab = labels({6, 6, 12}, {1, 1, 1}, [](int64_t, int64_t, int64_t k) { return k >= 4 && k < 8 ? 1 : 0; });
  const SizingFieldResult ps = runLabels(slab, p);
  EXPECT_EQ(ps.interfaceSamples, 4 * 12 * 12);
  EXPECT_NEAR(ps.field.at(0, 0, 3 + 3), 2.0, 0.02);
}

TEST(SizingField, AnisotropicSpacingIsMeasuredInMillimetres) {
  // Slab normal along the coarse axis: 3 samples of 2 mm = 6 mm thick, feature size 3 mm.
  const auto zs = labels({6, 6, 16}, {1, 1, 2}, [](int64_t, int64_t, int64_t k) { return k >= 6 && k < 9 ? 1 : 0; });
  const SizingFieldResult rz = runLabels(zs);
  EXPECT_NEAR(rz.minFeatureSize, 3.0, 0.05);
  EXPECT_NEAR(rz.maxFeatureSize, 3.0, 0.05);
  // Slab normal along the fine axis: 4 samples of 0.5 mm = 2 mm thick, feature size 1 mm; growth
  // per sample along x is lipschitz * 0.5 mm.
  const auto xs = labels({24, 5, 5}, {0.5, 1, 1}, [](int64_t i, int64_t, int64_t) { return i >= 10 && i < 14 ? 1 : 0; });
  const SizingFieldResult rx = runLabels(xs);
  EXPECT_NEAR(rx.minFeatureSize, 1.0, 0.05);
  EXPECT_NEAR(rx.field.at(2, 2, 2), rx.field.at(9, 2, 2) + 0.2 * 0.5 * 7, 1e-5); // 7 samples from 9
  // A sphere of radius 7 mm on a 1 x 1 x 1.5 mm grid.
  GridGeometry g;
  g.dims = {29, 29, 20};
  g.spacing = {1.0, 1.0, 1.5};
  const Vec3 c{14.3, 13.8, 14.1};
  const IndicatorMaterials m = twoMaterials(g, [&](const Vec3& p) { return 7.0 - norm(p - c); });
  const SizingFieldResult rs = sizingOf(m);
  EXPECT_NEAR(rs.minFeatureSize, 7.0, 2.0 * 1.5);
  EXPECT_NEAR(rs.maxFeatureSize, 7.0, 1.5);
  EXPECT_LE(worstLipschitzViolation(rs.field, 0.2), 1e-6);
}

TEST(SizingField, OneSliceVolumesAreTwoDimensional) {
  // A disc of radius 7 in a single slice: its medial axis is the centre, 7 mm from the circle.
  GridGeometry g;
  g.dims = {30, 30, 1};
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> off(-0.5, 0.5);
  for (int trial = 0; trial < 4; ++trial) {
    const Vec3 c{14.5 + off(rng), 14.5 + off(rng), 0.0};
    const IndicatorMaterials m = twoMaterials(g, [&](const Vec3& p) { return 7.0 - norm(p - c); });
    const SizingFieldResult r = sizingOf(m);
    SCOPED_TRACE(trial);
    EXPECT_GE(r.medialSamples, 1);
    EXPECT_NEAR(r.minFeatureSize, 7.0, 1.5);
    EXPECT_NEAR(r.maxFeatureSize, 7.0, 1.0);
    EXPECT_LE(worstLipschitzViolation(r.field, 0.2), 1e-6);
  }
}

TEST(SizingField, RotatedGridGivesTheSameField) {
  PhantomParams pp;
  pp.kind = PhantomKind::TwoSpheres;
  pp.radius = 5.0;
  pp.voxel_size = 1.0;
  const LabelVolume v = makePhantom(pp).volume;
  auto rotated = std::make_shared<LabelVolume>(v);
  rotated->grid.direction = {{{0, 0, 1}, {1, 0, 0}, {0, 1, 0}}};
  const SizingFieldResult a = runLabels(std::make_shared<const LabelVolume>(v));
  const SizingFieldResult b = runLabels(rotated);
  EXPECT_EQ(b.field.grid.direction, rotated->grid.direction);
  EXPECT_EQ(a.field.data, b.field.data);
}

TEST(SizingField, SingleMaterialIsUniform) {
  const auto vol = labels({10, 14, 6}, {1.0, 0.5, 2.0}, [](int64_t, int64_t, int64_t) { return 7; });
  const SizingFieldResult r = runLabels(vol);
  EXPECT_EQ(r.interfaceSamples, 0);
  EXPECT_EQ(r.medialSamples, 0);
  EXPECT_EQ(r.materialsPresent, 1);
  for (float s : r.field.data) ASSERT_EQ(s, 12.0f); // longest side: 6 x 2 mm
  SizingFieldParams p;
  p.max_size = 5.0;
  for (float s : runLabels(vol, p).field.data) ASSERT_EQ(s, 5.0f);
  p.max_size = 0.0;
  p.min_size = 20.0;
  for (float s : runLabels(vol, p).field.data) ASSERT_EQ(s, 20.0f);
}

TEST(SizingField, FlatInterfacesHaveNoMedialSamples) {
  // A plane through the box at random tilts and offsets: no medial samples, so the feature size
  // and the field are the unbounded size everywhere.
  std::mt19937 rng(23);
  std::normal_distribution<double> nd;
  std::uniform_real_distribution<double> off(-0.5, 0.5);
  GridGeometry g;
  g.dims = {20, 20, 20};
  for (int trial = 0; trial < 6; ++trial) {
    Vec3 nrm{nd(rng), nd(rng), nd(rng)};
    nrm = (1.0 / norm(nrm)) * nrm;
    const double c = off(rng);
    const IndicatorMaterials m = twoMaterials(g, [&](const Vec3& p) { return dot(nrm, p - Vec3{9.5, 9.5, 9.5}) + c; });
    const SizingFieldResult r = sizingOf(m);
    SCOPED_TRACE(trial);
    EXPECT_GT(r.interfaceSamples, 300);
    EXPECT_EQ(r.medialSamples, 0);
    EXPECT_EQ(r.minSize, 20.0);
  }
}

TEST(SizingField, CleaverSpheresIndicatorFunctions) {
  std::vector<ScalarVolume> vols;
  for (int i = 1; i <= 4; ++i)
    vols.push_back(readScalarVolume(std::string(TETFLOW_TEST_DATA) + "/spheres" + std::to_string(i) + ".nrrd"));
  const IndicatorMaterials m(std::move(vols));
  SizingFieldParams p;
  const SizingFieldResult r = sizingOf(m, p);
  EXPECT_EQ(r.field.grid, m.grid());
  EXPECT_EQ(r.materialsPresent, 4);
  EXPECT_GT(r.interfaceSamples, 0);
  EXPECT_GT(r.medialSamples, 0);
  EXPECT_GT(r.minSize, 0.0);
  EXPECT_LE(r.maxSize, r.unboundedSize);
  EXPECT_LE(worstLipschitzViolation(r.field, p.lipschitz), 1e-6);
}

TEST(SizingField, StagesAndReport) {
  const auto vol = labels({8, 8, 16}, {1, 1, 1}, [](int64_t, int64_t, int64_t k) { return k >= 5 && k < 9 ? 1 : 0; });
  LabelMaterials m(vol, 1.0);
  NullProgress np;
  const SizingFieldResult r = computeSizingField(m, SizingFieldParams{}, np);
  std::vector<std::string> names;
  for (const auto& s : np.stageTimes()) names.push_back(s.name);
  EXPECT_EQ(names, (std::vector<std::string>{"sample", "interfaces", "distance", "medial", "feature size",
                                             "lipschitz"}));
  Report rep;
  writeSizingFieldReport(r, rep);
  EXPECT_EQ(std::get<std::string>(*rep.find("dims")), "8 x 8 x 16");
  EXPECT_EQ(rep.number("samples"), 8 * 8 * 16);
  EXPECT_EQ(rep.number("interface_samples"), 4 * 64);
  EXPECT_EQ(rep.number("interface_edges"), 2 * 64);
  EXPECT_GT(rep.number("medial_samples"), 0);
  EXPECT_NEAR(rep.number("min_feature_size_mm"), 2.0, 0.02);
  EXPECT_NEAR(rep.number("min_size_mm"), 2.0, 0.02);
  EXPECT_DOUBLE_EQ(rep.number("max_size_mm"), r.maxSize);
  EXPECT_DOUBLE_EQ(rep.number("unbounded_size_mm"), 16.0);
  for (const char* k : {"spacing_mm", "mean_size_mm", "medial_samples", "clamped_to_min", "clamped_to_max"})
    EXPECT_TRUE(rep.has(k)) << k;
}

TEST(SizingField, CancelStops) {
  struct CancelAtMedial : Progress {
    void onStage(const std::string& name) override {
      if (name == "medial") requestCancel();
    }
  };
  const auto vol = labels({8, 8, 8}, {1, 1, 1}, [](int64_t i, int64_t, int64_t) { return i < 4 ? 1 : 0; });
  LabelMaterials m(vol, 1.0);
  CancelAtMedial cp;
  EXPECT_THROW(computeSizingField(m, SizingFieldParams{}, cp), Cancelled);
}

TEST(SizingField, BadParametersNameTheParameter) {
  const auto vol = labels({4, 4, 4}, {1, 1, 1}, [](int64_t i, int64_t, int64_t) { return i < 2 ? 1 : 0; });
  LabelMaterials m(vol, 1.0);
  NullProgress np;
  auto bad = [&](auto set) {
    SizingFieldParams p;
    set(p);
    return p;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW_MSG(computeSizingField(m, bad([](auto& p) { p.sampling_rate = 0; }), np), InputError,
                   "sampling_rate", "> 0");
  EXPECT_THROW_MSG(computeSizingField(m, bad([&](auto& p) { p.sampling_rate = nan; }), np), InputError,
                   "sampling_rate");
  EXPECT_THROW_MSG(computeSizingField(m, bad([](auto& p) { p.sampling_rate = 1e12; }), np), InputError,
                   "sampling_rate");
  EXPECT_THROW_MSG(computeSizingField(m, bad([](auto& p) { p.lipschitz = -0.2; }), np), InputError,
                   "lipschitz", "> 0");
  EXPECT_THROW_MSG(computeSizingField(m, bad([](auto& p) { p.feature_scaling = 0; }), np), InputError,
                   "feature_scaling", "> 0");
  EXPECT_THROW_MSG(computeSizingField(m, bad([](auto& p) { p.padding = -1; }), np), InputError, "padding",
                   ">= 0");
  EXPECT_THROW_MSG(computeSizingField(m, bad([](auto& p) { p.min_size = -1; }), np), InputError, "min_size",
                   ">= 0");
  EXPECT_THROW_MSG(computeSizingField(m, bad([](auto& p) { p.max_size = INFINITY; }), np), InputError,
                   "max_size");
  EXPECT_THROW_MSG(computeSizingField(m, bad([](auto& p) {
                     p.min_size = 5;
                     p.max_size = 2;
                   }), np),
                   InputError, "min_size", "max_size", "<=");
  // (refused for its memory first on any machine with less than ~100 EB; the 2^31 cap after)
  EXPECT_THROW_MSG(computeSizingField(m, bad([](auto& p) { p.padding = 700000; }), np), InputError,
                   "would need", "padding 700000");
  // min_size == max_size is allowed: a uniform field.
  SizingFieldParams eq;
  eq.min_size = eq.max_size = 3.0;
  for (float s : computeSizingField(m, eq, np).field.data) ASSERT_EQ(s, 3.0f);
}

TEST(SizingField, OneSampleBumpsAreNotThinLayersButThinTubesAre) {
  // A flat interface with a one-voxel bump: the bump is thin across two axes but does not continue,
  // so it adds no medial sample and the field over the surface stays the unbounded size.
  const auto bump = labels({16, 16, 20}, {1, 1, 1}, [](int64_t i, int64_t j, int64_t k) {
    return (k < 10 || (i == 8 && j == 8 && k == 10)) ? 1 : 0;
  });
  const SizingFieldResult rb = runLabels(bump);
  EXPECT_EQ(rb.medialSamples, 0);
  EXPECT_DOUBLE_EQ(rb.minSize, 20.0);
  // A tube one sample thick along x (indicator functions: a label volume's blend would dissolve a
  // one-voxel tube into its surroundings): every tube sample is medial, the feature size is half a
  // sample.
  GridGeometry g;
  g.dims = {16, 12, 12};
  const IndicatorMaterials tube = twoMaterials(g, [](const Vec3& p) {
    return 0.5 - std::max(std::abs(p[1] - 6.0), std::abs(p[2] - 6.0));
  });
  const SizingFieldResult rt = sizingOf(tube);
  EXPECT_GE(rt.medialSamples, 14);
  EXPECT_NEAR(rt.minFeatureSize, 0.5, 1e-3);
}
