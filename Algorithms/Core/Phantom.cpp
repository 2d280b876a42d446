#include "Phantom.h"

#include <cmath>
#include <numbers>
#include <sstream>

#include "Errors.h"

namespace tetflow {

namespace {
struct KindName {
  PhantomKind kind;
  const char* name;
};
constexpr KindName kKindNames[] = {{PhantomKind::Head, "head"},
                                   {PhantomKind::Sphere, "sphere"},
                                   {PhantomKind::TwoSpheres, "two_spheres"},
                                   {PhantomKind::Shell, "shell"},
                                   {PhantomKind::Blob, "blob"}};

void require(bool ok, const std::string& param, double value, const std::string& rule) {
  if (!ok) {
    std::ostringstream m;
    m << "phantom parameter '" << param << "' = " << value << ": " << rule;
    throw InputError(m.str());
  }
}

double sphereVolume(double r) { return 4.0 / 3.0 * std::numbers::pi * r * r * r; }
} // namespace

const char* phantomKindName(PhantomKind k) {
  for (const auto& kn : kKindNames)
    if (kn.kind == k) return kn.name;
  return "?";
}

PhantomKind phantomKindFromName(const std::string& name) {
  std::string valid;
  for (const auto& kn : kKindNames) {
    if (name == kn.name) return kn.kind;
    valid += std::string(valid.empty() ? "" : ", ") + kn.name;
  }
  throw InputError("unknown phantom kind '" + name + "'; valid kinds: " + valid);
}

int32_t Phantom::labelAt(const Vec3& p) const {
  int32_t label = background;
  for (const auto& s : spheres) {
    const Vec3 d = p - s.center;
    if (dot(d, d) <= s.radius * s.radius) label = s.label;
  }
  for (const auto& b : boxes)
    if (p[0] >= b.lo[0] && p[0] < b.hi[0] && p[1] >= b.lo[1] && p[1] < b.hi[1] &&
        p[2] >= b.lo[2] && p[2] < b.hi[2])
      label = b.label;
  return label;
}

std::map<int32_t, double> Phantom::analyticVolumes() const {
  std::map<int32_t, double> vol;
  const PhantomParams& p = params;
  switch (p.kind) {
    case PhantomKind::Head:
      vol[1] = sphereVolume(p.radius) - sphereVolume(p.skull_radius);
      vol[2] = sphereVolume(p.skull_radius) - sphereVolume(p.csf_radius);
      vol[3] = sphereVolume(p.csf_radius) - sphereVolume(p.brain_radius);
      vol[4] = sphereVolume(p.brain_radius);
      break;
    case PhantomKind::Sphere: vol[1] = sphereVolume(p.radius); break;
    case PhantomKind::TwoSpheres:
      vol[1] = sphereVolume(p.radius);
      vol[2] = sphereVolume(p.radius);
      break;
    case PhantomKind::Shell:
      vol[1] = sphereVolume(p.radius) - sphereVolume(p.radius - p.shell_thickness);
      vol[2] = sphereVolume(p.radius - p.shell_thickness);
      break;
    case PhantomKind::Blob:
      vol[1] = sphereVolume(p.radius);
      vol[2] = 7.0 * volume.grid.voxelVolume();
      break;
  }
  return vol;
}

Phantom makePhantom(const PhantomParams& p) {
  require(std::isfinite(p.voxel_size) && p.voxel_size > 0, "voxel_size", p.voxel_size,
          "must be a positive number of mm");
  require(std::isfinite(p.radius) && p.radius > 0, "radius", p.radius,
          "must be a positive number of mm");
  require(std::isfinite(p.margin) && p.margin >= 0, "margin", p.margin, "must be >= 0 mm");
  require(p.dims >= 0 && p.dims <= 4096, "dims", p.dims, "must be 0 (automatic) or 1..4096");
  Phantom ph;
  ph.params = p;
  const double R = p.radius;
  double halfExtent = R; // half size of the shapes' bounding box along the largest axis
  switch (p.kind) {
    case PhantomKind::Head:
      require(p.skull_radius > 0 && p.skull_radius < R, "skull_radius", p.skull_radius,
              "must be between 0 and radius");
      require(p.csf_radius > 0 && p.csf_radius < p.skull_radius, "csf_radius", p.csf_radius,
              "must be between 0 and skull_radius");
      require(p.brain_radius > 0 && p.brain_radius < p.csf_radius, "brain_radius",
              p.brain_radius, "must be between 0 and csf_radius");
      ph.spheres = {{{0, 0, 0}, R, 1},
                    {{0, 0, 0}, p.skull_radius, 2},
                    {{0, 0, 0}, p.csf_radius, 3},
                    {{0, 0, 0}, p.brain_radius, 4}};
      break;
    case PhantomKind::Sphere: ph.spheres = {{{0, 0, 0}, R, 1}}; break;
    case PhantomKind::TwoSpheres:
      ph.spheres = {{{-R, 0, 0}, R, 1}, {{R, 0, 0}, R, 2}};
      halfExtent = 2 * R;
      break;
    case PhantomKind::Shell:
      require(p.shell_thickness > 0 && p.shell_thickness < R, "shell_thickness",
              p.shell_thickness, "must be between 0 and radius");
      ph.spheres = {{{0, 0, 0}, R, 1}, {{0, 0, 0}, R - p.shell_thickness, 2}};
      break;
    case PhantomKind::Blob: ph.spheres = {{{0, 0, 0}, R, 1}}; halfExtent = 1.8 * R; break;
  }
  // Shift the sphere so the blob sits in free space on the +x side.
  if (p.kind == PhantomKind::Blob) ph.spheres[0].center = {-0.8 * R, 0, 0};

  GridGeometry g;
  const int64_t n = p.dims > 0 ? p.dims
                               : static_cast<int64_t>(
                                     std::ceil(2.0 * (halfExtent + p.margin) / p.voxel_size)) + 1;
  require(n <= 4096, "voxel_size", p.voxel_size,
          "gives more than 4096 voxels per axis; use a larger voxel_size");
  g.dims = {n, n, n};
  g.spacing = {p.voxel_size, p.voxel_size, p.voxel_size};
  const double o = -0.5 * static_cast<double>(n - 1) * p.voxel_size;
  g.origin = {o, o, o};
  if (p.kind == PhantomKind::TwoSpheres) {
    // Elongated box along x; y,z only need one sphere.
    const int64_t ny = p.dims > 0 ? p.dims
                                  : static_cast<int64_t>(
                                        std::ceil(2.0 * (R + p.margin) / p.voxel_size)) + 1;
    g.dims = {n, ny, ny};
    const double oy = -0.5 * static_cast<double>(ny - 1) * p.voxel_size;
    g.origin = {o, oy, oy};
  }
  ph.volume.allocate(g, ph.background);
  if (p.kind == PhantomKind::Head) ph.volume.labelNames = {{0, "air"}, {1, "scalp"}, {2, "skull"}, {3, "CSF"}, {4, "brain"}};

  const int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
#pragma omp parallel for schedule(static)
  for (int64_t k = 0; k < nz; ++k)
    for (int64_t j = 0; j < ny; ++j)
      for (int64_t i = 0; i < nx; ++i)
        ph.volume.at(i, j, k) = ph.labelAt(g.indexToPhysical(double(i), double(j), double(k)));

  if (p.kind == PhantomKind::Blob) {
    // The voxel nearest to (0.55 R, 0, 0) and its 6 face neighbours.
    auto idx = [&](int a, double x) {
      return static_cast<int64_t>(std::llround((x - g.origin[a]) / g.spacing[a]));
    };
    const int64_t ci = idx(0, 0.55 * R), cj = idx(1, 0.0), ck = idx(2, 0.0);
    const int64_t off[7][3] = {{0, 0, 0}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0},
                               {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (const auto& o3 : off) {
      const int64_t i = ci + o3[0], j = cj + o3[1], k = ck + o3[2];
      require(i >= 0 && j >= 0 && k >= 0 && i < nx && j < ny && k < nz, "dims",
              static_cast<double>(p.dims), "too small to hold the blob");
      require(ph.volume.at(i, j, k) == ph.background, "radius", R,
              "too small relative to voxel_size: the blob touches the sphere");
      ph.volume.at(i, j, k) = 2;
      const Vec3 c = g.indexToPhysical(double(i), double(j), double(k));
      const Vec3 h = 0.5 * g.spacing;
      ph.boxes.push_back({c - h, c + h, 2});
    }
  }
  return ph;
}

} // namespace tetflow
