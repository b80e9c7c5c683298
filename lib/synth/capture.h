// Synthetic captures with exact ground truth (shared/spec/dataset.md):
// a procedural object, a painted ground-truth SVBRDF (gt/), cameras on a
// sphere, one light per image, images rendered by lib/relight, then camera
// effects (noise, exposure, clipping, quantisation) and, for stability
// studies, errors written into scene.json (pose, light position, geometry)
// while the images are rendered with the true values.
#pragma once
#include <nlohmann/json.hpp>
#include <string>

#include "synth/ground_truth.h"

namespace svbrdf {

struct SynthOptions {
  std::string object = "sphere";  // sphere | torus | blob | cube
  std::string mesh_file;          // a mesh file (OBJ/PLY, e.g. a scan) instead of `object`
  bool mesh_uvs = true;           // false: the capture's mesh.obj has no texture coordinates
  int detail = 96;                // mesh segments around
  GroundTruthOptions material;
  int num_images = 16;
  int num_heldout = 4;            // extra views + lights for evaluation (heldout/scene.json)
  int width = 320, height = 240;
  double focal_factor = 1.2;      // focal length in units of the image width
  double distance = 2.2;          // camera distance from the object's centre (m)
  std::string lights = "mixed";   // flash | point | spot | goniometric | mixed
  double light_intensity = 10.0;  // W/sr (point, spot, goniometric peak)
  double flash_intensity = 6.0;   // W/sr
  double exposure = 1.0;
  std::string format = "exr";     // exr | png16 | png8 | jpg
  double noise = 0.0;             // shot noise: sigma = noise * sqrt(value) (value 1 = white)
  double read_noise = 0.0;        // additive Gaussian sigma
  double pose_error_deg = 0.0, pose_error_mm = 0.0;  // errors written into cam_from_world
  double light_error_mm = 0.0;    // error written into light positions
  double geometry_noise_mm = 0.0; // noise along normals written into mesh.obj
  int spp = 2;                    // supersampling (n x n per pixel)
  uint64_t seed = 1;
  int threads = 0;

  void Check() const;
  static SynthOptions FromJson(const nlohmann::json& j, const std::string& context);
  nlohmann::json ToJson() const;
};

// Named definitions in datasets_synth/*.json, compiled into the binary.
SynthOptions SynthPreset(const std::string& name);
std::vector<std::string> SynthPresetNames();

struct SynthReport {
  double seconds = 0;
  int images = 0;
  double saturated_fraction = 0;  // of object pixels
};

// Writes out_dir/{scene.json, mesh.obj, images/, masks/, lights/, gt/, heldout/}.
// Everything is written into a temporary sibling folder and renamed at the end.
SynthReport Synthesize(const SynthOptions& options, const std::string& out_dir);

}  // namespace svbrdf
