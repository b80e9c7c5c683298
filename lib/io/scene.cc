#include "io/scene.h"

#include <filesystem>
#include <map>

#include "core/error.h"
#include "io/json_field.h"

namespace svbrdf {
namespace {

using nlohmann::json;
constexpr const char* kSceneFormat = "svbrdf-scene/1";

// Fails unless `v` > 0 (or >= 0 when `allow_zero`), naming the field.
double Positive(const JsonField& f, const std::string& key, bool allow_zero = false) {
  const double v = f.Get<double>(key);
  if (allow_zero ? v < 0 : v <= 0)
    f.FailAt(key, Msg("expected ", allow_zero ? "non-negative" : "positive", " number, got ", v));
  return v;
}

int PositiveInt(const JsonField& f, const std::string& key) {
  const int v = f.Get<int>(key);
  if (v <= 0) f.FailAt(key, Msg("expected positive integer, got ", v));
  return v;
}

Rgb NonNegativeRgb(const JsonField& f, const std::string& key) {
  const Rgb v = f.Get<Rgb>(key);
  if ((v < 0).any()) f.FailAt(key, "expected array of 3 non-negative numbers");
  return v;
}

Vec3 UnitVector(const JsonField& f, const std::string& key) {
  const Vec3 v = f.Get<Vec3>(key);
  if (!(v.norm() > 1e-12)) f.FailAt(key, "expected non-zero array of 3 numbers (a direction)");
  return v.normalized();
}

Camera ParseCamera(const JsonField& f) {
  f.AllowOnly({"id", "model", "width", "height", "params"});
  Camera c;
  c.id = f.Get<int>("id");
  c.model = CameraModelFromName(f.Get<std::string>("model"), f.WhereAt("model"));
  c.width = PositiveInt(f, "width");
  c.height = PositiveInt(f, "height");
  // Beyond any sensor; a corrupt size must not allocate gigabytes per image.
  if (c.width > 65536) f.FailAt("width", Msg("expected at most 65536 pixels, got ", c.width));
  if (c.height > 65536) f.FailAt("height", Msg("expected at most 65536 pixels, got ", c.height));
  if (long(c.width) * c.height > (1L << 27))
    f.FailAt("height", Msg(c.width, "x", c.height, " is more than 134 megapixels"));
  c.params = f.Get<std::vector<double>>("params");
  const int n = CameraModelNumParams(c.model);
  if (static_cast<int>(c.params.size()) != n)
    f.FailAt("params", Msg("expected array of ", n, " numbers for ", CameraModelName(c.model), ", got ",
                                      c.params.size()));
  if (!(c.fx() > 0 && c.fy() > 0)) f.FailAt("params", "focal length must be positive");
  return c;
}

Light ParseLight(const JsonField& f, const std::string& dir) {
  Light l;
  l.id = f.Get<int>("id");
  const std::string type = f.Get<std::string>("type");
  const std::string frame = f.GetOr<std::string>("frame", "world");
  if (frame != "world" && frame != "camera")
    f.FailAt("frame", Msg("expected \"world\" or \"camera\", got \"", frame, "\""));
  l.camera_frame = frame == "camera";
  if (type == "point") {
    f.AllowOnly({"id", "type", "frame", "position", "intensity"});
    l.type = LightType::kPoint;
    l.position = f.Get<Vec3>("position");
    l.intensity = NonNegativeRgb(f, "intensity");
  } else if (type == "directional") {
    f.AllowOnly({"id", "type", "frame", "to_light", "irradiance"});
    l.type = LightType::kDirectional;
    l.to_light = UnitVector(f, "to_light");
    l.irradiance = NonNegativeRgb(f, "irradiance");
  } else if (type == "spot") {
    f.AllowOnly({"id", "type", "frame", "position", "direction", "intensity", "exponent", "cutoff_deg"});
    l.type = LightType::kSpot;
    l.position = f.Get<Vec3>("position");
    l.direction = UnitVector(f, "direction");
    l.intensity = NonNegativeRgb(f, "intensity");
    l.exponent = Positive(f, "exponent", /*allow_zero=*/true);
    l.cutoff_deg = Positive(f, "cutoff_deg");
    if (l.cutoff_deg > 180) f.FailAt("cutoff_deg", Msg("expected angle in (0, 180], got ", l.cutoff_deg));
  } else if (type == "goniometric") {
    f.AllowOnly({"id", "type", "frame", "position", "direction", "up", "ies", "scale"});
    l.type = LightType::kGoniometric;
    l.position = f.Get<Vec3>("position");
    l.direction = UnitVector(f, "direction");
    l.up = UnitVector(f, "up");
    if (l.up.cross(l.direction).norm() < 1e-6) f.FailAt("up", "must not be parallel to direction");
    l.scale = f.Has("scale") ? Positive(f, "scale", /*allow_zero=*/true) : 1.0;
    l.ies = f.Get<std::string>("ies");
    const std::string ies_path = (std::filesystem::path(dir) / l.ies).string();
    try {
      l.profile = std::make_shared<IesProfile>(LoadIes(ies_path));
    } catch (const Error& e) {
      f.FailAt("ies", e.what());
    }
  } else {
    f.FailAt("type", 
        Msg("unknown light type \"", type, "\" (expected point, directional, spot or goniometric)"));
  }
  return l;
}

ImageEntry ParseImage(const JsonField& f) {
  f.AllowOnly({"file", "camera", "light", "cam_from_world", "exposure", "mask"});
  ImageEntry im;
  im.file = f.Get<std::string>("file");
  im.camera = f.Get<int>("camera");
  im.light = f.Get<int>("light");
  const JsonField pose = f.Member("cam_from_world", "object {\"q\": [w, x, y, z], \"t\": [x, y, z]}");
  pose.AllowOnly({"q", "t"});
  const Eigen::Vector4d q = pose.Get<Eigen::Vector4d>("q");
  if (!(q.norm() > 1e-12)) pose.FailAt("q", "expected non-zero quaternion [w, x, y, z]");
  im.cam_from_world.rotation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
  im.cam_from_world.translation = pose.Get<Vec3>("t");
  im.exposure = f.Has("exposure") ? Positive(f, "exposure") : 1.0;
  im.mask = f.GetOr<std::string>("mask", "");
  return im;
}

// Ids must be unique within cameras and within lights.
template <class T>
void CheckUniqueIds(const std::vector<T>& items, const std::vector<JsonField>& fields) {
  std::map<int, size_t> seen;
  for (size_t i = 0; i < items.size(); ++i)
    if (!seen.emplace(items[i].id, i).second)
      fields[i].FailAt("id", Msg("duplicate id ", items[i].id, " (also used by entry ", seen[items[i].id], ")"));
}

template <class T>
bool HasId(const std::vector<T>& items, int id) {
  for (const T& x : items)
    if (x.id == id) return true;
  return false;
}

json LightToJson(const Light& l) {
  json j = {{"id", l.id}};
  auto vec = [](const auto& v) { return std::vector<double>(v.data(), v.data() + 3); };
  switch (l.type) {
    case LightType::kPoint:
      j["type"] = "point";
      j["position"] = vec(l.position);
      j["intensity"] = vec(l.intensity);
      break;
    case LightType::kDirectional:
      j["type"] = "directional";
      j["to_light"] = vec(l.to_light);
      j["irradiance"] = vec(l.irradiance);
      break;
    case LightType::kSpot:
      j["type"] = "spot";
      j["position"] = vec(l.position);
      j["direction"] = vec(l.direction);
      j["intensity"] = vec(l.intensity);
      j["exponent"] = l.exponent;
      j["cutoff_deg"] = l.cutoff_deg;
      break;
    case LightType::kGoniometric:
      j["type"] = "goniometric";
      j["position"] = vec(l.position);
      j["direction"] = vec(l.direction);
      j["up"] = vec(l.up);
      j["ies"] = l.ies;
      j["scale"] = l.scale;
      break;
  }
  if (l.camera_frame) j["frame"] = "camera";
  return j;
}

}  // namespace

const Camera& Scene::CameraById(int id) const {
  for (const Camera& c : cameras)
    if (c.id == id) return c;
  throw Error(Msg(Resolve("scene.json"), ": no camera with id ", id));
}

const Light& Scene::LightById(int id) const {
  for (const Light& l : lights)
    if (l.id == id) return l;
  throw Error(Msg(Resolve("scene.json"), ": no light with id ", id));
}

std::string Scene::Resolve(const std::string& relative) const {
  return dir.empty() ? relative : (std::filesystem::path(dir) / relative).string();
}

Scene ParseScene(const json& j, const std::string& dir, const std::string& context) {
  const JsonField root(j, context);
  root.AllowOnly({"format", "mesh", "mesh_normals", "images_color_space", "cameras", "lights", "images", "ground_truth"});
  const std::string format = root.Get<std::string>("format");
  if (format != kSceneFormat)
    root.FailAt("format", Msg("expected \"", kSceneFormat, "\", got \"", format, "\""));
  Scene s;
  s.dir = dir;
  s.mesh = root.Get<std::string>("mesh");
  if (!std::filesystem::is_regular_file(s.Resolve(s.mesh)))
    root.FailAt("mesh", Msg("mesh file not found: ", s.Resolve(s.mesh)));
  const std::string space = root.GetOr<std::string>("images_color_space", "linear");
  if (space != "linear" && space != "srgb")
    root.FailAt("images_color_space", Msg("expected \"linear\" or \"srgb\", got \"", space, "\""));
  s.images_color_space = space == "srgb" ? ColorSpace::kSRGB : ColorSpace::kLinear;
  const std::string normals = root.GetOr<std::string>("mesh_normals", "given");
  if (normals != "given" && normals != "unknown")
    root.FailAt("mesh_normals", Msg("expected \"given\" or \"unknown\", got \"", normals, "\""));
  s.mesh_normals_known = normals == "given";

  const std::vector<JsonField> cameras = root.Items("cameras"), lights = root.Items("lights");
  for (const JsonField& f : cameras) s.cameras.push_back(ParseCamera(f));
  for (const JsonField& f : lights) s.lights.push_back(ParseLight(f, dir));
  CheckUniqueIds(s.cameras, cameras);
  CheckUniqueIds(s.lights, lights);
  for (const JsonField& f : root.Items("images")) {
    s.images.push_back(ParseImage(f));
    if (!HasId(s.cameras, s.images.back().camera))
      f.FailAt("camera", Msg("no camera with id ", s.images.back().camera));
    if (!HasId(s.lights, s.images.back().light))
      f.FailAt("light", Msg("no light with id ", s.images.back().light));
  }
  if (root.Has("ground_truth")) s.ground_truth = j["ground_truth"];
  return s;
}

Scene LoadScene(const std::string& path) {
  const std::string dir = std::filesystem::path(path).parent_path().string();
  return ParseScene(ReadJsonFile(path), dir.empty() ? "." : dir, path);
}

json SceneToJson(const Scene& s) {
  json j = {{"format", kSceneFormat},
            {"mesh", s.mesh},
            {"images_color_space", s.images_color_space == ColorSpace::kSRGB ? "srgb" : "linear"}};
  if (!s.mesh_normals_known) j["mesh_normals"] = "unknown";
  j["cameras"] = json::array();
  for (const Camera& c : s.cameras)
    j["cameras"].push_back(
        {{"id", c.id}, {"model", CameraModelName(c.model)}, {"width", c.width}, {"height", c.height}, {"params", c.params}});
  j["lights"] = json::array();
  for (const Light& l : s.lights) j["lights"].push_back(LightToJson(l));
  j["images"] = json::array();
  for (const ImageEntry& im : s.images) {
    const Eigen::Quaterniond& q = im.cam_from_world.rotation;
    const Vec3& t = im.cam_from_world.translation;
    json e = {{"file", im.file},
              {"camera", im.camera},
              {"light", im.light},
              {"cam_from_world", {{"q", {q.w(), q.x(), q.y(), q.z()}}, {"t", {t.x(), t.y(), t.z()}}}},
              {"exposure", im.exposure}};
    if (!im.mask.empty()) e["mask"] = im.mask;
    j["images"].push_back(e);
  }
  if (!s.ground_truth.is_null()) j["ground_truth"] = s.ground_truth;
  return j;
}

void SaveScene(const Scene& scene, const std::string& path) { WriteFileAtomic(path, SceneToJson(scene).dump(2) + "\n"); }

}  // namespace svbrdf
