// Normal maps for the material folder and their comparison with ground truth.
// material.json's "normal_map" holds unit normals, RGB = xyz, in world space
// or in the tangent space of the shading point ("normal_map_space",
// io/normal_map_space.h; docs/reference/formats.md); relight interpolates the
// map bilinearly and applies it at the shading point.
#pragma once
#include <vector>

#include "atlas/atlas.h"
#include "io/image.h"
#include "io/material.h"

namespace svbrdf {

// Per-texel world-space normals into a W x H x 3 map in `space` (tangent:
// in the frame of the texel centre, texel normal and tangent; zero outside
// the atlas: relight falls back to the mesh normal there).
Image NormalMapImage(const Atlas& atlas, const std::vector<Vec3>& normals, NormalMapSpace space);

// The world-space shading normal a material gives a texel centre: its normal
// map at the texel's uv (bilinear, in the texel's frame when tangent space,
// renormalised) if it has one, else the texel's mesh normal.
// `material` and `atlas` must share texture coordinates (same mesh UVs).
Vec3 MaterialNormal(const Material& material, const Texel& texel, const Atlas& atlas);

struct NormalErrors {
  std::vector<double> degrees;  // per texel of the atlas
  double mean_deg = 0, median_deg = 0;
  // Per true material (truth's material_id at the texel's uv, nearest):
  // mean and median angle; empty when the truth has no material_id map.
  std::vector<double> mean_by_material, median_by_material;
};

// Angle between `normals` (per texel of `atlas`) and the true shading normals
// of `truth` at the same uv.
NormalErrors CompareNormals(const Atlas& atlas, const std::vector<Vec3>& normals, const Material& truth);

}  // namespace svbrdf
