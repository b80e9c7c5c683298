// Phong 1975, in the lecture's BRDF form.
//
//   rd   diffuse albedo per channel                       [0, 1]
//   rs   specular coefficient per channel                 [0, 1]
//   m    specular exponent (sharpness)                    [0.5, 10000]
//
//   f(L, E) = rd/pi + rs <R|E>^m / <N|L>,   R = 2<N|L>N - L,  <R|E> clamped at 0
//
// Neither reciprocal (dividing by <N|L> breaks the L <-> E symmetry) nor
// energy conserving (<N|L> -> 0 at grazing incidence makes the albedo
// unbounded); kept because it is the classic baseline. See CosineLobe.
#pragma once
#include "brdf/common.h"
#include "brdf/optics.h"

namespace svbrdf::brdf {

template <class T> struct Phong {
  RgbT<T> rd, rs;
  T m;

  RgbT<T> f(const Vec3T<T>& wi, const Vec3T<T>& wo) const {
    const T lobe = PowPos(Dot(ReflectLocal(wi), wo), m) / wi.z();
    return rd * InvPi<T>() + rs * lobe;
  }
};

}  // namespace svbrdf::brdf
