// Lambert: ideal diffuse reflection, reciprocal and energy conserving.
//
//   rd   diffuse albedo per channel            [0, 1]
//
//   f(L, E) = rd / pi
#pragma once
#include "brdf/common.h"

namespace svbrdf::brdf {

template <class T> struct Lambert {
  RgbT<T> rd;

  RgbT<T> f(const Vec3T<T>& /*wi*/, const Vec3T<T>& /*wo*/) const { return rd * InvPi<T>(); }
};

}  // namespace svbrdf::brdf
