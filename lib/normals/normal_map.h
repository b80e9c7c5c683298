// Normal maps for the material folder and their comparison with ground truth.
// material.json's "normal_map" holds world-space unit normals, RGB = xyz
// (README, material section); relight replaces the mesh's interpolated normal
// by the bilinearly interpolated, renormalised map value.
#pragma once
#include <vector>

#include "atlas/atlas.h"
#include "io/image.h"
#include "io/material.h"

namespace svbrdf {

// Per-texel world-space normals into a W x H x 3 map (zero outside the atlas:
// relight falls back to the mesh normal there).
Image NormalMapImage(const Atlas& atlas, const std::vector<Vec3>& normals);

// The shading normal a material gives a texel: its normal map at the texel's
// uv (bilinear, renormalised) if it has one, else the texel's mesh normal.
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
