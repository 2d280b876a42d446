// Triangle surfaces to .off, .stl and .vtp (see SurfaceIO.h).
#include "SurfaceIO.h"

#include <cstring>

#include "../Core/Errors.h"
#include "FileUtil.h"
#include "MeshFileText.h"

namespace tetflow {

using namespace mesh_io;

void writeTriangleSurface(const std::string& path, const std::vector<Vec3>& points,
                          const std::vector<std::array<int32_t, 3>>& triangles) {
  const std::string ext = fileExtension(path);
  if (ext != ".off" && ext != ".stl" && ext != ".vtp" && ext != ".surf")
    throw InputError(path + ": unknown surface file extension '" + ext + "'; supported: .off, .stl, .vtp, .surf");
  AtomicOutputFile out(path);
  {
    TextSink s(out.stream());
    if (ext == ".off") {
      s << "OFF\n";
      s.num(int64_t(points.size())) << ' ';
      s.num(int64_t(triangles.size())) << " 0\n";
      for (const Vec3& p : points) {
        s.real(p[0]) << ' ';
        s.real(p[1]) << ' ';
        s.real(p[2]) << '\n';
      }
      for (const auto& t : triangles) {
        s << "3 ";
        s.num(t[0]) << ' ';
        s.num(t[1]) << ' ';
        s.num(t[2]) << '\n';
      }
    } else if (ext == ".stl") {
      char header[80] = {};
      std::strncpy(header, "TetFlow ExtractSurfaces binary STL, mm", sizeof header - 1);
      s.bytes(header, sizeof header);
      const uint32_t n = uint32_t(triangles.size());
      s.bytes(&n, 4);
      for (const auto& t : triangles) {
        const Vec3 &a = points[size_t(t[0])], &b = points[size_t(t[1])], &c = points[size_t(t[2])];
        Vec3 nrm = cross(b - a, c - a);
        const double len = norm(nrm);
        if (len > 0) nrm = (1.0 / len) * nrm;
        float rec[12];
        for (int k = 0; k < 3; ++k) {
          rec[k] = float(nrm[k]);
          rec[3 + k] = float(a[k]);
          rec[6 + k] = float(b[k]);
          rec[9 + k] = float(c[k]);
        }
        const uint16_t attributes = 0;
        s.bytes(rec, sizeof rec);
        s.bytes(&attributes, 2);
      }
    } else if (ext == ".surf") {
      // FreeSurfer triangle surface: magic FF FF FE, a creator line and an empty line, then
      // big-endian int32 counts, float32 x y z per vertex, int32 corners per triangle.
      const unsigned char magic[3] = {0xFF, 0xFF, 0xFE};
      s.bytes(magic, 3);
      s << "created by TetFlow ExtractSurfaces\n\n";
      auto big32 = [&](uint32_t v) {
        const unsigned char b[4] = {static_cast<unsigned char>(v >> 24), static_cast<unsigned char>(v >> 16),
                                    static_cast<unsigned char>(v >> 8), static_cast<unsigned char>(v)};
        s.bytes(b, 4);
      };
      big32(uint32_t(points.size()));
      big32(uint32_t(triangles.size()));
      for (const Vec3& p : points)
        for (int k = 0; k < 3; ++k) {
          const float f = float(p[k]);
          uint32_t u = 0;
          std::memcpy(&u, &f, 4);
          big32(u);
        }
      for (const auto& t : triangles)
        for (int k = 0; k < 3; ++k) big32(uint32_t(t[size_t(k)]));
    } else {
      s << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\">\n"
           "  <PolyData>\n    <Piece NumberOfPoints=\"";
      s.num(int64_t(points.size())) << "\" NumberOfPolys=\"";
      s.num(int64_t(triangles.size())) << "\">\n      <Points>\n"
                                          "        <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n";
      for (const Vec3& p : points) {
        s.real(p[0]) << ' ';
        s.real(p[1]) << ' ';
        s.real(p[2]) << '\n';
      }
      s << "        </DataArray>\n      </Points>\n      <Polys>\n"
           "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
      for (const auto& t : triangles) {
        s.num(t[0]) << ' ';
        s.num(t[1]) << ' ';
        s.num(t[2]) << '\n';
      }
      s << "        </DataArray>\n        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
      for (size_t i = 1; i <= triangles.size(); ++i) s.num(int64_t(3 * i)) << '\n';
      s << "        </DataArray>\n      </Polys>\n    </Piece>\n  </PolyData>\n</VTKFile>\n";
    }
  }
  out.commit();
}

} // namespace tetflow
