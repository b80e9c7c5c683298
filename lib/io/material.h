// material.json, "svbrdf-material/1": a folder with a mesh (with the UVs the
// maps use), basis materials (model + named parameters), one RGB weight map per
// basis material, an optional normal map (world or tangent space:
// io/normal_map_space.h), a confidence map and an optional material-id map.
// See docs/reference/formats.md ("material.json: a result").
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "brdf/model.h"
#include "io/image.h"
#include "io/mesh.h"
#include "io/normal_map_space.h"

namespace svbrdf {

struct BasisMaterial {
  std::string name;
  ModelSpec spec;
  std::vector<double> params;  // in spec.Params() order
};

// How renderers read the maps between texel centres. kNearest suits maps
// with one texel per photo pixel (photometric captures, lib/photometric):
// each texel holds that pixel's own fit, so a pixel-integrating render must
// not blend it with its neighbours'.
enum class TextureFilter { kBilinear, kNearest };

// Light transfer beyond the BRDF (lib/photometric/transfer.h): per texel,
// radiance E * sum_k c_k phi_k(d) for a distant light of irradiance E in
// world direction d = (x, y, z), with the first 4, 9 or 16 of
// phi = [1, x, y, z, x^2, y^2, xy, xz, yz, x^3, y^3, x^2 y, x y^2, x^2 z, y^2 z, xyz]
// (a polynomial of degree 1, 2 or 3; z^2 = 1 - x^2 - y^2 adds nothing).
constexpr int kLightTransferMaxTerms = 16;
inline bool ValidLightTransferTerms(int n) { return n == 4 || n == 9 || n == 16; }
inline void LightTransferTerms(const Vec3& d, double* phi) {
  const double x = d.x(), y = d.y(), z = d.z();
  const double v[kLightTransferMaxTerms] = {1,         x,         y,         z,         x * x,     y * y,
                                            x * y,     x * z,     y * z,     x * x * x, y * y * y, x * x * y,
                                            x * y * y, x * x * z, y * y * z, x * y * z};
  for (int k = 0; k < kLightTransferMaxTerms; ++k) phi[k] = v[k];
}

// Light-space samples of what the model leaves in a photometric capture's
// photos (lib/photometric/transfer.h FitResidualField): per training light,
// its world direction d_j and an RGB map r_j of residual radiance per unit
// irradiance, already scaled per texel by the share of it that carried over
// to neighbouring lights when each was left out. A distant light in world
// direction d adds E * sum_j w_j r_j over the kLightResidualNeighbours
// sample directions nearest to d, w_j proportional to 1 / angle(d, d_j)
// (the 3-nearest-light interpolation of image-based relighting, applied to
// the model's residuals instead of the photos).
constexpr int kLightResidualNeighbours = 3;
// Indices into `dirs` and weights (summing to 1) of the samples for unit
// direction d, nearest first; `exclude` (>= 0) is left out. Returns how many
// (min(kLightResidualNeighbours, usable samples)).
int LightResidualNeighbours(const std::vector<Vec3>& dirs, const Vec3& d, int exclude, int* index, double* weight);

struct Material {
  std::string dir;               // folder of material.json
  Mesh mesh;
  std::string mesh_file = "mesh.obj";
  int width = 0, height = 0;     // texture resolution of all maps
  std::vector<BasisMaterial> basis;
  std::vector<Image> weights;    // one 3-channel map per basis material (per-channel mixing weights)
  Image normal_map;              // 3 channels, unit normals in normal_map_space; empty (width 0) when absent
  NormalMapSpace normal_map_space = NormalMapSpace::kWorld;  // material.json "normal_map_space" (absent = world)
  Image confidence;              // 1 channel in [0,1]; empty when absent
  Image material_id;             // 1 channel, integer ids (basis index); empty when absent
  TextureFilter texture_filter = TextureFilter::kBilinear;  // material.json "texture_filter" (absent = bilinear)
  std::vector<Image> light_transfer;  // 4, 9 or 16 RGB maps (LightTransferTerms), or none (material.json "light_transfer")
  // Residual samples (LightResidualNeighbours), or none (material.json "light_residuals").
  std::vector<Vec3> light_residual_directions;  // world frame, unit
  std::vector<Image> light_residuals;           // one RGB map per direction
  nlohmann::json extra;          // free-form provenance (written as "info")
};

// Reads material.json and every map; validates names against the model's
// parameters and sizes against width/height; throws Error naming file and field.
Material LoadMaterial(const std::string& dir);
// Writes the folder: material.json, mesh, maps (EXR). Written into
// `dir`.tmp-XXXX first and renamed over `dir` when complete.
void SaveMaterial(const Material& material, const std::string& dir);

// Indirect bounces a material was fitted without (reconstruct removed that
// interreflection from its samples): material.json "info.interreflection.bounces";
// 0 when absent. Renders meant to match photos add them back.
int MaterialBounces(const Material& material);
void SetMaterialBounces(Material* material, int bounces);

nlohmann::json BasisToJson(const BasisMaterial& b);
BasisMaterial BasisFromJson(const nlohmann::json& j, const std::string& context);

}  // namespace svbrdf
