// Coated dielectric (varnished wood, glazed ceramics, plastics): a
// Lambertian base under a rough, clear dielectric coat — the lecture's
// layered materials (primer / pigment layer / clear coat) with one layer.
//
//   rd    albedo of the diffuse base per channel                 [0, 1]
//   m     roughness of the coat: Beckmann RMS slope or GGX alpha [0.01, 1]
//   n     index of refraction of the coat (air outside)          [1.1, 2.5]
//   distribution  Beckmann | GGX, Smith shadowing
//
//   f(L, E) = D(H) G1(L) G1(E) F(<H|E>) / (4 <N|L><N|E>)                 coat reflection
//           + rd t(<N|L>) t(<N|E>) / (pi n^2 (1 - rd F_int))             base, seen through the coat
//
// The second term follows light through the rough coat (transmittance
// t(mu; m, n), rough_coat.h: the microfacet transmission integrated over
// the refracted directions), reflected diffusely by the base, and escaping
// with transmittance t(<N|E>); radiance leaving the dense medium is divided
// by n^2. Light reflected back at the coat's underside (fraction F_int, the
// rough coat's internal diffuse reflectance, total internal reflection
// included) returns to the base, and the geometric series of these bounces
// gives 1 / (1 - rd F_int). This is Mitsuba 3's `roughplastic` with
// `nonlinear = true` (the same t and F_int, interpolated from tables).
//
// Why rough and not the smooth-coat 1 - F(<N|L>): a rough coat transmits
// more at grazing angles (facets tilted towards the light): at Beckmann
// m 0.31, n 1.37 the smooth form's base falls 2.3x faster towards 85
// degrees (docs/measurements.md, "Rough plastic against the coated model").
// Energy: with a white base the albedo is the coat's reflection plus
// t(<N|L>) times the share of the base's light that escapes, <= 1 up to the
// tables' interpolation (brdf_test). Reciprocal: both terms are symmetric
// in L and E. No absorption in the coat, no scattering between coat facets.
#pragma once
#include "brdf/common.h"
#include "brdf/fresnel.h"
#include "brdf/microfacet.h"
#include "brdf/model.h"
#include "brdf/rough_coat.h"

namespace svbrdf::brdf {

template <class T> struct Coated {
  RgbT<T> rd;
  T m, n;
  Distribution distribution = Distribution::kGGX;
  // The coat's t(mu) and F_int, set by Prepare() once the parameters are
  // read (batched evaluation: they depend on m and n only).
  RoughCoat<T> prepared_coat;
  bool prepared = false;
  void Prepare() {
    prepared_coat = RoughCoat<T>(distribution, m, n);
    prepared = true;
  }

  RgbT<T> f(const Vec3T<T>& wi, const Vec3T<T>& wo) const {
    const Vec3T<T> h = HalfVector(wi, wo);
    const T coat = SmithMicrofacet(distribution, wi, wo, h, m) * FresnelDielectric(Dot(h, wo), n);
    const RoughCoat<T> layer = prepared ? prepared_coat : RoughCoat<T>(distribution, m, n);
    const T through = layer.Transmittance(wi.z()) * layer.Transmittance(wo.z()) / (T(kPi) * n * n);
    RgbT<T> v;
    for (int c = 0; c < 3; ++c) v[c] = coat + rd[c] * through / (T(1) - rd[c] * layer.f_int);
    return v;
  }
};

}  // namespace svbrdf::brdf
