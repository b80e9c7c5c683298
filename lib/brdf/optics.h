// Geometric optics at a smooth interface: ideal mirror reflection and Snell
// refraction. Directions point away from the surface (L towards the light),
// N is the unit normal on the side of L.
#pragma once
#include "brdf/common.h"

namespace svbrdf::brdf {

// R(L) = 2<N|L>N - L = (2NN^T - I) L, the Householder reflection of L about
// the normal. N must be unit length for R to keep the length of L.
template <class T> Vec3T<T> Reflect(const Vec3T<T>& l, const Vec3T<T>& n) { return T(2) * Dot(n, l) * n - l; }

// Mirror direction in the local shading frame (N = z): R = (-Lx, -Ly, Lz).
template <class T> Vec3T<T> ReflectLocal(const Vec3T<T>& l) { return Vec3T<T>(-l.x(), -l.y(), l.z()); }

// Snell: n_i sin(theta_i) = n_t sin(theta_t). Writes the refracted direction
// (pointing into the far medium, away from N) and returns true, or returns
// false on total internal reflection (n_i > n_t beyond the critical angle
// sin(theta_T) = n_t / n_i).
template <class T>
bool Refract(const Vec3T<T>& l, const Vec3T<T>& n, const T& n_i, const T& n_t, Vec3T<T>* t) {
  using std::sqrt;
  const T eta = n_i / n_t;
  const T cos_i = Dot(n, l);
  const T cos_t2 = T(1) - eta * eta * (T(1) - cos_i * cos_i);
  if (cos_t2 < T(0)) return false;
  *t = -eta * l + (eta * cos_i - sqrt(cos_t2)) * n;
  return true;
}

}  // namespace svbrdf::brdf
