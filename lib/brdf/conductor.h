// Rough conductor (metal): microfacet reflection with a coloured Fresnel
// term and no diffuse part (metals absorb what they do not reflect).
//
//   eta, kappa  complex index of refraction eta + i kappa per channel   eta [0.02, 6], kappa [0, 10]
//               (fresnel = exact; metals.h lists published values)
//   f0          reflectance at normal incidence per channel              [0, 1]
//               (fresnel = schlick or f82: cheaper, and linear in f0 for fits)
//   f82_tint    reflectance near 82 deg relative to Schlick's (f82 only) [0, 1]
//   m           roughness: Beckmann RMS slope or GGX alpha               [0.01, 1]
//   distribution  Beckmann | GGX; shadowing is always Smith (microfacet.h)
//
//   f(L, E) = D(H) G1(L) G1(E) F(<H|E>) / (4 <N|L><N|E>),  D = p(H)/pi
//
// Reciprocal (H and <H|E> = <H|L> are symmetric). F <= 1 and the Smith
// microfacet lobe reflects at most all light (white furnace in brdf_test), so
// the albedo is <= 1. The exact form gives F0 = ((eta-1)^2 + kappa^2) /
// ((eta+1)^2 + kappa^2) (ConductorF0) and F -> 1 at grazing incidence.
#pragma once
#include "brdf/common.h"
#include "brdf/fresnel.h"
#include "brdf/microfacet.h"
#include "brdf/model.h"

namespace svbrdf::brdf {

template <class T> struct Conductor {
  RgbT<T> eta, kappa;    // exact Fresnel
  RgbT<T> f0, f82_tint;  // Schlick / F82-tint Fresnel
  T m;
  Distribution distribution = Distribution::kGGX;
  FresnelMode fresnel = FresnelMode::kExact;

  T F(const T& c, int ch) const {
    switch (fresnel) {
      case FresnelMode::kSchlick: return FresnelSchlickF0(c, f0[ch]);
      case FresnelMode::kF82Tint: return FresnelF82Tint(c, f0[ch], f82_tint[ch]);
      case FresnelMode::kNone: return T(1);
      case FresnelMode::kExact: break;
    }
    return FresnelConductor(c, eta[ch], kappa[ch]);
  }

  RgbT<T> f(const Vec3T<T>& wi, const Vec3T<T>& wo) const {
    const Vec3T<T> h = HalfVector(wi, wo);
    const T lobe = SmithMicrofacet(distribution, wi, wo, h, m);
    const T c = Dot(h, wo);
    return RgbT<T>(lobe * F(c, 0), lobe * F(c, 1), lobe * F(c, 2));
  }
};

}  // namespace svbrdf::brdf
