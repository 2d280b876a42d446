// Layered head from two MNI atlases of mricron-data (see LayeredHead.h). Steps, in order:
//  1. both atlases onto one grid, placed by HarvardOxford's sform (header notes in step 1);
//  2. brain = union of their voxels, closed (2 mm), with its interior cavities filled, in 3-D
//     and in each axial slice (the thalami are in neither atlas); stand-ins for what the atlases
//     lack: a cerebellum and a spinal cord;
//  3. sulci: CSF sheets on the boundaries between different cortical labels near the surface,
//     and the interhemispheric fissure on the midline;
//  4. grey = brain near that CSF, white = the rest (tracts always white); lateral ventricles;
//  5. shells by exact Euclidean distance, with smoothly varying thickness: CSF, skull, scalp;
//     a neck (scalp around vertebrae around the spinal canal) down to the bottom face;
//  6. pieces under 1000 voxels go to their neighbours;
//  7. air inside: frontal sinus and mastoid cells (enclosed in bone), ear canals (open);
//  8. deliberate specks of 1-3 voxels;
//  9. optionally 2 mm: the most frequent label of each 2x2x2 block.
#include "LayeredHead.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Progress.h"
#include "Algorithms/IO/FileUtil.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Algorithms/Quality/LabelTopology.h"
#include "Algorithms/SizingField/SizingField.h"

namespace tetflow {
namespace {

constexpr const char* kCortexFile = "HarvardOxford-cort-maxprob-thr0-1mm.nii.gz";
constexpr const char* kTractsFile = "JHU-WhiteMatter-labels-1mm.nii.gz";
using Mask = std::vector<uint8_t>;
using Dims = std::array<int64_t, 3>;
Mask invert(Mask m) {
  for (auto& v : m) v = !v;
  return m;
}

// f(i, j, k, linear index) over the grid, in parallel over slices.
template <class F> void forVoxels(const Dims& d, F&& f) {
#pragma omp parallel for schedule(static)
  for (int64_t k = 0; k < d[2]; ++k)
    for (int64_t j = 0; j < d[1]; ++j)
      for (int64_t i = 0; i < d[0]; ++i) f(i, j, k, size_t(i + d[0] * (j + d[1] * k)));
}

// Axis-aligned affine map, p[r] = s[r] x[r] + o[r] (voxel index -> RAS mm, or between index
// spaces). All grids involved here are axis-aligned; anything else is refused.
struct Axes {
  double s[3] = {1, 1, 1}, o[3] = {0, 0, 0};
  Vec3 operator()(const Vec3& x) const { return {s[0] * x[0] + o[0], s[1] * x[1] + o[1], s[2] * x[2] + o[2]}; }
  Axes then(const Axes& b) const { // b after this
    Axes c;
    for (int r = 0; r < 3; ++r) c.s[r] = b.s[r] * s[r], c.o[r] = b.s[r] * o[r] + b.o[r];
    return c;
  }
  Axes inverse() const {
    Axes c;
    for (int r = 0; r < 3; ++r) c.s[r] = 1 / s[r], c.o[r] = -o[r] / s[r];
    return c;
  }
};
Axes axesOf(const double m[3][3], const double t[3], const std::string& what) {
  Axes a;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      if (c != r && std::abs(m[r][c]) > 1e-6) throw InputError(what + ": rotated axes are not supported here");
    a.s[r] = m[r][r], a.o[r] = t[r];
  }
  return a;
}

// qform and sform of a NIfTI-1 header (file voxel index -> RAS mm).
struct NiftiForms { Axes qform, sform; int qcode = 0, scode = 0; };
NiftiForms niftiForms(const std::string& path) {
  const std::vector<char> file = readFileBytes(path);
  const std::vector<char> h = looksGzipped(file.data(), file.size())
      ? gunzip(file.data(), file.size(), 348, path)
      : std::vector<char>(file.begin(), file.begin() + std::min<size_t>(348, file.size()));
  int32_t size = 0;
  if (h.size() >= 348) std::memcpy(&size, h.data(), 4);
  if (size != 348) throw InputError(path + ": not a little-endian NIfTI-1 header");
  auto f32 = [&](int off) { float v; std::memcpy(&v, h.data() + off, 4); return double(v); };
  auto i16 = [&](int off) { int16_t v; std::memcpy(&v, h.data() + off, 2); return int(v); };
  const double b = f32(256), c = f32(260), d = f32(264), a = std::sqrt(std::max(0.0, 1 - b * b - c * c - d * d));
  double Q[3][3] = {{a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)},
                    {2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b)},
                    {2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b}}, S[3][3];
  double qt[3], st[3];
  for (int r = 0; r < 3; ++r) {
    for (int col = 0; col < 3; ++col) {
      Q[r][col] *= f32(80 + 4 * col) * (col == 2 && f32(76) < 0 ? -1.0 : 1.0); // pixdim, qfac
      S[r][col] = f32(280 + 16 * r + 4 * col);
    }
    qt[r] = f32(268 + 4 * r), st[r] = f32(292 + 16 * r);
  }
  return {axesOf(Q, qt, path), axesOf(S, st, path), i16(252), i16(254)};
}

// Array index -> RAS mm of a grid as the project's readers describe it (LPS).
Axes gridToRas(const GridGeometry& g) {
  double m[3][3], t[3];
  for (int r = 0; r < 3; ++r) {
    t[r] = (r < 2 ? -1.0 : 1.0) * g.origin[r];
    for (int c = 0; c < 3; ++c) m[r][c] = (r < 2 ? -1.0 : 1.0) * g.direction[r][c] * g.spacing[c];
  }
  return axesOf(m, t, "volume grid");
}

// Smooth random field in [0, 1]: a sum of separable cosine products (wavelengths 30-90 mm, one
// table per axis), stretched and clamped so that both ends of a range cover patches of a few cm.
struct SmoothField {
  static constexpr int K = 6;
  std::vector<float> tab[K][3];
  double amp[K] = {}, sum = 0;
  SmoothField(std::mt19937& rng, const Dims& dims) {
    auto u = [&] { return double(rng()) / 4294967296.0; };
    for (int n = 0; n < K; ++n) {
      sum += amp[n] = 0.5 + u();
      for (int a = 0; a < 3; ++a) {
        const double wave = 30.0 + 60.0 * u(), phase = 2 * M_PI * u();
        for (int64_t x = 0; x < dims[a]; ++x) tab[n][a].push_back(float(std::cos(2 * M_PI * double(x) / wave + phase)));
      }
    }
  }
  double operator()(int64_t i, int64_t j, int64_t k) const {
    double v = 0;
    for (int n = 0; n < K; ++n) v += amp[n] * tab[n][0][size_t(i)] * tab[n][1][size_t(j)] * tab[n][2][size_t(k)];
    return std::clamp(0.5 + 2.5 * v / sum, 0.0, 1.0);
  }
};

double gauss(const Vec3& p, const Vec3& c, double sigma) {
  const Vec3 d = p - c;
  return std::exp(-dot(d, d) / (2 * sigma * sigma));
}
double ellipsoid(const Vec3& p, const Vec3& c, const Vec3& r) { // <= 1 inside
  const Vec3 d = p - c;
  return d[0] * d[0] / (r[0] * r[0]) + d[1] * d[1] / (r[1] * r[1]) + d[2] * d[2] / (r[2] * r[2]);
}

// Background (solid == 0) reached from the box faces through 6-neighbours; with `planar`, within
// each axial slice from its edges through 4-neighbours.
Mask reachable(const Dims& d, const Mask& solid, bool planar) {
  const int64_t nx = d[0], ny = d[1], nz = d[2];
  Mask r(solid.size(), 0);
  std::vector<int64_t> stack;
  auto visit = [&](int64_t i, int64_t j, int64_t k) {
    const size_t x = size_t(i + nx * (j + ny * k));
    if (i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz || solid[x] || r[x]) return;
    r[x] = 1;
    stack.push_back(int64_t(x));
  };
  for (int64_t k = 0; k < nz; ++k)
    for (int64_t j = 0; j < ny; ++j)
      for (int64_t i = 0; i < nx; ++i)
        if (!i || !j || i == nx - 1 || j == ny - 1 || (!planar && (!k || k == nz - 1))) visit(i, j, k);
  while (!stack.empty()) {
    const int64_t x = stack.back(), i = x % nx, j = (x / nx) % ny, k = x / (nx * ny);
    stack.pop_back();
    visit(i - 1, j, k), visit(i + 1, j, k), visit(i, j - 1, k), visit(i, j + 1, k);
    if (!planar) visit(i, j, k - 1), visit(i, j, k + 1);
  }
  return r;
}

} // namespace

std::vector<float> distanceToMask(const Dims& dims, const std::vector<uint8_t>& mask) {
  // Seeds: mask voxels with a 6-neighbour outside the mask (the nearest mask voxel of any voxel
  // outside is one of them).
  const int64_t nx = dims[0], ny = dims[1], nz = dims[2];
  std::vector<std::array<int32_t, 3>> seeds;
  std::vector<int32_t> ft(mask.size(), -1);
  for (int64_t k = 0, x = 0; k < nz; ++k)
    for (int64_t j = 0; j < ny; ++j)
      for (int64_t i = 0; i < nx; ++i, ++x)
        if (mask[size_t(x)] && ((i > 0 && !mask[size_t(x - 1)]) || (i + 1 < nx && !mask[size_t(x + 1)]) ||
                                (j > 0 && !mask[size_t(x - nx)]) || (j + 1 < ny && !mask[size_t(x + nx)]) ||
                                (k > 0 && !mask[size_t(x - nx * ny)]) || (k + 1 < nz && !mask[size_t(x + nx * ny)]))) {
          ft[size_t(x)] = int32_t(seeds.size());
          seeds.push_back({int32_t(i), int32_t(j), int32_t(k)});
        }
  std::vector<float> d(mask.size());
  if (!seeds.empty()) euclideanFeatureTransform(dims, Vec3{1, 1, 1}, seeds, ft);
  forVoxels(dims, [&](int64_t i, int64_t j, int64_t k, size_t x) {
    if (mask[x] || seeds.empty()) { d[x] = mask[x] ? 0.f : INFINITY; return; }
    const auto& s = seeds[size_t(ft[x])];
    d[x] = float(std::sqrt(double((s[0] - i) * (s[0] - i) + (s[1] - j) * (s[1] - j) + (s[2] - k) * (s[2] - k))));
  });
  return d;
}

std::string mricronTemplatesDir() {
  const char* env = std::getenv("TETFLOW_MRICRON_DIR");
  return env && *env ? std::string(env) : std::string("/usr/share/mricron/templates");
}

bool mricronAtlasesPresent(const std::string& dir, std::string* why) {
  for (const char* f : {kCortexFile, kTractsFile}) {
    std::error_code ec;
    if (std::filesystem::is_regular_file(std::filesystem::path(dir) / f, ec)) continue;
    if (why)
      *why = std::string(f) + " not found in " + dir + " (install the Debian package mricron-data, or set TETFLOW_MRICRON_DIR)";
    return false;
  }
  return true;
}

LabelVolume makeLayeredHead(const std::string& dir, const LayeredHeadParams& p, LayeredHeadInfo* info) {
  if (p.variant < 0 || p.variant > 2) throw InputError("layered head: variant must be 0, 1 or 2");
  if (p.parcels && p.voxel != 1) throw InputError("layered head: parcels are made at 1 mm only (voxel 1)");
  if (p.voxel != 1 && p.voxel != 2 && p.voxel != 4) throw InputError("layered head: voxel must be 1, 2 or 4 (mm)");
  std::string why;
  if (!mricronAtlasesPresent(dir, &why)) throw InputError("layered head: " + why);
  LayeredHeadInfo scratch;
  LayeredHeadInfo& inf = info ? *info : scratch;
  inf = LayeredHeadInfo{};

  // ---- 1. Atlases onto one grid. The project's reader applies the qform, and VTK reverses the
  // slices of both files (qfac = -1). mricron-data's qforms do not place them in MNI space
  // (HarvardOxford's offsets are 90, 0, 0; JHU's mirrors z), and JHU's sform says RAS storage
  // although its "_R" tracts lie at x > 0 by HarvardOxford's sform and both midlines are on the
  // same voxel plane: the two files share FSL's MNI152 storage. So every voxel is placed by
  // HarvardOxford's sform, and each atlas is sampled through (reader grid)^-1 o (form the reader
  // used), which undoes whatever the reader did to its array.
  const std::string cortexPath = (std::filesystem::path(dir) / kCortexFile).string();
  const std::string tractsPath = (std::filesystem::path(dir) / kTractsFile).string();
  const LabelVolume hoV = readLabelVolume(cortexPath), jhV = readLabelVolume(tractsPath);
  const NiftiForms fH = niftiForms(cortexPath), fJ = niftiForms(tractsPath);
  if (hoV.grid.dims != jhV.grid.dims || fH.scode <= 0)
    throw InputError("layered head: the two atlases do not share HarvardOxford's 1 mm MNI grid");
  for (int r = 0; r < 3; ++r)
    if (std::abs(std::abs(fH.sform.s[r]) - 1.0) > 1e-6) throw InputError(cortexPath + ": expected a 1 mm sform");
  GridGeometry g; // identity axes (LPS) over the sform's box
  g.dims = hoV.grid.dims;
  for (int r = 0; r < 3; ++r) {
    const double a = fH.sform.o[r], b = a + fH.sform.s[r] * double(g.dims[r] - 1);
    g.origin[r] = r < 2 ? -std::max(a, b) : std::min(a, b);
  }
  const Dims D = g.dims;
  const int64_t nx = D[0], ny = D[1], nz = D[2], n = g.voxelCount();
  const size_t sy = size_t(nx), sz = size_t(nx * ny);
  const Axes outToFile = gridToRas(g).then(fH.sform.inverse());
  auto mapOf = [&](const LabelVolume& v, const NiftiForms& f) { // output index -> atlas array index
    return outToFile.then(f.qcode > 0 ? f.qform : f.sform).then(gridToRas(v.grid).inverse());
  };
  const Axes mapH = mapOf(hoV, fH), mapJ = mapOf(jhV, fJ);
  auto idx = [&](int64_t i, int64_t j, int64_t k) { return size_t(i + nx * (j + ny * k)); };
  auto mni = [&](int64_t i, int64_t j, int64_t k) { // RAS mm of a voxel centre
    return Vec3{-(g.origin[0] + double(i)), -(g.origin[1] + double(j)), g.origin[2] + double(k)};
  };
  auto toIndex = [&](const Vec3& m) { return Vec3{-m[0] - g.origin[0], -m[1] - g.origin[1], m[2] - g.origin[2]}; };
  auto sample = [&](const LabelVolume& v, const Axes& map, int64_t i, int64_t j, int64_t k) {
    const Vec3 q = map(Vec3{double(i), double(j), double(k)});
    const int64_t a = std::llround(q[0]), b = std::llround(q[1]), c = std::llround(q[2]);
    const auto& d = v.grid.dims;
    return (a < 0 || b < 0 || c < 0 || a >= d[0] || b >= d[1] || c >= d[2]) ? 0 : v.at(a, b, c);
  };
  std::vector<int32_t> ho(static_cast<size_t>(n));
  Mask tract(static_cast<size_t>(n)), brain(static_cast<size_t>(n)), cortex(static_cast<size_t>(n));
  forVoxels(D, [&](int64_t i, int64_t j, int64_t k, size_t x) {
    ho[x] = sample(hoV, mapH, i, j, k);
    tract[x] = sample(jhV, mapJ, i, j, k) != 0;
    cortex[x] = ho[x] != 0;
    brain[x] = cortex[x] || tract[x];
  });

  // ---- 2. Brain. Closing by r: voxels within r of the mask, less those within r of the rest.
  auto below = [&](const std::vector<float>& d, double r) {
    Mask m(d.size());
    for (size_t x = 0; x < d.size(); ++x) m[x] = d[x] <= r;
    return m;
  };
  auto closing = [&](const Mask& m, double r) {
    return invert(below(distanceToMask(D, invert(below(distanceToMask(D, m), r))), r));
  };
  // Closed by 2 mm; then background not reached from the box faces (6-connected) is an interior
  // cavity, and, from 12 mm below the AC-PC plane up, background not reached from the edges of
  // its axial slice (4-connected) a notch enclosed in that slice (thalami and hypothalamus, in
  // neither atlas; lower down such rings enclose cisterns): both become brain.
  brain = invert(reachable(D, closing(brain, 2), false));
  const Mask notch = invert(reachable(D, brain, true));
  forVoxels(D, [&](int64_t i, int64_t j, int64_t k, size_t x) { brain[x] = brain[x] || (notch[x] && mni(i, j, k)[2] >= -12); });
  // Stand-ins: a cerebellum (two ellipsoids, 2.5 mm clear of the cortex so that CSF separates
  // them where the tentorium would be; it joins the brainstem's peduncle tracts) and a spinal
  // cord (white, radius 4.5 mm) from the brainstem's lowest tract voxels to the bottom face.
  double cordX = 0, cordY = 0, cordN = 0;
  int64_t lowest = 0;
  while (lowest < nz - 1 && std::count(tract.begin() + int64_t(sz) * lowest, tract.begin() + int64_t(sz) * (lowest + 1), 1) == 0)
    ++lowest;
  for (int64_t k = lowest; k < std::min(nz, lowest + 4); ++k)
    for (int64_t j = 0; j < ny; ++j)
      for (int64_t i = 0; i < nx; ++i)
        if (tract[idx(i, j, k)]) cordX += mni(i, j, k)[0], cordY += mni(i, j, k)[1], cordN += 1;
  cordX /= std::max(1.0, cordN);
  cordY /= std::max(1.0, cordN);
  const double cordTop = mni(0, 0, std::min(lowest + 4, nz - 1))[2];
  auto inCylinder = [&](const Vec3& m, double r) { return m[2] <= cordTop && std::hypot(m[0] - cordX, m[1] - cordY) <= r; };
  auto cerebellum = [&](const Vec3& m) {
    return std::min(ellipsoid(m, {24, -62, -36}, {26, 25, 18}), ellipsoid(m, {-24, -62, -36}, {26, 25, 18})) <= 1;
  };
  forVoxels(D, [&](int64_t i, int64_t j, int64_t k, size_t x) {
    const Vec3 m = mni(i, j, k);
    bool clear = cerebellum(m);
    for (int64_t c = std::max<int64_t>(0, k - 2); clear && c <= std::min(nz - 1, k + 2); ++c)
      for (int64_t b = std::max<int64_t>(0, j - 2); clear && b <= std::min(ny - 1, j + 2); ++b)
        for (int64_t a = std::max<int64_t>(0, i - 2); clear && a <= std::min(nx - 1, i + 2); ++a)
          clear = !cortex[idx(a, b, c)] || (a - i) * (a - i) + (b - j) * (b - j) + (c - k) * (c - k) > 6;
    if (clear) brain[x] = 1;
    if (inCylinder(m, 4.5)) brain[x] = tract[x] = 1;
  });

  // The brain's 10 mm closing (its envelope, with the stand-ins) is intracranial: what it adds is CSF (the cisterns
  // between temporal lobes, brainstem and cerebellum), so the skull base stays smooth.
  const Mask envelope = closing(brain, 10);

  // ---- 3. Sulci. A voxel is sulcal CSF when its cortical label differs from a 6-neighbour's
  // (on the higher label's side only: one voxel thick; on both where a random field is high:
  // two), it lies within 10-15 mm of the brain's surface and is no tract. The interhemispheric
  // fissure: the midline plane (x = 0, and x = -1 where that field is high) to a depth of 35 mm,
  // stopped 2 voxels short of the tracts (the corpus callosum), not in the cerebellum.
  std::mt19937 rng(0x7e7f10u + 7919u * uint32_t(p.variant));
  auto u01 = [&] { return double(rng()) / 4294967296.0; };
  const SmoothField fCsf(rng, D), fSkull(rng, D), fScalp(rng, D), fGrey(rng, D), fSulcus(rng, D), fTwo(rng, D);
  const std::vector<float> depth = distanceToMask(D, invert(brain));
  const int64_t mid = std::llround(toIndex({0, 0, 0})[0]);
  Mask sulcus(static_cast<size_t>(n), 0);
  forVoxels(D, [&](int64_t i, int64_t j, int64_t k, size_t x) {
    if (!brain[x] || tract[x] || !i || !j || !k || i == nx - 1 || j == ny - 1 || k == nz - 1) return;
    const bool two = fTwo(i, j, k) > 0.7;
    if (ho[x] && depth[x] <= p.sulcusMin + (p.sulcusMax - p.sulcusMin) * fSulcus(i, j, k))
      for (size_t y : {x - 1, x + 1, x - sy, x + sy, x - sz, x + sz})
        if (brain[y] && ho[y] && ho[y] != ho[x] && (ho[x] > ho[y] || two)) sulcus[x] = 1;
    if ((i == mid || (i == mid + 1 && two)) && depth[x] <= 35 && !cerebellum(mni(i, j, k))) {
      bool nearTract = false;
      for (int64_t c = std::max<int64_t>(0, k - 2); c <= std::min(nz - 1, k + 2); ++c)
        for (int64_t b = std::max<int64_t>(0, j - 2); b <= std::min(ny - 1, j + 2); ++b)
          for (int64_t a = i - 2; a <= i + 2; ++a) nearTract = nearTract || tract[idx(a, b, c)];
      sulcus[x] = sulcus[x] || !nearTract;
    }
  });

  // ---- 4. Grey matter: brain within 2.5-3 mm of non-brain or sulcus, unless a tract; white: the
  // rest. Lateral ventricles: two ellipsoids beneath the corpus callosum, cut to white matter at
  // least 6 mm from all other CSF (so grey matter and outer CSF never reach them).
  Mask csfSeed = invert(brain);
  for (int64_t x = 0; x < n; ++x) csfSeed[size_t(x)] |= sulcus[size_t(x)];
  const std::vector<float> dCsf = distanceToMask(D, csfSeed);
  LabelVolume out;
  out.allocate(g, kHeadAir);
  auto& L = out.data;
  forVoxels(D, [&](int64_t i, int64_t j, int64_t k, size_t x) {
    if (!brain[x]) return;
    const bool grey = !tract[x] && dCsf[x] <= p.greyMin + (p.greyMax - p.greyMin) * fGrey(i, j, k);
    L[x] = sulcus[x] ? kHeadCsf : grey ? kHeadGrey : kHeadWhite;
    const Vec3 m = mni(i, j, k);
    const double e = std::min(ellipsoid(m, {13, -10, 16}, {6, 30, 8}), ellipsoid(m, {-13, -10, 16}, {6, 30, 8}));
    if (!tract[x] && dCsf[x] >= 6 && e <= 1) L[x] = kHeadCsf;
  });
  for (int64_t x = 0; x < n; ++x) {
    inf.sulcusVoxels += sulcus[size_t(x)];
    inf.ventricleVoxels += !sulcus[size_t(x)] && brain[size_t(x)] && L[size_t(x)] == kHeadCsf;
  }

  // ---- 5. Shells. Intracranial = the envelope, plus everything within t_csf (1-3 mm, at least
  // 1.75 so no brain voxel touches bone even diagonally) of the brain, plus the spinal canal
  // (radius 8 mm around the cord): its non-brain voxels are CSF. Skull: within t_skull (4-7 mm,
  // towards 4 at the temples, thicker where the cavities sit) of it. Scalp: within t_scalp
  // (4-7 mm) of the skull, plus the neck (an elliptic cylinder around the cord).
  const std::vector<float> dBrain = distanceToMask(D, brain);
  Mask inner(static_cast<size_t>(n));
  forVoxels(D, [&](int64_t i, int64_t j, int64_t k, size_t x) {
    inner[x] = brain[x] || envelope[x] || dBrain[x] <= std::max(1.75, p.csfMin + (p.csfMax - p.csfMin) * fCsf(i, j, k)) ||
               inCylinder(mni(i, j, k), 8);
    if (inner[x] && !brain[x]) L[x] = kHeadCsf;
  });
  auto hit = [&](Vec3 m, const Vec3& dir) { // first intracranial point on a ray from outside
    for (int s = 0; s < 400; ++s, m = m + 0.5 * dir) {
      const Vec3 q = toIndex(m);
      const int64_t a = std::llround(q[0]), b = std::llround(q[1]), c = std::llround(q[2]);
      if (a >= 0 && b >= 0 && c >= 0 && a < nx && b < ny && c < nz && inner[idx(a, b, c)]) return m;
    }
    throw ProcessingError("layered head: a cavity ray missed the head");
  };
  const double earY = -22, earZ = -36; // MNI mm
  const Vec3 sinusC = hit({0, 120, 16}, {0, -1, 0}) + Vec3{0, 5.5, 0};
  const Vec3 mastoidC[2] = {hit({120, earY - 15, earZ + 3}, {-1, 0, 0}) + Vec3{4.5, 0, 0},
                            hit({-120, earY - 15, earZ + 3}, {1, 0, 0}) + Vec3{-4.5, 0, 0}};
  auto skullT = [&](int64_t i, int64_t j, int64_t k) {
    const Vec3 m = mni(i, j, k);
    const double t = (p.skullMax - p.skullMin) * fSkull(i, j, k);
    return p.skullMin + t * (1 - 0.9 * std::max(gauss(m, {66, 14, 4}, 18), gauss(m, {-66, 14, 4}, 18))) +
           (p.cavities ? 4 * gauss(m, sinusC, 14) + 5 * std::max(gauss(m, mastoidC[0], 9), gauss(m, mastoidC[1], 9)) : 0);
  };
  const std::vector<float> dInner = distanceToMask(D, inner);
  Mask bone(static_cast<size_t>(n));
  forVoxels(D, [&](int64_t i, int64_t j, int64_t k, size_t x) {
    bone[x] = inner[x] || (dInner[x] <= 20 && dInner[x] <= skullT(i, j, k));
    if (bone[x] && !inner[x]) L[x] = kHeadSkull;
  });
  const std::vector<float> dBone = distanceToMask(D, bone);
  forVoxels(D, [&](int64_t i, int64_t j, int64_t k, size_t x) {
    const Vec3 m = mni(i, j, k);
    const bool neck = m[2] <= cordTop + 8 && ellipsoid({m[0], m[1], 0}, {cordX, cordY + 12, 0}, {46, 50, 1}) <= 1;
    if (!bone[x] && (neck || dBone[x] <= p.scalpMin + (p.scalpMax - p.scalpMin) * fScalp(i, j, k))) L[x] = kHeadScalp;
  });

  // ---- 6. Pieces under 1000 voxels (26-connected) take the most frequent label around them
  // (stray bits of sulci, notches): the cavities and specks placed next are the only islands.
  {
    NullProgress np;
    const LabelImageTopology topo = analyzeLabelImage(out, np);
    std::vector<std::array<int64_t, 6>> votes(topo.comps.size(), std::array<int64_t, 6>{});
    for (int64_t k = 0; k < nz; ++k)
      for (int64_t j = 0; j < ny; ++j)
        for (int64_t i = 0; i < nx; ++i) {
          const int32_t id = topo.comp[idx(i, j, k)];
          if (topo.comps[size_t(id)].voxels >= 1000) continue;
          for (int64_t c = std::max<int64_t>(k - 1, 0); c <= std::min(k + 1, nz - 1); ++c)
            for (int64_t b = std::max<int64_t>(j - 1, 0); b <= std::min(j + 1, ny - 1); ++b)
              for (int64_t a = std::max<int64_t>(i - 1, 0); a <= std::min(i + 1, nx - 1); ++a)
                if (topo.comp[idx(a, b, c)] != id) ++votes[size_t(id)][size_t(L[idx(a, b, c)])];
        }
    for (int64_t x = 0; x < n; ++x) {
      const size_t id = size_t(topo.comp[size_t(x)]);
      if (topo.comps[id].voxels < 1000)
        L[size_t(x)] = int32_t(std::max_element(votes[id].begin(), votes[id].end()) - votes[id].begin());
    }
  }
  // ---- 7. Air inside. Frontal sinus and mastoid cells: ellipsoids cut to the bone lying at least
  // 2.5 mm from both of its faces, so bone encloses them (no contact, not even diagonal). Ear
  // canals: cylinders (radius 3.5 mm) along x from outside through the scalp into the bone,
  // ending 2.5 mm short of the CSF: open to the outside air.
  auto at = [&](const Vec3& m) {
    const Vec3 q = toIndex(m);
    return std::array<int, 3>{int(std::lround(q[0])), int(std::lround(q[1])), int(std::lround(q[2]))};
  };
  if (p.cavities) {
    const Vec3 earIn[2] = {hit({120, earY, earZ}, {-1, 0, 0}), hit({-120, earY, earZ}, {1, 0, 0})};
    forVoxels(D, [&](int64_t i, int64_t j, int64_t k, size_t x) {
      const Vec3 m = mni(i, j, k);
      const bool deepBone = L[x] == kHeadSkull && dInner[x] >= 2.5 && dInner[x] <= skullT(i, j, k) - 2.5;
      bool air = deepBone && ellipsoid(m, sinusC, {12, 3.5, 9}) <= 1;
      for (int s = 0; s < 2; ++s)
        air = air || (deepBone && ellipsoid(m, mastoidC[s], {4, 5, 5}) <= 1) ||
              ((s ? m[0] <= earIn[s][0] : m[0] >= earIn[s][0]) && std::hypot(m[1] - earY, m[2] - earZ) <= 3.5 &&
               dInner[x] >= 2.5 && L[x] != kHeadAir);
      if (air) L[x] = kHeadAir;
    });
    inf.earCanal = {at({90, earY, earZ}), at({-90, earY, earZ})};
    inf.mastoid = {at(mastoidC[0]), at(mastoidC[1])};
    inf.frontalSinus = at(sinusC);
  }

  // ---- 8. Specks, two of each: white in grey (1 voxel), bone in scalp (a calcification, 2 voxels), air
  // in scalp (3), CSF in white (2). All 26 neighbours of a speck's voxels are its host's.
  if (p.specks) {
    const int32_t kinds[4][3] = {{kHeadWhite, kHeadGrey, 1}, {kHeadSkull, kHeadScalp, 2}, {kHeadAir, kHeadScalp, 3},
                                 {kHeadCsf, kHeadWhite, 2}}; // speck, host, voxels
    for (const auto& kind : kinds)
      for (int copy = 0; copy < 2; ++copy)
        for (int tries = 0; tries < 1000000; ++tries) {
          const int64_t i = 2 + int64_t(u01() * double(nx - 6)), j = 2 + int64_t(u01() * double(ny - 6)),
                        k = 2 + int64_t(u01() * double(nz - 6));
          const size_t step = std::array<size_t, 3>{1, sy, sz}[size_t(u01() * 3)];
          bool ok = true;
          for (int s = 0; s < kind[2]; ++s)
            for (int c = -1; c <= 1; ++c)
              for (int b = -1; b <= 1; ++b)
                for (int a = -1; a <= 1; ++a) ok = ok && L[idx(i + a, j + b, k + c) + size_t(s) * step] == kind[1];
          if (!ok) continue;
          for (int s = 0; s < kind[2]; ++s) L[idx(i, j, k) + size_t(s) * step] = kind[0];
          inf.specks.push_back({int(i), int(j), int(k), kind[0]});
          break;
        }
  }
  // ---- 9. Parcels: a many-label brain atlas of realistic shapes (a stand-in for atlases such as
  // AAL's 116 regions, which label the brain and nothing around it). Grey matter takes its
  // cortical label, left (6-53) or right (54-101); grey without one (the stand-ins) stays grey,
  // white stays white; everything outside the brain (CSF included) becomes 0.
  if (p.parcels) {
    forVoxels(D, [&](int64_t i, int64_t j, int64_t k, size_t x) {
      if (L[x] == kHeadGrey && ho[x] > 0 && ho[x] <= 48) L[x] = 5 + ho[x] + (mni(i, j, k)[0] > 0 ? 48 : 0);
      else if (L[x] != kHeadGrey && L[x] != kHeadWhite) L[x] = kHeadAir;
    });
  }
  if (p.voxel == 1) return out;

  // ---- 10. 2 or 4 mm: the most frequent label of each 2x2x2 (4x4x4) block (ties to the lower label).
  const int b = p.voxel;
  GridGeometry g2 = g;
  for (int a = 0; a < 3; ++a) g2.dims[a] = g.dims[a] / b, g2.spacing[a] = b, g2.origin[a] = g.origin[a] + 0.5 * (b - 1);
  LabelVolume out2;
  out2.allocate(g2, kHeadAir);
  forVoxels(g2.dims, [&](int64_t i, int64_t j, int64_t k, size_t x) {
    int count[6] = {};
    for (int c = 0; c < b * b * b; ++c) ++count[L[idx(b * i + c % b, b * j + c / b % b, b * k + c / (b * b))]];
    out2.data[x] = int32_t(std::max_element(count, count + 6) - count);
  });
  return out2;
}

} // namespace tetflow
