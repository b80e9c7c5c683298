// material.json, "svbrdf-material/1": a folder with a mesh (with the UVs the
// maps use), basis materials (model + named parameters), one RGB weight map per
// basis material, an optional normal map (world or tangent space:
// io/normal_map_space.h), a confidence map and an optional material-id map.
// See README "Material folder".
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
  nlohmann::json extra;          // free-form provenance (written as "info")
};

// Reads material.json and every map; validates names against the model's
// parameters and sizes against width/height; throws Error naming file and field.
Material LoadMaterial(const std::string& dir);
// Writes the folder: material.json, mesh, maps (EXR). Written into
// `dir`.tmp-XXXX first and renamed over `dir` when complete.
void SaveMaterial(const Material& material, const std::string& dir);

nlohmann::json BasisToJson(const BasisMaterial& b);
BasisMaterial BasisFromJson(const nlohmann::json& j, const std::string& context);

}  // namespace svbrdf
