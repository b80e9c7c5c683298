// The glTF 2.0 metallic-roughness BRDF (Khronos glTF 2.0 specification,
// appendix B), in the local frame (z = normal), per colour channel:
//
//   baseColor  b  per channel                                   [0, 1]
//   metallic   m                                                [0, 1]
//   roughness  r  perceptual; alpha = r^2                       [0, 1]
//
//   D   = alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2)          GGX
//   Vis = G1(wi) G1(wo) / (4 n.wi n.wo),  G1 = 2 n.w / (n.w + sqrt(alpha^2 + (1 - alpha^2)(n.w)^2))
//   s   = (1 - |wo.h|)^5,  Fd = 0.04 + 0.96 s                   (dielectric Fresnel, ior 1.5)
//   f   = (1 - m) [(1 - Fd) b/pi + Fd D Vis] + m D Vis (b + (1 - b) s)
//
// which is affine in b:  f = b A(m, r) + C(m, r)  with
//   A = (1 - m)(1 - Fd)/pi + m D Vis (1 - s),   C = D Vis ((1 - m) Fd + m s).
#pragma once
#include <cmath>

#include "core/types.h"

namespace svbrdf {

struct GltfAffine {
  double a = 0, c = 0;
};

inline GltfAffine GltfBrdfAffine(double metallic, double roughness, const Vec3& wi, const Vec3& wo) {
  if (wi.z() <= 0 || wo.z() <= 0) return {};
  const double alpha = std::max(roughness * roughness, 1e-6), a2 = alpha * alpha;
  const Vec3 h = (wi + wo).normalized();
  const double nh = h.z();
  const double d_den = nh * nh * (a2 - 1) + 1;
  const double d = a2 / (kPi * d_den * d_den);
  auto g1 = [&](double c) { return 2 * c / (c + std::sqrt(a2 + (1 - a2) * c * c)); };
  const double vis = g1(wi.z()) * g1(wo.z()) / (4 * wi.z() * wo.z());
  const double k = 1 - std::abs(wo.dot(h));
  const double s = k * k * k * k * k;
  const double fd = 0.04 + 0.96 * s;
  GltfAffine out;
  out.a = (1 - metallic) * (1 - fd) / kPi + metallic * d * vis * (1 - s);
  out.c = d * vis * ((1 - metallic) * fd + metallic * s);
  return out;
}

inline Rgb GltfBrdf(const Rgb& base_color, double metallic, double roughness, const Vec3& wi, const Vec3& wo) {
  const GltfAffine f = GltfBrdfAffine(metallic, roughness, wi, wo);
  return base_color * f.a + f.c;
}

}  // namespace svbrdf
