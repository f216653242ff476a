#pragma once
// Three-component vectors for positions, directions and normals.

#include <cmath>

namespace skinspec::render {

struct Vec3 {
  double x = 0, y = 0, z = 0;

  constexpr Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  constexpr Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  constexpr Vec3 operator-() const { return {-x, -y, -z}; }
  constexpr Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  constexpr Vec3& operator+=(const Vec3& o) { return *this = *this + o; }
  constexpr double operator[](int axis) const { return axis == 0 ? x : axis == 1 ? y : z; }
};

constexpr double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(const Vec3& v) { return std::sqrt(dot(v, v)); }
// v scaled to length 1; the zero vector stays zero rather than becoming NaN.
inline Vec3 normalized(const Vec3& v) {
  const double n = length(v);
  return n > 0 ? v * (1.0 / n) : v;
}
inline Vec3 component_min(const Vec3& a, const Vec3& b) {
  return {std::fmin(a.x, b.x), std::fmin(a.y, b.y), std::fmin(a.z, b.z)};
}
inline Vec3 component_max(const Vec3& a, const Vec3& b) {
  return {std::fmax(a.x, b.x), std::fmax(a.y, b.y), std::fmax(a.z, b.z)};
}

struct Ray {
  Vec3 origin;
  Vec3 direction;  // unit length
};

}  // namespace skinspec::render
