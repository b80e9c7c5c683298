// Oren-Nayar 1994, qualitative model as in the lecture: V-cavities with
// Lambertian facets and Gaussian slope distribution of standard deviation sigma.
// Reciprocal; sigma = 0 gives Lambert.
//
// Energy: this qualitative form does not quite conserve energy. At grazing
// incidence its albedo tends to rd (A + B/2) (sin(alpha) -> 1, and
// int max(0, cos dphi) tan(theta_r) cos(theta_r) dw / pi = 1/2), which peaks
// at 1.0152 rd for sigma ~ 0.2; rd <= 0.985 keeps the albedo <= 1.
//
//   rd      diffuse albedo per channel                          [0, 1]
//   sigma   standard deviation of facet angles, radians         [0, 1]
//
//   f(L, E) = rd/pi (A + B max(0, cos(phi_i - phi_r)) sin(alpha) tan(beta))
//   A = 1 - 0.5 sigma^2/(sigma^2 + 0.33),  B = 0.45 sigma^2/(sigma^2 + 0.09),
//   alpha = max(theta_i, theta_r),  beta = min(theta_i, theta_r)
#pragma once
#include "brdf/common.h"

namespace svbrdf::brdf {

template <class T> struct OrenNayar {
  RgbT<T> rd;
  T sigma;

  RgbT<T> f(const Vec3T<T>& wi, const Vec3T<T>& wo) const {
    const T s2 = sigma * sigma;
    const T a = T(1) - T(0.5) * s2 / (s2 + T(0.33));
    const T b = T(0.45) * s2 / (s2 + T(0.09));
    const T sin_i = SafeSqrt(T(1) - wi.z() * wi.z());
    const T sin_o = SafeSqrt(T(1) - wo.z() * wo.z());
    // cos(phi_i - phi_r) from the tangential components; when either is
    // normal the azimuth is undefined but then sin(alpha) tan(beta) = 0.
    const T sin_prod = sin_i * sin_o;
    const T cos_dphi = sin_prod > T(0) ? (wi.x() * wo.x() + wi.y() * wo.y()) / sin_prod : T(0);
    // The larger angle has the smaller cosine.
    const bool i_larger = wi.z() < wo.z();
    const T sin_alpha = i_larger ? sin_i : sin_o;
    const T tan_beta = i_larger ? sin_o / wo.z() : sin_i / wi.z();
    return rd * (InvPi<T>() * (a + b * Max(T(0), cos_dphi) * sin_alpha * tan_beta));
  }
};

}  // namespace svbrdf::brdf
