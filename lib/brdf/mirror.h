// Smooth conductor (polished metal, a mirror): all of its reflection is a
// delta in the mirror direction, so its BRDF part is zero.
//
//   f0    reflectance at normal incidence per channel   [0, 1]
//
//   f(L, E) = 0
//   mirror reflectance R(<N|E>) = F0 + (1 - F0)(1 - <N|E>)^5   (Schlick 1994, per channel)
//
// Under point and directional lights a mirror sends the light to the camera
// at single points only: the photos show it reflecting the object itself,
// so it is not fitted like the other models (its f predicts nothing) but by
// the reconstruction's mirror stage, against the radiance its mirror
// direction sees (pipeline/mirror_stage.h); `relight --bounces N` renders
// it through MaterialShader::Mirror. Reciprocal and energy conserving
// trivially (f = 0; R <= 1).
#pragma once
#include "brdf/common.h"

namespace svbrdf::brdf {

template <class T> struct Mirror {
  RgbT<T> f0;

  RgbT<T> f(const Vec3T<T>& /*wi*/, const Vec3T<T>& /*wo*/) const { return f0 * T(0); }
};

}  // namespace svbrdf::brdf
