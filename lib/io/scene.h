// scene.json, "svbrdf-scene/1" (shared/spec/dataset.md): reader with
// validation and writer. Paths inside are relative to the scene's folder.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "camera/camera.h"
#include "io/image.h"
#include "light/light.h"

namespace svbrdf {

struct ImageEntry {
  std::string file;    // relative path as written in scene.json
  int camera = 0;      // camera id
  int light = 0;       // light id
  Rigid3 cam_from_world;
  double exposure = 1.0;
  std::string mask;    // relative path; empty when absent
};

struct Scene {
  std::string dir;     // folder of scene.json (absolute or as given); paths resolve against it
  std::string mesh;    // relative path
  ColorSpace images_color_space = ColorSpace::kLinear;
  std::vector<Camera> cameras;
  std::vector<Light> lights;   // goniometric lights have their IES profile loaded
  std::vector<ImageEntry> images;
  nlohmann::json ground_truth; // null when absent
  // scene.json "mesh_normals": "given" (absent) or "unknown": the mesh's
  // normals are placeholders (a photometric capture without a scan), so the
  // reconstruction estimates them from the photos (lib/photometric).
  bool mesh_normals_known = true;

  const Camera& CameraById(int id) const;  // throws Error if unknown
  const Light& LightById(int id) const;    // throws Error if unknown
  std::string Resolve(const std::string& relative) const;  // dir + "/" + relative
};

// Reads and validates; every problem throws Error naming the file and the
// field (e.g. "scene.json: images[3].cam_from_world.q: expected 4 numbers").
Scene LoadScene(const std::string& path);
Scene ParseScene(const nlohmann::json& j, const std::string& dir, const std::string& context);
nlohmann::json SceneToJson(const Scene& scene);
// Writes scene.json atomically.
void SaveScene(const Scene& scene, const std::string& path);

// Writes text to `path` via a temporary file and rename (shared by all writers).
void WriteFileAtomic(const std::string& path, const std::string& contents);
// Parses a JSON file; throws Error naming the file and the parse position.
nlohmann::json ReadJsonFile(const std::string& path);

}  // namespace svbrdf
