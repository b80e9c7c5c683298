// Per-texel SVBRDF lookup for rendering: the BRDF at a surface point is the
// per-channel weighted sum of the basis materials, with weights bilinearly
// interpolated from the material's weight maps at the hit's texture coordinate.
#pragma once
#include <cstdint>
#include <vector>

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
  // The delta (mirror) reflection that Eval leaves out: the share of the
  // radiance arriving from the mirror direction of wo_world that leaves
  // towards wo_world, per channel: sum_k w_k F_k(<N|wo>) over the basis
  // materials with a flat coat (`plastic`, F its dielectric Fresnel) or a
  // mirror (`mirror`, F Schlick's of its F0). Zero when there are none, or
  // wo_world is below the surface.
  Rgb Mirror(const Vec2& uv, const Frame& frame, const Vec3& wo_world) const;
  bool HasMirror() const { return !mirrors_.empty(); }

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
  // Basis materials with a delta reflection: their index and either the
  // coat's ior (`plastic`: dielectric Fresnel) or F0 (`mirror`: Schlick).
  struct MirrorPart {
    int k;
    bool coat;   // true: a flat coat of index `ior`; false: a mirror of reflectance `f0`
    double ior;
    Rgb f0;
  };
  std::vector<MirrorPart> mirrors_;
};

}  // namespace svbrdf
