// Cook-Torrance / Torrance-Sparrow microfacet BRDF as in the lecture.
//
//   rd      diffuse albedo per channel                          [0, 1]
//   rs      specular scale per channel                          [0, 1]
//   m       roughness, see microfacet.h                         [0.01, 1]
//   n       index of refraction of the material (air outside)   [1.05, 3]
//   distribution  Beckmann | Blinn Gaussian | GGX  (p(H), microfacet.h)
//   shadowing     V-cavity min(1, Gm, Gs) | Smith G1(L) G1(E)
//   fresnel       exact dielectric | Schlick | none (F = 1)
//
//   f(L, E) = rd/pi + rs/pi * p(H) G(L, E) F(<H|E>) / (4 <N|L><N|E>)
//
// Reciprocal. Since p/pi is a normalised density and G, F <= 1, the specular
// albedo is <= rs, so rd + rs <= 1 conserves energy (brdf_test checks this
// numerically for every distribution and shadowing term).
#pragma once
#include "brdf/common.h"
#include "brdf/fresnel.h"
#include "brdf/microfacet.h"
#include "brdf/model.h"

namespace svbrdf::brdf {

template <class T> struct CookTorrance {
  RgbT<T> rd, rs;
  T m, n;
  Distribution distribution = Distribution::kBeckmann;
  Shadowing shadowing = Shadowing::kVCavity;
  FresnelMode fresnel = FresnelMode::kExact;

  T P(const T& cos_h) const { return MicrofacetP(distribution, cos_h, m); }
  T G1(const T& cos_t) const { return SmithG1(distribution, cos_t, m); }

  T G(const Vec3T<T>& wi, const Vec3T<T>& wo, const Vec3T<T>& h) const {
    return shadowing == Shadowing::kSmith ? G1(wi.z()) * G1(wo.z()) : VCavityG(wi, wo, h);
  }

  T F(const T& c) const {
    switch (fresnel) {
      case FresnelMode::kSchlick: return FresnelSchlick(c, n);
      case FresnelMode::kNone: return T(1);
      case FresnelMode::kExact:
      case FresnelMode::kF82Tint: break;  // F82 is a conductor form; not offered for Cook-Torrance
    }
    return FresnelDielectric(c, n);
  }

  RgbT<T> f(const Vec3T<T>& wi, const Vec3T<T>& wo) const {
    const Vec3T<T> h = HalfVector(wi, wo);
    const T spec = P(h.z()) * G(wi, wo, h) * F(Dot(h, wo)) / (T(4 * kPi) * wi.z() * wo.z());
    return rd * InvPi<T>() + rs * spec;
  }
};

}  // namespace svbrdf::brdf
