// The glTF 2.0 metallic-roughness BRDF (brdf/gltf_pbr.h, the Khronos glTF 2.0
// specification's appendix B) as the export's per-texel fit uses it: affine
// in the base colour, f = b A(m, r) + C(m, r) per channel.
#pragma once
#include "brdf/gltf_pbr.h"
#include "core/types.h"

namespace svbrdf {

struct GltfAffine {
  double a = 0, c = 0;
};

inline GltfAffine GltfBrdfAffine(double metallic, double roughness, const Vec3& wi, const Vec3& wo) {
  if (wi.z() <= 0 || wo.z() <= 0) return {};
  brdf::GltfPbr<double> m{brdf::RgbT<double>(0, 1, 0), metallic, roughness};
  const brdf::RgbT<double> f = m.f(wi, wo);  // channel 0: base 0, channel 1: base 1
  return {f[1] - f[0], f[0]};
}

inline Rgb GltfBrdf(const Rgb& base_color, double metallic, double roughness, const Vec3& wi, const Vec3& wo) {
  const GltfAffine f = GltfBrdfAffine(metallic, roughness, wi, wo);
  return base_color * f.a + f.c;
}

}  // namespace svbrdf
