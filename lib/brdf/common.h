// Small scalar helpers shared by the model headers. Everything is templated
// on the scalar T so that ceres::Jet flows through; math functions are called
// unqualified after `using std::f` so that argument-dependent lookup picks the
// Jet overloads without lib/brdf depending on Ceres.
//
// Jet safety: sqrt'(0) and pow'(0, n) are infinite, and Jet multiplies them
// by a zero derivative vector, giving NaN even for constant inputs. The
// helpers below therefore never evaluate sqrt or pow at 0.
#pragma once
#include <cmath>

#include <Eigen/Core>

#include "core/types.h"

namespace svbrdf::brdf {

template <class T> using RgbT = Eigen::Array<T, 3, 1>;

template <class T> T Dot(const Vec3T<T>& a, const Vec3T<T>& b) {
  return a.x() * b.x() + a.y() * b.y() + a.z() * b.z();
}

// Branching on the value picks the derivative of the active branch, which is
// the correct one almost everywhere.
template <class T> T Max(const T& a, const T& b) { return a < b ? b : a; }
template <class T> T Min(const T& a, const T& b) { return b < a ? b : a; }

// sqrt(max(x, 0)) with a zero (not NaN) derivative at and below 0.
template <class T> T SafeSqrt(const T& x) {
  using std::sqrt;
  return x > T(0) ? sqrt(x) : T(0);
}

// max(x, 0)^n for n > 0: the lobe bases of Phong and Lafortune are clamped
// at 0, and pow is only evaluated for a positive base.
template <class T> T PowPos(const T& x, const T& n) {
  using std::pow;
  return x > T(0) ? pow(x, n) : T(0);
}

template <class T> Vec3T<T> Normalized(const Vec3T<T>& v) {
  using std::sqrt;
  return v / sqrt(Dot(v, v));
}

// Half vector H = (L + E) / |L + E|; well defined whenever both directions
// are above the horizon, which the models assume.
template <class T> Vec3T<T> HalfVector(const Vec3T<T>& wi, const Vec3T<T>& wo) { return Normalized<T>(wi + wo); }

template <class T> T InvPi() { return T(1.0 / kPi); }

}  // namespace svbrdf::brdf
