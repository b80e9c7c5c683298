// Coated dielectric (varnished wood, glazed ceramics, plastics): a
// Lambertian base under a rough, clear dielectric coat — the lecture's
// layered materials (primer / pigment layer / clear coat) with one layer.
//
//   rd    albedo of the diffuse base per channel                 [0, 1]
//   m     roughness of the coat: Beckmann RMS slope or GGX alpha [0.01, 1]
//   n     index of refraction of the coat (air outside)          [1.1, 2.5]
//   distribution  Beckmann | GGX, Smith shadowing
//
//   f(L, E) = D(H) G1(L) G1(E) F(<H|E>) / (4 <N|L><N|E>)                      coat reflection
//           + rd (1 - F(<N|L>)) (1 - F(<N|E>)) / (pi n^2 (1 - rd F_int(n)))    base, seen through the coat
//
// The second term follows light refracted into the coat (transmittance
// 1 - F(<N|L>)), reflected diffusely by the base, and escaping with
// transmittance 1 - F(<N|E>); radiance leaving the dense medium is divided by
// n^2. Light reflected back at the coat's underside (fraction F_int(n), the
// internal diffuse Fresnel reflectance, fresnel.h) returns to the base, and
// the geometric series of these bounces gives 1 / (1 - rd F_int). With a
// white base the diffuse albedo is then exactly 1 - F(<N|L>): everything
// that enters the coat comes out.
//
// Approximation (stated, measured): the transmittances use the smooth-coat
// Fresnel F at the macroscopic angle, whereas a rough coat transmits
// 1 - (its microfacet reflection's albedo). The two differ by less than
// 2e-3 of the incident energy for roughness <= 1 and n in [1.1, 2.5]
// (numerical integration), so the albedo is <= 1 + 2e-3 (brdf_test).
// Reciprocal: both terms are symmetric in L and E. No absorption in the coat,
// no scattering between coat facets.
#pragma once
#include "brdf/common.h"
#include "brdf/fresnel.h"
#include "brdf/microfacet.h"
#include "brdf/model.h"

namespace svbrdf::brdf {

template <class T> struct Coated {
  RgbT<T> rd;
  T m, n;
  Distribution distribution = Distribution::kGGX;
  // F_int(n), set by Prepare() once the parameters are read (batched
  // evaluation: it depends on n only and costs as much as the rest of f).
  T f_int_prepared = T(0);
  bool prepared = false;
  void Prepare() {
    f_int_prepared = DielectricInternalDiffuseReflectance(n);
    prepared = true;
  }

  RgbT<T> f(const Vec3T<T>& wi, const Vec3T<T>& wo) const {
    const Vec3T<T> h = HalfVector(wi, wo);
    const T coat = SmithMicrofacet(distribution, wi, wo, h, m) * FresnelDielectric(Dot(h, wo), n);
    const T through = (T(1) - FresnelDielectric(wi.z(), n)) * (T(1) - FresnelDielectric(wo.z(), n)) /
                      (T(kPi) * n * n);
    const T f_int = prepared ? f_int_prepared : DielectricInternalDiffuseReflectance(n);
    RgbT<T> v;
    for (int c = 0; c < 3; ++c) v[c] = coat + rd[c] * through / (T(1) - rd[c] * f_int);
    return v;
  }
};

}  // namespace svbrdf::brdf
