// glTF 2.0 export of a material folder: the mesh with its UVs, normals (and
// tangents when there is a normal map) and a metallic-roughness PBR material
// whose textures are fitted per texel to the reconstructed SVBRDF.
//
// Written into the output folder:
//   model.gltf, model.bin            mesh (vertices split per position/UV pair;
//                                    glTF v = 1 - OBJ v), one material, one node
//   baseColor.png                    sRGB 8 bit
//   metallicRoughness.png            linear 8 bit, G = roughness, B = metallic
//   normal.png                       tangent-space normal map (only with a normal map)
//   fit_error.exr                    per-texel relative RMSE of the fit
//   export_report.json               fit error statistics, grid, warnings
//
// The fit: for each texel, the target is the material's BRDF there,
// f_c = sum_k w_k,c f_k,c, sampled on DirectionPairs (radiance under unit
// irradiance, solid-angle weighted). glTF's BRDF is affine in the base colour
// for fixed (metallic, roughness) (gltf_brdf.h), so for every point of a grid
// over metallic (21 values) x roughness (64 values) the best base colour is a
// clamped 1-D least-squares solution per channel and its error follows from
// precomputed inner products (no per-texel BRDF evaluations); the grid point
// of least error wins. The result is deterministic and independent of the
// thread count.
#pragma once
#include <nlohmann/json.hpp>
#include <string>

#include "io/material.h"

namespace svbrdf {

struct GltfExportOptions {
  int threads = 0;             // 0 = all cores
  int metallic_steps = 21;     // grid over metallic in [0, 1]
  int roughness_steps = 64;    // grid over roughness in [0.03, 1]
  void Check() const;
};

// Fitted glTF parameters of one texel; error is the relative RMSE.
struct GltfTexel {
  Rgb base_color = Rgb::Zero();
  double metallic = 0, roughness = 1, error = 0;
};

// Fits every texel of the material (texels with all weights zero get
// base colour 0, roughness 1). Returns width*height values, row-major.
std::vector<GltfTexel> FitGltfTexels(const Material& material, const GltfExportOptions& options);

// Writes the files above into `dir` (which must exist); returns the report.
nlohmann::json ExportGltf(const Material& material, const GltfExportOptions& options, const std::string& dir);

}  // namespace svbrdf
