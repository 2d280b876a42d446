#pragma once
// Small fixed-size geometry helpers (double precision, physical units = mm unless stated).
#include <array>
#include <cmath>

namespace tetflow {

// A point (or vector) in a 2-D plane, e.g. a surface patch's parameters (u, v) = (x, y).
struct Point2 {
  double x = 0, y = 0;
};

using Vec3 = std::array<double, 3>;
using Mat3 = std::array<std::array<double, 3>, 3>; // row-major: m[row][col]

inline Vec3 operator+(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
inline Vec3 operator-(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline Vec3 operator*(double s, const Vec3& a) { return {s * a[0], s * a[1], s * a[2]}; }
inline double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }

inline Mat3 identity3() { return {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}}; }
inline Vec3 mul(const Mat3& m, const Vec3& v) {
  return {dot(m[0], v), dot(m[1], v), dot(m[2], v)};
}
inline double det(const Mat3& m) { return dot(m[0], cross(m[1], m[2])); }

// Signed volume of tet (a,b,c,d): positive when d lies on the side of triangle (a,b,c) that its
// counter-clockwise normal (b-a)x(c-a) points to. TetFlow tets are stored with positive volume.
inline double signedTetVolume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return dot(cross(b - a, c - a), d - a) / 6.0;
}

} // namespace tetflow
