// The glTF 2.0 metallic-roughness BRDF (Khronos glTF 2.0 specification,
// appendix B), so that a material fitted with it exports to glTF unchanged
// (`reconstruct --for gltf`).
//
//   base       baseColor per channel                            [0, 1]
//   metallic   0 dielectric, 1 metal                            [0, 1]
//   roughness  perceptual roughness r; GGX alpha = r^2          [0.05, 1]
//
//   D    = alpha^2 / (pi ((N.H)^2 (alpha^2 - 1) + 1)^2)          GGX
//   Vis  = G1(L) G1(E) / (4 N.L N.E),  G1 Smith GGX (separable)
//   s    = (1 - |E.H|)^5,  Fd = 0.04 + 0.96 s                   dielectric Schlick Fresnel, ior 1.5
//   f    = (1 - metallic) [(1 - Fd) base/pi + Fd D Vis] + metallic D Vis (base + (1 - base) s)
//
// Reciprocal (E.H = L.H). Affine in base, so fits may start it linearly.
// Not exactly energy conserving (the spec's (1 - Fd) uses E.H, not the
// directional albedo), but below 1 for base <= 1 (white furnace in brdf_test).
#pragma once
#include "brdf/common.h"
#include "brdf/microfacet.h"

namespace svbrdf::brdf {

template <class T> struct GltfPbr {
  RgbT<T> base;
  T metallic;
  T roughness;

  RgbT<T> f(const Vec3T<T>& wi, const Vec3T<T>& wo) const {
    const Vec3T<T> h = HalfVector(wi, wo);
    const T alpha = Max(roughness * roughness, T(1e-4));
    const T dvis = SmithMicrofacet(Distribution::kGGX, wi, wo, h, alpha);
    const T k = T(1) - Dot(wo, h);
    const T s = k * k * k * k * k;
    const T fd = T(0.04) + T(0.96) * s;
    RgbT<T> out;
    for (int c = 0; c < 3; ++c)
      out[c] = (T(1) - metallic) * ((T(1) - fd) * base[c] * InvPi<T>() + fd * dvis) +
               metallic * dvis * (base[c] + (T(1) - base[c]) * s);
    return out;
  }
};

}  // namespace svbrdf::brdf
