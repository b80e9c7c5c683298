// Per-texel SVBRDF lookup for rendering: the BRDF at a surface point is the
// per-channel weighted sum of the basis materials, with weights bilinearly
// interpolated from the material's weight maps at the hit's texture coordinate.
#pragma once
#include <cstdint>

#include "io/material.h"

namespace svbrdf {

class MaterialShader {
 public:
  explicit MaterialShader(const Material& material);

  // Per-channel mixing weights of every basis material at uv (K x 3, row-major into `w`).
  void Weights(const Vec2& uv, std::vector<Rgb>* w) const;
  // World-space shading normal at a point with mesh shading normal
  // `smooth_normal` on a face with dP/du `dpdu`: the normal map's (in its
  // space, io/normal_map_space.h) if present, else `smooth_normal`.
  Vec3 Normal(const Vec2& uv, const Vec3& smooth_normal, const Vec3& dpdu) const;
  // BRDF value (1/sr per channel) for world directions, given the shading frame.
  Rgb Eval(const Vec2& uv, const Frame& frame, const Vec3& wi_world, const Vec3& wo_world) const;

  // Light transfer beyond the BRDF (material.light_transfer, and the
  // interpolated material.light_residuals) for a distant light in world
  // direction `to_light`: radiance per unit irradiance; zero when the
  // material has neither.
  Rgb Transfer(const Vec2& uv, const Vec3& to_light) const;
  bool HasTransfer() const { return !material_.light_transfer.empty() || !material_.light_residuals.empty(); }

  const Material& material() const { return material_; }

 private:
  const Material& material_;
  // Distinct for every shader ever made: keys the per-thread cache of
  // residual neighbours (a material's address can be reused by the next).
  const uint64_t id_;
};

}  // namespace svbrdf
