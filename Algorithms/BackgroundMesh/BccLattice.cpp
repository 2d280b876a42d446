#include "BccLattice.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <iomanip>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/MemoryBudget.h"

namespace tetflow {

SizeRange checkSizingField(const ScalarVolume& sizing) {
  sizing.grid.validate("background mesh: sizing field");
  if (sizing.data.size() != size_t(sizing.grid.voxelCount()))
    throw InputError("background mesh: sizing field has the wrong number of values");
  SizeRange r{std::numeric_limits<float>::max(), 0.0f};
  for (size_t i = 0; i < sizing.data.size(); ++i) {
    const float s = sizing.data[i];
    if (!(s > 0.0f) || !std::isfinite(s)) {
      const int64_t nx = sizing.grid.dims[0], ny = sizing.grid.dims[1];
      std::ostringstream m;
      m << "sizing field value " << s << " at sample (" << int64_t(i) % nx << ", " << (int64_t(i) / nx) % ny
        << ", " << int64_t(i) / (nx * ny) << ") is not a positive size in mm; compute the field with "
        << "ComputeSizingField or clamp it with min_size";
      throw InputError(m.str());
    }
    r.min = std::min(r.min, s);
    r.max = std::max(r.max, s);
  }
  return r;
}

double bccSnappedCell(const BccParams& p) {
  if (!(p.snap_voxel > 0.0) || !(p.cell_size > 0.0) || !std::isfinite(p.cell_size)) return p.cell_size;
  return p.snap_voxel * std::exp2(std::round(std::log2(p.cell_size / p.snap_voxel)));
}

BackgroundMesh generateRegularBcc(const GridGeometry& grid, const BccParams& asked, Progress& progress) {
  grid.validate("background mesh: volume");
  if (!(asked.cell_size > 0.0) || !std::isfinite(asked.cell_size))
    throw InputError("cell_size must be a positive number of mm");
  BccParams p = asked;
  p.cell_size = bccSnappedCell(asked);
  std::string named; // cell_size as the user gave it, and the cells it became
  {
    std::ostringstream o;
    o << "cell_size " << asked.cell_size << " mm";
    if (p.cell_size != asked.cell_size) o << " (cells of " << p.cell_size << " mm: a power of two times the voxel)";
    named = o.str();
  }
  if (!(p.padding >= 0.0) || !std::isfinite(p.padding))
    throw InputError("padding must be >= 0 mm");
  progress.beginStage("lattice");
  BackgroundMesh bg;
  Vec3 lo, len;
  int64_t n[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = -0.5 * grid.spacing[a] - p.padding;
    len[a] = double(grid.dims[a]) * grid.spacing[a] + 2.0 * p.padding;
    n[a] = std::max<int64_t>(1, std::llround(len[a] / p.cell_size));
    bg.cells[a] = n[a];
    bg.cellSize[a] = len[a] / double(n[a]);
  }
  const int64_t nx = n[0], ny = n[1], nz = n[2];
  // In double first: a tiny cell_size would overflow the int64 counts below.
  const double tetsD = 12.0 * double(nx) * double(ny) * double(nz);
  // Peak memory: 34 bytes per tet measured (head phantom, 1.4-5.8 M tets: tets, materials,
  // points, vertex kinds); 40 assumed. Tets go as cell_size^-3.
  {
    std::ostringstream what;
    what << named << " (" << nx << " x " << ny << " x " << nz << " cells, " << std::fixed << std::setprecision(0) << tetsD
         << " tets)";
    requireMemory(kBccBytesPerTet * tetsD, what.str(), [&](double avail) {
      double need = p.cell_size * std::cbrt(kBccBytesPerTet * tetsD / std::max(avail, 1.0)) * 1.02;
      // Snapped: the smallest cell_size whose power of two is >= need (the geometric midpoint below it).
      if (p.snap_voxel > 0) need = p.snap_voxel * std::exp2(std::ceil(std::log2(need / p.snap_voxel)) - 0.5) * 1.001;
      std::ostringstream f;
      f << "use cell_size >= " << roundUpForAdvice(need);
      return f.str();
    });
  }
  auto tooMany = [&] {
    std::ostringstream m;
    m << named << " gives " << nx << " x " << ny << " x " << nz << " cells, too many for one mesh; use a larger cell_size";
    return InputError(m.str());
  };
  if (tetsD > double((int64_t(1) << 31) - 1)) throw tooMany();
  const int64_t nPrimal = (nx + 1) * (ny + 1) * (nz + 1);
  const int64_t nDual = nx * ny * nz;
  const int64_t nFace = 2 * (ny * nz + nx * nz + nx * ny);
  const int64_t nVerts = nPrimal + nDual + nFace;
  const int64_t nTets = 12 * nDual; // 4 per cell face, each interior face shared by 2 cells
  if (nVerts > (int64_t(1) << 31) - 1 || nTets > (int64_t(1) << 31) - 1) throw tooMany();
  auto primal = [&](int64_t i, int64_t j, int64_t k) {
    return static_cast<int32_t>(i + (nx + 1) * (j + (ny + 1) * k));
  };
  auto dual = [&](int64_t i, int64_t j, int64_t k) {
    return static_cast<int32_t>(nPrimal + i + nx * (j + ny * k));
  };
  // Face centres: six groups (x-, x+, y-, y+, z-, z+).
  const int64_t faceBase[6] = {nPrimal + nDual,
                               nPrimal + nDual + ny * nz,
                               nPrimal + nDual + 2 * ny * nz,
                               nPrimal + nDual + 2 * ny * nz + nx * nz,
                               nPrimal + nDual + 2 * ny * nz + 2 * nx * nz,
                               nPrimal + nDual + 2 * ny * nz + 2 * nx * nz + nx * ny};
  auto faceCentre = [&](int side, int64_t u, int64_t v) {
    // side 0/1: (u,v) = (j,k); 2/3: (i,k); 4/5: (i,j)
    const int64_t stride = side < 2 ? ny : nx;
    return static_cast<int32_t>(faceBase[side] + u + stride * v);
  };

  TetMesh& m = bg.mesh;
  m.points.resize(static_cast<size_t>(nVerts));
  bg.kind.resize(static_cast<size_t>(nVerts));
  const Vec3 h = bg.cellSize;
  auto local = [&](double i, double j, double k) -> Vec3 {
    return {lo[0] + i * h[0], lo[1] + j * h[1], lo[2] + k * h[2]};
  };
  auto toPhysical = [&](const Vec3& l) { return grid.origin + mul(grid.direction, l); };
#pragma omp parallel for schedule(static)
  for (int64_t k = 0; k <= nz; ++k)
    for (int64_t j = 0; j <= ny; ++j)
      for (int64_t i = 0; i <= nx; ++i) {
        m.points[primal(i, j, k)] = toPhysical(local(double(i), double(j), double(k)));
        bg.kind[primal(i, j, k)] = LatticeVertexKind::Primal;
        if (i < nx && j < ny && k < nz) {
          m.points[dual(i, j, k)] = toPhysical(local(i + 0.5, j + 0.5, k + 0.5));
          bg.kind[dual(i, j, k)] = LatticeVertexKind::Dual;
        }
      }
  for (int64_t k = 0; k < nz; ++k)
    for (int64_t j = 0; j < ny; ++j) {
      m.points[faceCentre(0, j, k)] = toPhysical(local(0, j + 0.5, k + 0.5));
      m.points[faceCentre(1, j, k)] = toPhysical(local(double(nx), j + 0.5, k + 0.5));
    }
  for (int64_t k = 0; k < nz; ++k)
    for (int64_t i = 0; i < nx; ++i) {
      m.points[faceCentre(2, i, k)] = toPhysical(local(i + 0.5, 0, k + 0.5));
      m.points[faceCentre(3, i, k)] = toPhysical(local(i + 0.5, double(ny), k + 0.5));
    }
  for (int64_t j = 0; j < ny; ++j)
    for (int64_t i = 0; i < nx; ++i) {
      m.points[faceCentre(4, i, j)] = toPhysical(local(i + 0.5, j + 0.5, 0));
      m.points[faceCentre(5, i, j)] = toPhysical(local(i + 0.5, j + 0.5, double(nz)));
    }
  for (int64_t v = nPrimal + nDual; v < nVerts; ++v) bg.kind[v] = LatticeVertexKind::FaceCentre;

  progress.checkCancel();
  // Tets: for every cell, its 6 faces; an interior face is emitted by the cell on its low side.
  m.tets.resize(static_cast<size_t>(nTets));
  auto emitFace = [&](int64_t cellIndex, int face, int32_t apex2, const int32_t q[4], int32_t apex1) {
    // 4 tets (apex1, apex2, q[e], q[e+1]) into the slots of this cell and face.
    for (int e = 0; e < 4; ++e) {
      TetMesh::Tet t{apex1, apex2, q[e], q[(e + 1) % 4]};
      m.tets[static_cast<size_t>(cellIndex * 12 + face * 4 + e)] = t;
    }
  };
  // Each cell owns 3 faces (-x, -y, -z) plus the +x/+y/+z faces when they lie on the box.
  // Slots: 12 per cell = 3 owned faces x 4. Boundary faces on the + side are appended after.
  std::vector<TetMesh::Tet> extra;
  extra.reserve(static_cast<size_t>(4 * (ny * nz + nx * nz + nx * ny)));
  for (int64_t k = 0; k < nz; ++k) {
    progress.checkCancel(); // one slab of cells between checks
    for (int64_t j = 0; j < ny; ++j)
      for (int64_t i = 0; i < nx; ++i) {
        const int64_t c = i + nx * (j + ny * k);
        const int32_t d = dual(i, j, k);
        // -x face at x = i
        {
          const int32_t q[4] = {primal(i, j, k), primal(i, j + 1, k), primal(i, j + 1, k + 1), primal(i, j, k + 1)};
          emitFace(c, 0, i > 0 ? dual(i - 1, j, k) : faceCentre(0, j, k), q, d);
        }
        {
          const int32_t q[4] = {primal(i, j, k), primal(i + 1, j, k), primal(i + 1, j, k + 1), primal(i, j, k + 1)};
          emitFace(c, 1, j > 0 ? dual(i, j - 1, k) : faceCentre(2, i, k), q, d);
        }
        {
          const int32_t q[4] = {primal(i, j, k), primal(i + 1, j, k), primal(i + 1, j + 1, k), primal(i, j + 1, k)};
          emitFace(c, 2, k > 0 ? dual(i, j, k - 1) : faceCentre(4, i, j), q, d);
        }
        if (i == nx - 1) {
          const int32_t q[4] = {primal(i + 1, j, k), primal(i + 1, j + 1, k), primal(i + 1, j + 1, k + 1), primal(i + 1, j, k + 1)};
          for (int e = 0; e < 4; ++e) extra.push_back({d, faceCentre(1, j, k), q[e], q[(e + 1) % 4]});
        }
        if (j == ny - 1) {
          const int32_t q[4] = {primal(i, j + 1, k), primal(i + 1, j + 1, k), primal(i + 1, j + 1, k + 1), primal(i, j + 1, k + 1)};
          for (int e = 0; e < 4; ++e) extra.push_back({d, faceCentre(3, i, k), q[e], q[(e + 1) % 4]});
        }
        if (k == nz - 1) {
          const int32_t q[4] = {primal(i, j, k + 1), primal(i + 1, j, k + 1), primal(i + 1, j + 1, k + 1), primal(i, j + 1, k + 1)};
          for (int e = 0; e < 4; ++e) extra.push_back({d, faceCentre(5, i, j), q[e], q[(e + 1) % 4]});
        }
      }
  }
  m.tets.resize(static_cast<size_t>(12 * nDual));
  m.tets.insert(m.tets.end(), extra.begin(), extra.end());
  progress.checkCancel();
  // Orient positively (the grid's axes may flip handedness).
  const int64_t nt = static_cast<int64_t>(m.tets.size());
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < nt; ++t)
    if (m.tetVolume(static_cast<size_t>(t)) < 0) std::swap(m.tets[t][2], m.tets[t][3]);
  m.materials.assign(m.tets.size(), 0);
  bg.boxVolume = len[0] * len[1] * len[2];
  progress.endStage();
  return bg;
}

} // namespace tetflow
