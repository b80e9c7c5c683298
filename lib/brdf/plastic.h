// Smooth plastic (glazed ceramics, lacquer, polished plastics): a Lambertian
// base under a smooth, clear dielectric coat — the coated model of coated.h
// with a mirror-flat coat. Mitsuba 3's `plastic` (nonlinear = true).
//
//   rd    albedo of the diffuse base per channel   [0, 1]
//   n     index of refraction of the coat          [1.1, 2.5]
//
//   f(L, E) = rd (1 - F(<N|L>)) (1 - F(<N|E>)) / (pi n^2 (1 - rd F_int))
//           + F(<N|E>) delta(mirror)                 (not evaluated: see below)
//
// F is the exact dielectric Fresnel of index n. Light enters through the
// flat coat with transmittance 1 - F(<N|L>), is reflected diffusely by the
// base, and leaves with 1 - F(<N|E>); radiance leaving the dense medium is
// divided by n^2. Light reflected back at the coat's underside (fraction
// F_int, the internal diffuse reflectance, total internal reflection
// included: fresnel.h) returns to the base; the geometric series of these
// bounces gives 1 / (1 - rd F_int).
//
// The coat's reflection is a delta: under point and directional lights it
// reflects nothing towards the camera except at a single point, so f holds
// the base term only. A rough coat fitted to such a material runs to its
// smallest roughness and renders highlights that the photos never show;
// here there is none. What the mirror reflects of other surfaces (the
// object in itself: a share F, 4 % at normal incidence for n 1.5, of the
// light that reaches the surface from them) is rendered by the light paths
// (MaterialShader::Mirror), not by f.
//
// Reciprocal (symmetric in L and E); energy: the base's albedo is at most
// (1 - F_ext) rd / (n^2 (1 - rd F_int)) <= 1 - F(<N|L>) (brdf_test).
#pragma once
#include "brdf/common.h"
#include "brdf/fresnel.h"

namespace svbrdf::brdf {

template <class T> struct Plastic {
  RgbT<T> rd;
  T n;
  // F_int, set by Prepare() once the parameters are read (batched evaluation).
  T prepared_f_int = T(0);
  bool prepared = false;
  void Prepare() {
    prepared_f_int = DielectricInternalDiffuseReflectance(n);
    prepared = true;
  }

  RgbT<T> f(const Vec3T<T>& wi, const Vec3T<T>& wo) const {
    const T through = (T(1) - FresnelDielectric(wi.z(), n)) * (T(1) - FresnelDielectric(wo.z(), n)) / (T(kPi) * n * n);
    const T f_int = prepared ? prepared_f_int : DielectricInternalDiffuseReflectance(n);
    RgbT<T> v;
    for (int c = 0; c < 3; ++c) v[c] = rd[c] * through / (T(1) - rd[c] * f_int);
    return v;
  }
};

}  // namespace svbrdf::brdf
