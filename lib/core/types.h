// Basic math types shared by every module. Directions are unit Eigen vectors;
// colours are linear RGB Eigen arrays.
#pragma once
#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace svbrdf {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Vec3i = Eigen::Vector3i;
using Vec3f = Eigen::Vector3f;
using Mat3 = Eigen::Matrix3d;
using Rgb = Eigen::Array3d;
template <class T> using Vec3T = Eigen::Matrix<T, 3, 1>;

constexpr double kPi = 3.14159265358979323846;

// Orthonormal shading frame: z is the normal. Tangent is chosen by the caller
// (UV-aligned for anisotropic materials) or made up from the normal.
struct Frame {
  Vec3 t, b, n;
  static Frame FromNormal(const Vec3& n);                 // deterministic tangent
  static Frame FromNormalTangent(const Vec3& n, const Vec3& t);  // Gram-Schmidt; falls back to FromNormal
  Vec3 ToLocal(const Vec3& w) const { return Vec3(w.dot(t), w.dot(b), w.dot(n)); }
  Vec3 ToWorld(const Vec3& w) const { return w.x() * t + w.y() * b + w.z() * n; }
};

// The median (the upper one of an even count); 0 for no values.
inline double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// A cosine-weighted direction of the upper hemisphere (z up, pdf cos / pi)
// from two uniform numbers in [0, 1): Malley's method, u1 for the radius of
// the disc point, u2 for its angle.
inline Vec3 CosineHemisphere(double u1, double u2) {
  const double r = std::sqrt(u1), phi = 2 * kPi * u2;
  return Vec3(r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1 - u1)));
}

}  // namespace svbrdf
