// Lafortune et al. 1997 generalised cosine lobes: <R|E>^m = (L^T (2NN^T - I) E)^m
// with the Householder matrix replaced by a general symmetric matrix M,
// diagonal in the shading frame. Symmetry of M keeps the model reciprocal;
// energy conservation depends on the coefficients and is not guaranteed.
//
//   rd          diffuse albedo per channel                          [0, 1]
//   per lobe i (1..3):
//   rho_i       lobe albedo/scale per channel                       [0, 100]
//   Cx_i, Cy_i  tangential coefficients; Cx = Cy (isotropic) unless
//               anisotropic. Negative: forward (specular) lobe,
//               positive: retro-reflection                          [-1.5, 1.5]
//   Cz_i        normal coefficient; positive for reflection lobes   [-1.5, 1.5]
//   n_i         lobe exponent (sharpness)                           [0.5, 1000]
//
//   f(L, E) = rd/pi + sum_i rho_i max(0, Cx Ex Lx + Cy Ey Ly + Cz Ez Lz)^n_i
//
// The base is clamped at 0 because a negative number to a real power is
// undefined. The lobe's peak is rho |C|^n, so |C| <= 1.5 and n <= 1000 keep it
// finite in double (1.5^1000 ~ 1e176).
// -Cx = -Cy = Cz = ((m+2)/(2pi))^(1/m) with rho = rs gives the Lewis cosine lobe.
#pragma once
#include "brdf/common.h"

namespace svbrdf::brdf {

template <class T> struct LafortuneLobe {
  RgbT<T> rho;
  T cx, cy, cz, n;

  T Lobe(const Vec3T<T>& wi, const Vec3T<T>& wo) const {
    return PowPos(cx * wi.x() * wo.x() + cy * wi.y() * wo.y() + cz * wi.z() * wo.z(), n);
  }
};

template <class T> struct Lafortune {
  static constexpr int kMaxLobes = 3;
  RgbT<T> rd;
  int num_lobes = 1;
  LafortuneLobe<T> lobes[kMaxLobes];

  RgbT<T> f(const Vec3T<T>& wi, const Vec3T<T>& wo) const {
    RgbT<T> sum = rd * InvPi<T>();
    for (int i = 0; i < num_lobes; ++i) sum += lobes[i].rho * lobes[i].Lobe(wi, wo);
    return sum;
  }
};

}  // namespace svbrdf::brdf
