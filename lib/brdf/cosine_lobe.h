// Lewis 1993 normalised cosine lobe: the Phong lobe without 1/<N|L> and with
// the factor (m+2)/(2pi) that makes its albedo at normal incidence exactly rs.
// Reciprocal; energy conserving for rd + rs <= 1.
//
//   rd   diffuse albedo per channel                       [0, 1]
//   rs   specular albedo per channel                      [0, 1]
//   m    specular exponent (sharpness)                    [0.5, 10000]
//
//   f(L, E) = rd/pi + rs (m+2)/(2pi) <R|E>^m,   R = 2<N|L>N - L,  <R|E> clamped at 0
#pragma once
#include "brdf/common.h"
#include "brdf/optics.h"

namespace svbrdf::brdf {

template <class T> struct CosineLobe {
  RgbT<T> rd, rs;
  T m;

  RgbT<T> f(const Vec3T<T>& wi, const Vec3T<T>& wo) const {
    const T lobe = (m + T(2)) * T(0.5 / kPi) * PowPos(Dot(ReflectLocal(wi), wo), m);
    return rd * InvPi<T>() + rs * lobe;
  }
};

}  // namespace svbrdf::brdf
