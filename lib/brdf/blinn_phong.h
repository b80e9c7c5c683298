// Blinn-Phong 1978, in the lecture's BRDF form: Phong with the half vector
// instead of the mirror direction.
//
//   rd   diffuse albedo per channel                       [0, 1]
//   rs   specular coefficient per channel                 [0, 1]
//   m    specular exponent (sharpness)                    [0.5, 10000]
//
//   f(L, E) = rd/pi + rs <H|N>^m / <N|L>,   H = (L + E) / |L + E|
//
// Neither reciprocal (the 1/<N|L> factor) nor energy conserving (unbounded
// as <N|L> -> 0).
#pragma once
#include "brdf/common.h"

namespace svbrdf::brdf {

template <class T> struct BlinnPhong {
  RgbT<T> rd, rs;
  T m;

  RgbT<T> f(const Vec3T<T>& wi, const Vec3T<T>& wo) const {
    const T lobe = PowPos(HalfVector(wi, wo).z(), m) / wi.z();
    return rd * InvPi<T>() + rs * lobe;
  }
};

}  // namespace svbrdf::brdf
