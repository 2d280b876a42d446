#include "SizingField.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/MemoryBudget.h"

namespace tetflow {

namespace {

// Medial criteria (see the header): closest points of a medial pair spread by more than
// kSpread times the pair's distance, and are seen from the medial point under more than
// kMinSeparationDeg degrees.
constexpr double kSpread = 1.5;
// Closest points are feet on tangent planes at most this many sample spacings from the point.
constexpr double kFootReach = 1.5;
constexpr double kMinSeparationDeg = 120.0;
constexpr double kPi = 3.14159265358979323846;
constexpr float kInf = std::numeric_limits<float>::infinity();

[[noreturn]] void badParam(const char* name, double value, const char* allowed) {
  std::ostringstream m;
  m << "parameter '" << name << "' = " << value << " is out of range: " << allowed;
  throw InputError(m.str());
}

void checkParams(const SizingFieldParams& p) {
  if (!std::isfinite(p.sampling_rate) || p.sampling_rate <= 0.0)
    badParam("sampling_rate", p.sampling_rate,
             "it must be a number > 0 (samples per voxel along each axis, e.g. 0.5 or 2)");
  if (!std::isfinite(p.lipschitz) || p.lipschitz <= 0.0)
    badParam("lipschitz", p.lipschitz, "it must be a number > 0 (size growth in mm per mm, e.g. 0.2)");
  if (!std::isfinite(p.feature_scaling) || p.feature_scaling <= 0.0)
    badParam("feature_scaling", p.feature_scaling, "it must be a number > 0 (e.g. 1)");
  if (p.padding < 0) badParam("padding", p.padding, "it must be a whole number of samples >= 0");
  if (!std::isfinite(p.min_size) || p.min_size < 0.0)
    badParam("min_size", p.min_size, "it must be a size in mm >= 0 (0 = no lower clamp)");
  if (!std::isfinite(p.max_size) || p.max_size < 0.0)
    badParam("max_size", p.max_size, "it must be a size in mm >= 0 (0 = no upper clamp)");
  if (p.min_size > 0.0 && p.max_size > 0.0 && p.min_size > p.max_size) {
    std::ostringstream m;
    m << "parameter 'min_size' = " << p.min_size << " mm is larger than 'max_size' = " << p.max_size
      << " mm; make min_size <= max_size, or set either to 0 for no clamp";
    throw InputError(m.str());
  }
}

// Where the sizing grid samples the materials: continuous index coordinates in the materials'
// grid of sizing sample (i, j, k); padding samples are clamped to the nearest in-grid sample.
struct Sampler {
  const GridGeometry* in = nullptr;
  int64_t pad = 0;
  std::array<int64_t, 3> core{1, 1, 1};
  std::array<double, 3> ratio{1, 1, 1}; // materials' voxels per sample
  Vec3 position(int64_t i, int64_t j, int64_t k) const {
    const int64_t c[3] = {i - pad, j - pad, k - pad};
    double u[3];
    for (int a = 0; a < 3; ++a) {
      const int64_t cc = std::clamp<int64_t>(c[a], 0, core[a] - 1);
      u[a] = (double(cc) + 0.5) * ratio[a] - 0.5;
    }
    return in->indexToPhysical(u[0], u[1], u[2]);
  }
};

float valueOf(const MaterialSample* b, const MaterialSample* e, int32_t material, float absent) {
  for (; b != e; ++b)
    if (b->material == material) return b->value;
  return absent;
}

std::string dimsText(const std::array<int64_t, 3>& d) {
  return std::to_string(d[0]) + " x " + std::to_string(d[1]) + " x " + std::to_string(d[2]);
}

} // namespace

GridGeometry sizingGrid(const GridGeometry& in, double samplingRate, int padding) {
  if (!std::isfinite(samplingRate) || samplingRate <= 0.0)
    badParam("sampling_rate", samplingRate,
             "it must be a number > 0 (samples per voxel along each axis, e.g. 0.5 or 2)");
  if (padding < 0) badParam("padding", padding, "it must be a whole number of samples >= 0");
  GridGeometry g = in;
  double u[3];
  for (int a = 0; a < 3; ++a) {
    const double want = double(in.dims[a]) * samplingRate;
    if (!(want < 2147483647.0)) {
      std::ostringstream m;
      m << "parameter 'sampling_rate' = " << samplingRate << " gives " << want
        << " samples along axis " << a << "; lower it";
      throw InputError(m.str());
    }
    const int64_t m = std::max<int64_t>(1, std::llround(want));
    const double ratio = double(in.dims[a]) / double(m);
    g.dims[a] = m + 2 * int64_t(padding);
    g.spacing[a] = in.spacing[a] * ratio;
    u[a] = (double(-padding) + 0.5) * ratio - 0.5;
  }
  g.origin = in.indexToPhysical(u[0], u[1], u[2]);
  return g;
}

void euclideanFeatureTransform(const std::array<int64_t, 3>& dims, const Vec3& spacing,
                               const std::vector<std::array<int32_t, 3>>& seeds,
                               std::vector<int32_t>& ft) {
  const int64_t n = dims[0] * dims[1] * dims[2];
  if (static_cast<int64_t>(ft.size()) != n)
    throw ProcessingError("feature transform: the feature array does not match the grid");
  if (seeds.empty()) {
    std::fill(ft.begin(), ft.end(), -1);
    return;
  }
  const int64_t stride[3] = {1, dims[0], dims[0] * dims[1]};
  for (int a = 0; a < 3; ++a) {
    const int64_t len = dims[a];
    if (len == 1) continue; // nothing to propagate along this axis
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    const int64_t lines = dims[b] * dims[c];
    const double w = spacing[a] * spacing[a];
    const double hb2 = spacing[b] * spacing[b], hc2 = spacing[c] * spacing[c];
#pragma omp parallel
    {
      std::vector<int32_t> g(static_cast<size_t>(len));
      std::vector<double> f(static_cast<size_t>(len));
      std::vector<int64_t> v(static_cast<size_t>(len));
      std::vector<double> z(static_cast<size_t>(len) + 1);
#pragma omp for schedule(static)
      for (int64_t line = 0; line < lines; ++line) {
        const int64_t ib = line % dims[b], ic = line / dims[b];
        const int64_t base = ib * stride[b] + ic * stride[c];
        // Lower envelope of the parabolas f(q) + w (p - q)^2 over the seeds' features on the line;
        // f(q) = squared distance from line point q to its feature across the other two axes.
        int64_t k = -1;
        for (int64_t q = 0; q < len; ++q) {
          const int32_t id = ft[static_cast<size_t>(base + q * stride[a])];
          g[static_cast<size_t>(q)] = id;
          if (id < 0) continue;
          const auto& s = seeds[static_cast<size_t>(id)];
          const double db = double(s[b] - ib), dc = double(s[c] - ic);
          const double fq = db * db * hb2 + dc * dc * hc2;
          f[static_cast<size_t>(q)] = fq;
          if (k < 0) {
            k = 0;
            v[0] = q;
            z[0] = -std::numeric_limits<double>::infinity();
            z[1] = std::numeric_limits<double>::infinity();
            continue;
          }
          double x;
          for (;;) {
            const int64_t r = v[static_cast<size_t>(k)];
            const double fr = f[static_cast<size_t>(r)];
            x = ((fq + w * double(q) * double(q)) - (fr + w * double(r) * double(r))) /
                (2.0 * w * double(q - r));
            if (x <= z[static_cast<size_t>(k)] && k > 0) --k;
            else break;
          }
          ++k;
          v[static_cast<size_t>(k)] = q;
          z[static_cast<size_t>(k)] = x;
          z[static_cast<size_t>(k) + 1] = std::numeric_limits<double>::infinity();
        }
        if (k < 0) continue; // no feature on this line yet
        int64_t e = 0;
        for (int64_t p = 0; p < len; ++p) {
          while (z[static_cast<size_t>(e) + 1] < double(p)) ++e;
          ft[static_cast<size_t>(base + p * stride[a])] = g[static_cast<size_t>(v[static_cast<size_t>(e)])];
        }
      }
    }
  }
}

void lipschitzExtension(const std::array<int64_t, 3>& dims, const Vec3& spacing, double lipschitz,
                        std::vector<float>& v) {
  const int64_t nx = dims[0], ny = dims[1], nz = dims[2];
  if (static_cast<int64_t>(v.size()) != nx * ny * nz)
    throw ProcessingError("Lipschitz extension: the value array does not match the grid");
  auto weight = [&](int di, int dj, int dk) {
    const double x = di * spacing[0], y = dj * spacing[1], z = dk * spacing[2];
    return static_cast<float>(lipschitz * std::sqrt(x * x + y * y + z * z));
  };
  // Neighbours in the previous slice (dk = -1 forward, +1 backward), 3 x 3 in (di, dj).
  float wSlice[3][3];
  for (int dj = -1; dj <= 1; ++dj)
    for (int di = -1; di <= 1; ++di) wSlice[dj + 1][di + 1] = weight(di, dj, 1);
  const float wRowDiag = weight(1, 1, 0), wRowAxis = weight(0, 1, 0), wAlong = weight(1, 0, 0);
  const int64_t sy = nx, sz = nx * ny;

  for (int pass = 0; pass < 2; ++pass) {
    const int dir = pass == 0 ? 1 : -1; // forward: neighbours at lower indices (offset -1)
    for (int64_t kk = 0; kk < nz; ++kk) {
      const int64_t k = dir > 0 ? kk : nz - 1 - kk;
      const int64_t kn = k - dir; // previous slice in sweep order
      float* slice = v.data() + k * sz;
      if (kn >= 0 && kn < nz) {
        const float* prev = v.data() + kn * sz;
        // One parallel region per slice: only worth its barrier for large slices (on a loaded
        // machine small regions cost more in waiting than they save).
#pragma omp parallel for schedule(static) if (sz >= 65536)
        for (int64_t j = 0; j < ny; ++j)
          for (int64_t i = 0; i < nx; ++i) {
            float best = slice[j * sy + i];
            for (int dj = -1; dj <= 1; ++dj) {
              const int64_t jj = j + dj;
              if (jj < 0 || jj >= ny) continue;
              for (int di = -1; di <= 1; ++di) {
                const int64_t ii = i + di;
                if (ii < 0 || ii >= nx) continue;
                best = std::min(best, prev[jj * sy + ii] + wSlice[dj + 1][di + 1]);
              }
            }
            slice[j * sy + i] = best;
          }
      }
      // In-slice: the previous row (three neighbours), then the previous sample along the row.
      for (int64_t jj = 0; jj < ny; ++jj) {
        const int64_t j = dir > 0 ? jj : ny - 1 - jj;
        const int64_t jn = j - dir;
        float* row = slice + j * sy;
        if (jn >= 0 && jn < ny) {
          const float* prow = slice + jn * sy;
          for (int64_t i = 0; i < nx; ++i) {
            float best = std::min(row[i], prow[i] + wRowAxis);
            if (i > 0) best = std::min(best, prow[i - 1] + wRowDiag);
            if (i + 1 < nx) best = std::min(best, prow[i + 1] + wRowDiag);
            row[i] = best;
          }
        }
        if (dir > 0) {
          for (int64_t i = 1; i < nx; ++i) row[i] = std::min(row[i], row[i - 1] + wAlong);
        } else {
          for (int64_t i = nx - 2; i >= 0; --i) row[i] = std::min(row[i], row[i + 1] + wAlong);
        }
      }
    }
  }
}

SizingFieldResult computeSizingField(const MaterialSet& materials, const SizingFieldParams& params,
                                     Progress& progress) {
  checkParams(params);
  const GridGeometry& in = materials.grid();
  in.validate("materials");
  if (materials.numMaterials() < 1) throw InputError("sizing field: the material set is empty");
  const GridGeometry g = sizingGrid(in, params.sampling_rate, params.padding);
  const double total = double(g.dims[0]) * double(g.dims[1]) * double(g.dims[2]);
  // Peak memory: 35 bytes per sample above the input measured on the 97^3 head phantom (32 MB,
  // SizingField.h); 48 assumed (more interface samples in busier images). Samples go as
  // sampling_rate^3.
  {
    constexpr double kBytesPerSample = 48.0;
    std::ostringstream what;
    what << "sampling_rate " << params.sampling_rate;
    if (params.padding > 0) what << " with padding " << params.padding;
    what << " (" << g.dims[0] << " x " << g.dims[1] << " x " << g.dims[2] << " samples)";
    requireMemory(kBytesPerSample * total, what.str(), [&](double avail) {
      std::ostringstream f;
      if (params.padding > 0) f << "lower padding, or ";
      f << "use sampling_rate <= "
        << roundDownForAdvice(params.sampling_rate * std::cbrt(std::max(avail, 1.0) / (kBytesPerSample * total)) * 0.98);
      return f.str();
    });
  }
  if (!(total < 2147483647.0)) {
    std::ostringstream m;
    m << "the sizing grid of " << g.dims[0] << " x " << g.dims[1] << " x " << g.dims[2]
      << " samples exceeds 2^31 - 1 samples; lower 'sampling_rate' (now " << params.sampling_rate
      << ") or 'padding' (now " << params.padding << ")";
    throw InputError(m.str());
  }
  const int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const int64_t n = nx * ny * nz;
  const int64_t pad = params.padding;
  const Vec3 h = g.spacing;
  const int64_t stride[3] = {1, nx, nx * ny};

  Sampler sampler;
  sampler.in = &in;
  sampler.pad = pad;
  for (int a = 0; a < 3; ++a) {
    sampler.core[a] = g.dims[a] - 2 * pad;
    sampler.ratio[a] = double(in.dims[a]) / double(sampler.core[a]);
  }
  double boxSide = 0.0;
  for (int a = 0; a < 3; ++a) boxSide = std::max(boxSide, double(in.dims[a]) * in.spacing[a]);
  const double unbounded = params.max_size > 0.0 ? params.max_size : boxSide;

  SizingFieldResult res;
  res.samples = n;
  res.unboundedSize = unbounded;
  const int K = materials.numMaterials();

  // ---- sample: dominant material per sample ----
  progress.beginStage("sample");
  std::vector<int32_t> label(static_cast<size_t>(n), 0);
  std::vector<int64_t> present(static_cast<size_t>(K), 0);
  {
    const int64_t cx = sampler.core[0], cy = sampler.core[1], cz = sampler.core[2];
    const int64_t rows = cy * cz;
    std::atomic<int64_t> done{0};
    std::atomic<bool> stop{false};
#pragma omp parallel
    {
      std::vector<MaterialSample> s;
      std::vector<int64_t> localPresent(static_cast<size_t>(K), 0);
#pragma omp for schedule(dynamic, 4)
      for (int64_t r = 0; r < rows; ++r) {
        if (stop.load(std::memory_order_relaxed)) continue;
        const int64_t j = r % cy + pad, k = r / cy + pad;
        int32_t* out = label.data() + k * stride[2] + j * stride[1] + pad;
        for (int64_t i = 0; i < cx; ++i) {
          materials.sample(sampler.position(i + pad, j, k), s);
          const int32_t best = std::clamp(dominantMaterial(s), 0, K - 1);
          out[i] = best;
          ++localPresent[static_cast<size_t>(best)];
        }
        const int64_t d = done.fetch_add(1, std::memory_order_relaxed) + 1;
        if (d % 64 == 0) progress.report(double(d) / double(rows));
        if (progress.cancelRequested()) stop.store(true);
      }
#pragma omp critical
      for (int m = 0; m < K; ++m) present[static_cast<size_t>(m)] += localPresent[static_cast<size_t>(m)];
    }
    progress.checkCancel();
    if (pad > 0) {
      // Padding samples copy the nearest in-grid sample.
#pragma omp parallel for schedule(static)
      for (int64_t k = 0; k < nz; ++k)
        for (int64_t j = 0; j < ny; ++j) {
          const int64_t ck = std::clamp(k, pad, pad + cz - 1), cj = std::clamp(j, pad, pad + cy - 1);
          const bool inside = ck == k && cj == j;
          for (int64_t i = 0; i < nx; ++i) {
            if (inside && i >= pad && i < pad + cx) continue;
            const int64_t ci = std::clamp(i, pad, pad + cx - 1);
            label[static_cast<size_t>(k * stride[2] + j * stride[1] + i)] =
                label[static_cast<size_t>(ck * stride[2] + cj * stride[1] + ci)];
          }
        }
    }
  }
  for (int m = 0; m < K; ++m) res.materialsPresent += present[static_cast<size_t>(m)] > 0 ? 1 : 0;

  // ---- interfaces: interface samples and their subvoxel interface points ----
  progress.beginStage("interfaces");
  std::vector<int32_t> ft(static_cast<size_t>(n), -1);
  std::vector<std::array<int32_t, 3>> seeds;
  std::vector<Vec3> ipoint;  // interface point kept by each interface sample (local mm)
  std::vector<Vec3> inormal; // unit normal of the interface there
  {
    int64_t edges = 0;
#pragma omp parallel for schedule(static) reduction(+ : edges)
    for (int64_t k = 0; k < nz; ++k)
      for (int64_t j = 0; j < ny; ++j)
        for (int64_t i = 0; i < nx; ++i) {
          const int64_t x = k * stride[2] + j * stride[1] + i;
          const int32_t l = label[static_cast<size_t>(x)];
          const int64_t c[3] = {i, j, k};
          bool seed = false;
          for (int a = 0; a < 3; ++a) {
            if (c[a] + 1 < g.dims[a] && label[static_cast<size_t>(x + stride[a])] != l) {
              seed = true;
              ++edges;
            }
            if (c[a] > 0 && label[static_cast<size_t>(x - stride[a])] != l) seed = true;
          }
          if (seed) ft[static_cast<size_t>(x)] = 0;
        }
    res.interfaceEdges = edges;
    for (int64_t k = 0; k < nz; ++k)
      for (int64_t j = 0; j < ny; ++j)
        for (int64_t i = 0; i < nx; ++i) {
          int32_t& f = ft[static_cast<size_t>(k * stride[2] + j * stride[1] + i)];
          if (f < 0) continue;
          f = static_cast<int32_t>(seeds.size());
          seeds.push_back({int32_t(i), int32_t(j), int32_t(k)});
        }
  }
  const int64_t ns = static_cast<int64_t>(seeds.size());
  res.interfaceSamples = ns;
  progress.checkCancel();

  std::vector<float> lfs(static_cast<size_t>(ns), 0.0f);
  if (ns > 0) {
    // Material values at the interface samples (CSR: start[s] .. start[s+1]).
    const int64_t block = 1024;
    const int64_t nBlocks = (ns + block - 1) / block;
    std::vector<std::vector<MaterialSample>> blockValues(static_cast<size_t>(nBlocks));
    std::vector<int64_t> start(static_cast<size_t>(ns) + 1, 0);
    std::atomic<bool> stop{false};
#pragma omp parallel
    {
      std::vector<MaterialSample> s;
#pragma omp for schedule(dynamic, 1)
      for (int64_t bi = 0; bi < nBlocks; ++bi) {
        if (stop.load(std::memory_order_relaxed)) continue;
        auto& out = blockValues[static_cast<size_t>(bi)];
        for (int64_t id = bi * block; id < std::min(ns, (bi + 1) * block); ++id) {
          const auto& c = seeds[static_cast<size_t>(id)];
          materials.sample(sampler.position(c[0], c[1], c[2]), s);
          start[static_cast<size_t>(id) + 1] = static_cast<int64_t>(s.size());
          out.insert(out.end(), s.begin(), s.end());
        }
        if (progress.cancelRequested()) stop.store(true);
      }
    }
    progress.checkCancel();
    for (int64_t id = 0; id < ns; ++id) start[static_cast<size_t>(id) + 1] += start[static_cast<size_t>(id)];
    std::vector<MaterialSample> values;
    values.reserve(static_cast<size_t>(start[static_cast<size_t>(ns)]));
    for (auto& b : blockValues) {
      values.insert(values.end(), b.begin(), b.end());
      std::vector<MaterialSample>().swap(b);
    }
    const float absent = materials.absentValue();

    ipoint.resize(static_cast<size_t>(ns));
    inormal.resize(static_cast<size_t>(ns));
    auto valuesOf = [&](int32_t id) {
      return std::make_pair(values.data() + start[static_cast<size_t>(id)],
                            values.data() + start[static_cast<size_t>(id) + 1]);
    };
#pragma omp parallel for schedule(static)
    for (int64_t id = 0; id < ns; ++id) {
      const auto& c = seeds[static_cast<size_t>(id)];
      const int64_t x = c[2] * stride[2] + c[1] * stride[1] + c[0];
      const int32_t l = label[static_cast<size_t>(x)];
      const Vec3 lx{double(c[0]) * h[0], double(c[1]) * h[1], double(c[2]) * h[2]};
      double bestD = std::numeric_limits<double>::infinity();
      Vec3 best = lx;
      int bestAxis = 0;
      int32_t bestA = l, bestB = l;
      for (int a = 0; a < 3; ++a)
        for (int dir = -1; dir <= 1; dir += 2) {
          const int64_t cn = c[a] + dir;
          if (cn < 0 || cn >= g.dims[a]) continue;
          const int64_t nb = x + dir * stride[a];
          if (label[static_cast<size_t>(nb)] == l) continue;
          // Canonical orientation (p below q along axis a) so both endpoints agree exactly.
          const int64_t p = std::min(x, nb), q = std::max(x, nb);
          const int32_t A = label[static_cast<size_t>(p)], B = label[static_cast<size_t>(q)];
          const auto [vp, vpe] = valuesOf(ft[static_cast<size_t>(p)]);
          const auto [vq, vqe] = valuesOf(ft[static_cast<size_t>(q)]);
          const double gp = double(valueOf(vp, vpe, A, absent)) - double(valueOf(vp, vpe, B, absent));
          const double gq = double(valueOf(vq, vqe, A, absent)) - double(valueOf(vq, vqe, B, absent));
          const double den = gp - gq;
          const double t = den > 0.0 ? std::clamp(gp / den, 0.0, 1.0) : 0.5;
          // Position along axis a, measured from x.
          const double fromP = t * h[a];
          const double along = (p == x) ? fromP : fromP - h[a];
          if (std::abs(along) < bestD) {
            bestD = std::abs(along);
            best = lx;
            best[a] += along;
            bestAxis = a;
            bestA = A;
            bestB = B;
          }
        }
      ipoint[static_cast<size_t>(id)] = best;
      // Normal: least-squares gradient of g = f_A - f_B (a linear fit with intercept) over the
      // interface samples of the 3x3x3 block; the edge's axis when that is degenerate.
      double sd[3] = {0, 0, 0}, sg = 0.0, sdd[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}, sdg[3] = {0, 0, 0};
      int cnt = 0;
      for (int dk = -1; dk <= 1; ++dk)
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) {
            const int64_t ii = c[0] + di, jj = c[1] + dj, kk = c[2] + dk;
            if (ii < 0 || jj < 0 || kk < 0 || ii >= nx || jj >= ny || kk >= nz) continue;
            const int32_t sid = ft[static_cast<size_t>(kk * stride[2] + jj * stride[1] + ii)];
            if (sid < 0) continue;
            const auto [vn, vne] = valuesOf(sid);
            const double gv = double(valueOf(vn, vne, bestA, absent)) - double(valueOf(vn, vne, bestB, absent));
            const double d[3] = {di * h[0], dj * h[1], dk * h[2]};
            ++cnt;
            sg += gv;
            for (int r = 0; r < 3; ++r) {
              sd[r] += d[r];
              sdg[r] += d[r] * gv;
              for (int q = 0; q < 3; ++q) sdd[r][q] += d[r] * d[q];
            }
          }
      double M[3][3], rhs[3];
      for (int r = 0; r < 3; ++r) {
        rhs[r] = sdg[r] - sd[r] * sg / cnt;
        for (int q = 0; q < 3; ++q) M[r][q] = sdd[r][q] - sd[r] * sd[q] / cnt;
      }
      {
        // A grid one sample thick along an axis (a 2-D image) has no extent there: the gradient
        // has no component along it.
        double trOthers = 0.0;
        for (int r = 0; r < 3; ++r) trOthers += M[r][r];
        for (int r = 0; r < 3; ++r)
          if (g.dims[r] == 1) {
            M[r][r] = std::max(trOthers, 1e-300);
            rhs[r] = 0.0;
          }
      }
      Vec3 nrm{0, 0, 0};
      nrm[bestAxis] = 1.0;
      const Mat3 Mm = {{{M[0][0], M[0][1], M[0][2]}, {M[1][0], M[1][1], M[1][2]}, {M[2][0], M[2][1], M[2][2]}}};
      const double detM = det(Mm);
      const double tr = M[0][0] + M[1][1] + M[2][2];
      if (tr > 0.0 && detM > 1e-6 * tr * tr * tr) {
        // Cramer's rule.
        Vec3 grad;
        for (int col = 0; col < 3; ++col) {
          Mat3 Mc = Mm;
          for (int r = 0; r < 3; ++r) Mc[r][col] = rhs[r];
          grad[col] = det(Mc) / detM;
        }
        const double gl = norm(grad);
        if (gl > 0.0 && std::isfinite(gl)) nrm = (1.0 / gl) * grad;
      }
      inormal[static_cast<size_t>(id)] = nrm;
    }
    progress.checkCancel();

    // ---- distance: closest interface sample of every sample ----
    progress.beginStage("distance");
    euclideanFeatureTransform(g.dims, h, seeds, ft);
    progress.checkCancel();

    // ---- medial: divergence of the closest points between same-material neighbours ----
    progress.beginStage("medial");
    std::vector<std::array<int32_t, 3>> medial;
    std::vector<Vec3> mpoint;
    {
      const double cosMax = std::cos(kMinSeparationDeg * kPi / 180.0);
      const double reach = kFootReach * std::max({h[0], h[1], h[2]});
      // Closest point of local position lx: the foot on the tangent plane of its nearest
      // interface sample's point, at most `reach` from that point.
      auto closest = [&](const Vec3& lx, int32_t sid) {
        const Vec3& P = ipoint[static_cast<size_t>(sid)];
        const Vec3& nu = inormal[static_cast<size_t>(sid)];
        const Vec3 v = lx - P;
        Vec3 tang = v - dot(v, nu) * nu;
        const double tl = norm(tang);
        if (tl > reach) tang = (reach / tl) * tang;
        return P + tang;
      };
      // The 13 neighbour offsets later in index order: every pair is examined once.
      std::vector<std::array<int, 3>> fwd;
      for (int dk = -1; dk <= 1; ++dk)
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di)
            if (di + nx * (dj + ny * dk) > 0) fwd.push_back({di, dj, dk});
      struct Candidate {
        int64_t owner;
        double dist; // from the owner sample to y
        Vec3 y;
      };
      auto byOwner = [](const Candidate& u, const Candidate& v) {
        return u.owner < v.owner || (u.owner == v.owner && u.dist < v.dist);
      };
      const int64_t rows = ny * nz;
      const int64_t rowsPerBlock = 16;
      const int64_t nBlocksM = (rows + rowsPerBlock - 1) / rowsPerBlock;
      std::vector<std::vector<Candidate>> found(static_cast<size_t>(nBlocksM));
      std::atomic<bool> stop{false};
#pragma omp parallel for schedule(dynamic, 1)
      for (int64_t bi = 0; bi < nBlocksM; ++bi) {
        if (stop.load(std::memory_order_relaxed)) continue;
        auto& out = found[static_cast<size_t>(bi)];
        for (int64_t r = bi * rowsPerBlock; r < std::min(rows, (bi + 1) * rowsPerBlock); ++r) {
          const int64_t j = r % ny, k = r / ny;
          for (int64_t i = 0; i < nx; ++i) {
            const int64_t x = k * stride[2] + j * stride[1] + i;
            const int32_t l = label[static_cast<size_t>(x)];
            const Vec3 lp{double(i) * h[0], double(j) * h[1], double(k) * h[2]};
            const Vec3 A = closest(lp, ft[static_cast<size_t>(x)]);
            for (const auto& o : fwd) {
              const int64_t ii = i + o[0], jj = j + o[1], kk = k + o[2];
              if (ii < 0 || jj < 0 || kk < 0 || ii >= nx || jj >= ny || kk >= nz) continue;
              const int64_t nb = kk * stride[2] + jj * stride[1] + ii;
              if (label[static_cast<size_t>(nb)] != l) continue;
              // Same nearest interface sample: both feet lie on one tangent plane within one disc
              // (a 1-Lipschitz projection), so |A - B| <= |x - n| and (1) fails.
              if (ft[static_cast<size_t>(nb)] == ft[static_cast<size_t>(x)]) continue;
              const Vec3 lq{double(ii) * h[0], double(jj) * h[1], double(kk) * h[2]};
              const Vec3 B = closest(lq, ft[static_cast<size_t>(nb)]);
              const Vec3 e = lq - lp, ab = B - A;
              if (dot(ab, ab) <= kSpread * kSpread * dot(e, e)) continue; // (1)
              const double den = 2.0 * dot(e, ab);
              if (!(den > 0.0)) continue; // the bisector of A, B does not cross [p, q]
              const Vec3 pa = lp - A, pb = lp - B;
              const double t = std::clamp((dot(pb, pb) - dot(pa, pa)) / den, 0.0, 1.0);
              const Vec3 y = lp + t * e;
              const Vec3 ya = A - y, yb = B - y;
              const double na = norm(ya), nbn = norm(yb);
              if (!(na > 0.0) || !(nbn > 0.0)) continue;
              if (!(dot(ya, yb) < cosMax * na * nbn)) continue; // (2)
              const double le = norm(e);
              if (t <= 0.5) out.push_back({x, t * le, y});
              else out.push_back({nb, (1.0 - t) * le, y});
            }
          }
        }
        // Keep the nearest candidate per owner already here (most owners lie in the block).
        std::stable_sort(out.begin(), out.end(), byOwner);
        out.erase(std::unique(out.begin(), out.end(),
                              [](const Candidate& u, const Candidate& v) { return u.owner == v.owner; }),
                  out.end());
        out.shrink_to_fit();
        if (progress.cancelRequested()) stop.store(true);
      }
      progress.checkCancel();
      std::vector<Candidate> all;
      for (auto& b : found) {
        all.insert(all.end(), b.begin(), b.end());
        std::vector<Candidate>().swap(b);
      }
      // Layers one sample thick: a sample whose two 6-neighbours along an axis both belong to
      // other materials is thin along that axis. It lies on its layer's medial surface (the
      // divergence test above needs 1.5 samples of thickness) when the layer continues: at least
      // two of its four neighbours across that axis have its material and are thin along it too
      // (a sheet or a thin tube, not a one-sample bump on a voxelised surface). Such a sample
      // keeps its own centre as medial point, at distance 0.
      {
        std::vector<uint8_t> thin(static_cast<size_t>(n), 0);
#pragma omp parallel for schedule(static)
        for (int64_t k = 0; k < nz; ++k)
          for (int64_t j = 0; j < ny; ++j)
            for (int64_t i = 0; i < nx; ++i) {
              const int64_t x = k * stride[2] + j * stride[1] + i;
              const int32_t l = label[static_cast<size_t>(x)];
              const int64_t c[3] = {i, j, k};
              uint8_t bits = 0;
              for (int ax = 0; ax < 3; ++ax)
                if (c[ax] > 0 && c[ax] + 1 < g.dims[ax] && label[static_cast<size_t>(x - stride[ax])] != l &&
                    label[static_cast<size_t>(x + stride[ax])] != l)
                  bits |= uint8_t(1 << ax);
              thin[static_cast<size_t>(x)] = bits;
            }
        for (int64_t k = 0; k < nz; ++k)
          for (int64_t j = 0; j < ny; ++j)
            for (int64_t i = 0; i < nx; ++i) {
              const int64_t x = k * stride[2] + j * stride[1] + i;
              const uint8_t bits = thin[static_cast<size_t>(x)];
              if (!bits) continue;
              const int32_t l = label[static_cast<size_t>(x)];
              const int64_t c[3] = {i, j, k};
              bool sheet = false;
              for (int ax = 0; ax < 3 && !sheet; ++ax) {
                if (!(bits & (1 << ax))) continue;
                int along = 0;
                for (int o = 1; o <= 2; ++o) {
                  const int b2 = (ax + o) % 3;
                  for (int dir = -1; dir <= 1; dir += 2) {
                    const int64_t cn = c[b2] + dir;
                    if (cn < 0 || cn >= g.dims[b2]) continue;
                    const int64_t nb = x + dir * stride[b2];
                    if (label[static_cast<size_t>(nb)] == l && (thin[static_cast<size_t>(nb)] & (1 << ax))) ++along;
                  }
                }
                sheet = along >= 2;
              }
              if (sheet) all.push_back({x, 0.0, Vec3{double(i) * h[0], double(j) * h[1], double(k) * h[2]}});
            }
      }
      // One medial point per sample: the nearest to it (ties: the first found, stable order).
      std::stable_sort(all.begin(), all.end(), byOwner);
      for (size_t c = 0; c < all.size(); ++c) {
        if (c > 0 && all[c].owner == all[c - 1].owner) continue;
        const int64_t o = all[c].owner;
        medial.push_back({int32_t(o % nx), int32_t((o / nx) % ny), int32_t(o / (nx * ny))});
        mpoint.push_back(all[c].y);
      }
    }
    res.medialSamples = static_cast<int64_t>(medial.size());
    std::vector<int32_t>().swap(label);
    progress.checkCancel();

    // ---- feature size: distance from each interface point to the nearest medial point ----
    progress.beginStage("feature size");
    const double floorLfs = 0.5 * std::min({h[0], h[1], h[2]});
    if (medial.empty()) {
      std::fill(lfs.begin(), lfs.end(), static_cast<float>(unbounded));
    } else {
      std::fill(ft.begin(), ft.end(), -1);
      for (size_t m = 0; m < medial.size(); ++m) {
        const auto& c = medial[m];
        ft[static_cast<size_t>(c[2] * stride[2] + c[1] * stride[1] + c[0])] = static_cast<int32_t>(m);
      }
      euclideanFeatureTransform(g.dims, h, medial, ft);
#pragma omp parallel for schedule(static)
      for (int64_t id = 0; id < ns; ++id) {
        const auto& c = seeds[static_cast<size_t>(id)];
        const int32_t m = ft[static_cast<size_t>(c[2] * stride[2] + c[1] * stride[1] + c[0])];
        const double d = std::max(norm(ipoint[static_cast<size_t>(id)] - mpoint[static_cast<size_t>(m)]), floorLfs);
        lfs[static_cast<size_t>(id)] = static_cast<float>(std::min(d * params.feature_scaling, unbounded));
      }
    }
    res.minFeatureSize = *std::min_element(lfs.begin(), lfs.end());
    res.maxFeatureSize = *std::max_element(lfs.begin(), lfs.end());
  } else {
    std::vector<int32_t>().swap(label);
  }
  std::vector<int32_t>().swap(ft);
  progress.checkCancel();

  // ---- lipschitz: extension from the interface samples, cap, clamps ----
  progress.beginStage("lipschitz");
  std::vector<float> field(static_cast<size_t>(n), ns > 0 ? kInf : static_cast<float>(unbounded));
  for (int64_t id = 0; id < ns; ++id) {
    const auto& c = seeds[static_cast<size_t>(id)];
    field[static_cast<size_t>(c[2] * stride[2] + c[1] * stride[1] + c[0])] = lfs[static_cast<size_t>(id)];
  }
  if (ns > 0) lipschitzExtension(g.dims, h, params.lipschitz, field);
  progress.checkCancel();
  {
    const float cap = static_cast<float>(unbounded);
    const float lo = static_cast<float>(params.min_size);
    const float hi = static_cast<float>(params.max_size);
    const bool hasLo = params.min_size > 0.0, hasHi = params.max_size > 0.0;
    double mn = std::numeric_limits<double>::infinity(), mx = 0.0, sum = 0.0;
    int64_t toMin = 0, toMax = 0;
#pragma omp parallel for schedule(static) reduction(min : mn) reduction(max : mx) reduction(+ : sum, toMin, toMax)
    for (int64_t x = 0; x < n; ++x) {
      float s = field[static_cast<size_t>(x)];
      if (hasHi && s > hi) ++toMax;
      s = std::min(s, cap);
      if (hasLo && s < lo) {
        s = lo;
        ++toMin;
      }
      if (hasHi) s = std::min(s, hi);
      field[static_cast<size_t>(x)] = s;
      mn = std::min(mn, double(s));
      mx = std::max(mx, double(s));
      sum += s;
    }
    res.minSize = mn;
    res.maxSize = mx;
    res.meanSize = n > 0 ? sum / double(n) : 0.0;
    res.clampedToMin = toMin;
    res.clampedToMax = toMax;
  }
  res.field.grid = g;
  res.field.data = std::move(field);
  progress.endStage();
  return res;
}

void writeSizingFieldReport(const SizingFieldResult& r, Report& rep) {
  const GridGeometry& g = r.field.grid;
  rep.set("dims", dimsText(g.dims));
  std::ostringstream sp;
  sp << g.spacing[0] << " x " << g.spacing[1] << " x " << g.spacing[2];
  rep.set("spacing_mm", sp.str());
  rep.set("samples", ReportValue(r.samples));
  rep.set("materials_present", ReportValue(int64_t(r.materialsPresent)));
  rep.set("interface_edges", ReportValue(r.interfaceEdges));
  rep.set("interface_samples", ReportValue(r.interfaceSamples));
  rep.set("medial_samples", ReportValue(r.medialSamples));
  rep.set("unbounded_size_mm", ReportValue(r.unboundedSize));
  if (r.interfaceSamples > 0) {
    rep.set("min_feature_size_mm", ReportValue(r.minFeatureSize));
    rep.set("max_feature_size_mm", ReportValue(r.maxFeatureSize));
  }
  rep.set("min_size_mm", ReportValue(r.minSize));
  rep.set("max_size_mm", ReportValue(r.maxSize));
  rep.set("mean_size_mm", ReportValue(r.meanSize));
  rep.set("clamped_to_min", ReportValue(r.clampedToMin));
  rep.set("clamped_to_max", ReportValue(r.clampedToMax));
}

} // namespace tetflow
