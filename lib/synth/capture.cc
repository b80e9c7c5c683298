#include "synth/capture.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <random>
#include <set>
#include <unistd.h>

#include "core/error.h"
#include "core/rng.h"
#include "io/output_folder.h"
#include "relight/relight.h"
#include "synth/shapes.h"

namespace svbrdf {

namespace fs = std::filesystem;

void SynthOptions::Check() const {
  material.Check();
  const std::set<std::string> objects{"sphere", "torus", "blob", "cube"};
  const std::set<std::string> light_modes{"flash", "point", "spot", "goniometric", "mixed"};
  const std::set<std::string> formats{"exr", "png16", "png8", "jpg"};
  if (!objects.count(object)) throw Error(Msg("synth: object '", object, "' unknown; expected sphere, torus, blob or cube"));
  if (!light_modes.count(lights)) throw Error(Msg("synth: lights '", lights, "' unknown; expected flash, point, spot, goniometric or mixed"));
  if (!formats.count(format)) throw Error(Msg("synth: format '", format, "' unknown; expected exr, png16, png8 or jpg"));
  if (num_images < 1) throw Error("synth: num_images must be >= 1");
  if (num_heldout < 0) throw Error("synth: num_heldout must be >= 0");
  if (width < 8 || height < 8 || width > 16384 || height > 16384) throw Error("synth: width/height must be in [8, 16384]");
  if (!(focal_factor > 0) || !(distance > 0) || !(exposure > 0)) throw Error("synth: focal_factor, distance and exposure must be > 0");
  if (noise < 0 || read_noise < 0 || pose_error_deg < 0 || pose_error_mm < 0 || light_error_mm < 0 || geometry_noise_mm < 0)
    throw Error("synth: noise and error magnitudes must be >= 0");
  if (spp < 1 || spp > 16) throw Error("synth: spp must be in [1, 16]");
  if (bounces < 0 || bounces > 64) throw Error("synth: bounces must be in [0, 64]");
  if (bounce_samples < 1 || bounce_samples > 1024) throw Error("synth: bounce_samples must be in [1, 1024]");
  if (detail < 8) throw Error("synth: detail must be >= 8");
}

namespace {

// Reads optional fields of a JSON object into a struct; unknown keys are errors
// so that a typo in a preset never silently falls back to a default.
class FieldReader {
 public:
  FieldReader(const nlohmann::json& j, std::string context) : j_(j), context_(std::move(context)) {
    if (!j.is_object()) throw Error(Msg(context_, ": expected a JSON object"));
  }
  template <class T>
  FieldReader& operator()(const char* key, T* value) {
    seen_.insert(key);
    if (!j_.contains(key)) return *this;
    try {
      *value = j_.at(key).get<T>();
    } catch (const std::exception& e) {
      throw Error(Msg(context_, ": field '", key, "': ", e.what()));
    }
    return *this;
  }
  void RejectUnknown() const {
    for (auto it = j_.begin(); it != j_.end(); ++it)
      if (!seen_.count(it.key())) throw Error(Msg(context_, ": unknown field '", it.key(), "'"));
  }

 private:
  const nlohmann::json& j_;
  std::string context_;
  std::set<std::string> seen_;
};

#include "synth_presets.inc"  // kPresets: {name, json text} from datasets_synth/*.json

nlohmann::json MaterialParamsJson(const std::vector<MaterialParams>& params) {
  nlohmann::json out = nlohmann::json::array();
  for (const MaterialParams& p : params) {
    nlohmann::json j = nlohmann::json::object();
    if (!p.metal.empty()) j["metal"] = p.metal;
    for (const auto& [name, value] : p.values) j[name] = value;
    out.push_back(j);
  }
  return out;
}

}  // namespace

SynthOptions SynthOptions::FromJson(const nlohmann::json& j, const std::string& context) {
  SynthOptions o;
  std::string description;  // free text, documentation only
  FieldReader r(j, context);
  nlohmann::json material = nlohmann::json::object();
  r("object", &o.object)("detail", &o.detail)("num_images", &o.num_images)("num_heldout", &o.num_heldout)(
      "width", &o.width)("height", &o.height)("focal_factor", &o.focal_factor)("distance", &o.distance)(
      "lights", &o.lights)("light_intensity", &o.light_intensity)("flash_intensity", &o.flash_intensity)(
      "exposure", &o.exposure)("format", &o.format)("noise", &o.noise)("read_noise", &o.read_noise)(
      "pose_error_deg", &o.pose_error_deg)("pose_error_mm", &o.pose_error_mm)("light_error_mm", &o.light_error_mm)(
      "geometry_noise_mm", &o.geometry_noise_mm)("spp", &o.spp)("seed", &o.seed)("threads", &o.threads)(
      "material", &material)("description", &description)("mesh_file", &o.mesh_file)("mesh_uvs", &o.mesh_uvs)(
      "bounces", &o.bounces)("bounce_samples", &o.bounce_samples);
  r.RejectUnknown();
  FieldReader m(material, context + ": material");
  nlohmann::json params = nlohmann::json::array();
  m("num_materials", &o.material.num_materials)("models", &o.material.models)(
      "texture_size", &o.material.texture_size)("blend", &o.material.blend)("variation", &o.material.variation)(
      "bump", &o.material.bump)("seed", &o.material.seed)("params", &params);
  m.RejectUnknown();
  // "params": one object per material, {"metal": "gold", "<param>": value, ...}.
  if (!params.is_array()) throw Error(Msg(context, ": material: field 'params': expected an array of objects"));
  for (size_t k = 0; k < params.size(); ++k) {
    const std::string where = Msg(context, ": material: params[", k, "]");
    if (!params[k].is_object()) throw Error(Msg(where, ": expected an object of parameter values"));
    MaterialParams mp;
    for (const auto& [key, value] : params[k].items()) {
      if (key == "metal") {
        if (!value.is_string()) throw Error(Msg(where, ": field 'metal': expected a string"));
        mp.metal = value.get<std::string>();
      } else {
        if (!value.is_number()) throw Error(Msg(where, ": field '", key, "': expected a number"));
        mp.values[key] = value.get<double>();
      }
    }
    o.material.params.push_back(mp);
  }
  o.Check();
  return o;
}

nlohmann::json SynthOptions::ToJson() const {
  return {{"object", object}, {"detail", detail}, {"num_images", num_images}, {"num_heldout", num_heldout},
          {"width", width}, {"height", height}, {"focal_factor", focal_factor}, {"distance", distance},
          {"lights", lights}, {"light_intensity", light_intensity}, {"flash_intensity", flash_intensity},
          {"exposure", exposure}, {"format", format}, {"noise", noise}, {"read_noise", read_noise},
          {"pose_error_deg", pose_error_deg}, {"pose_error_mm", pose_error_mm}, {"light_error_mm", light_error_mm},
          {"geometry_noise_mm", geometry_noise_mm}, {"spp", spp}, {"seed", seed},
          {"mesh_file", mesh_file}, {"mesh_uvs", mesh_uvs}, {"bounces", bounces}, {"bounce_samples", bounce_samples},
          {"material",
           {{"num_materials", material.num_materials}, {"models", material.models},
            {"texture_size", material.texture_size}, {"blend", material.blend}, {"variation", material.variation},
            {"bump", material.bump}, {"seed", material.seed}, {"params", MaterialParamsJson(material.params)}}}};
}

std::vector<std::string> SynthPresetNames() {
  std::vector<std::string> names;
  for (const auto& p : kPresets) names.push_back(p.name);
  return names;
}

SynthOptions SynthPreset(const std::string& name) {
  std::string valid;
  for (const auto& p : kPresets) {
    if (name == p.name) {
      nlohmann::json j;
      try {
        j = nlohmann::json::parse(p.text);
      } catch (const std::exception& e) {
        throw Error(Msg("datasets_synth/", name, ".json: ", e.what()));
      }
      return SynthOptions::FromJson(j, Msg("datasets_synth/", name, ".json"));
    }
    valid += std::string(valid.empty() ? "" : ", ") + p.name;
  }
  throw Error(Msg("unknown synthetic capture '", name, "'; known: ", valid));
}

namespace {

// A small rotationally symmetric LM-63 table: a wide beam with a soft edge.
constexpr const char* kLampIes =
    "IESNA:LM-63-2002\n[TEST] svbrdf synthetic lamp\n[MANUFAC] svbrdf\nTILT=NONE\n"
    "1 1000 1 10 1 1 2 0 0 0\n1 1 10\n"
    "0 10 20 30 40 50 60 70 80 90\n0\n"
    "1000 990 950 880 780 640 470 300 140 40\n";

Vec3 RandomUnit(Rng& rng) {
  std::normal_distribution<double> g;
  Vec3 v(g(rng), g(rng), g(rng));
  return v.normalized();
}

// Camera direction i of n: a Fibonacci spiral over elevations -40..70 degrees
// (a turntable with cameras above and below), so every side is seen.
Vec3 CameraDirection(int i, int n, double offset) {
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  const double s = (i + 0.5) / n;
  const double elev = (-40.0 + 110.0 * s) * kPi / 180.0;
  const double az = golden * i + offset;
  return Vec3(std::cos(elev) * std::cos(az), std::sin(elev), std::cos(elev) * std::sin(az));
}

// Builds images and their lights for `count` views starting at `first`.
void AddViews(const SynthOptions& o, int first, int count, Rng& rng, bool heldout, Scene* scene) {
  Camera cam;
  cam.id = 1;
  cam.model = CameraModelId::kPinhole;
  cam.width = o.width;
  cam.height = o.height;
  const double f = o.focal_factor * o.width;
  cam.params = {f, f, o.width / 2.0, o.height / 2.0};
  scene->cameras = {cam};
  std::uniform_real_distribution<double> u01(0, 1);
  const double offset = heldout ? 0.37 : 0.0;
  const int light_modes = 4;
  for (int k = 0; k < count; ++k) {
    const int i = first + k;
    const Vec3 dir = CameraDirection(k, count, offset);
    ImageEntry e;
    char name[32];
    std::snprintf(name, sizeof name, "%04d", k);
    const std::string ext = o.format == "exr" ? ".exr" : o.format == "jpg" ? ".jpg" : ".png";
    e.file = Msg("images/", name, ext);
    e.mask = Msg("masks/", name, ".png");
    e.camera = 1;
    e.exposure = o.exposure;
    e.cam_from_world = Rigid3::LookAt(o.distance * dir, Vec3::Zero(), Vec3::UnitY());

    std::string mode = o.lights;
    if (mode == "mixed") {
      static const char* kModes[light_modes] = {"flash", "point", "spot", "goniometric"};
      mode = heldout ? "point" : kModes[i % light_modes];
    }
    Light light;
    light.id = static_cast<int>(scene->lights.size()) + 1;
    if (mode == "flash") {
      light.type = LightType::kPoint;
      light.camera_frame = true;
      light.position = Vec3(0.06, -0.04, 0.0);
      light.intensity = Rgb::Constant(o.flash_intensity);
    } else {
      // Light from a direction near the camera's, so the visible side is lit
      // and highlights appear, at 1.1x the camera distance.
      Vec3 ldir = (dir + 0.9 * RandomUnit(rng)).normalized();
      light.position = 1.1 * o.distance * ldir;
      light.intensity = Rgb::Constant(o.light_intensity);
      light.direction = (-light.position).normalized();
      if (mode == "point") {
        light.type = LightType::kPoint;
      } else if (mode == "spot") {
        light.type = LightType::kSpot;
        light.exponent = 4.0;
        light.cutoff_deg = 30.0;
      } else {
        light.type = LightType::kGoniometric;
        light.ies = heldout ? "../lights/lamp.ies" : "lights/lamp.ies";
        light.profile = std::make_shared<IesProfile>(ParseIes(kLampIes, "built-in lamp"));
        light.scale = o.light_intensity / 1000.0;
        const Vec3 up = std::abs(light.direction.y()) < 0.9 ? Vec3::UnitY() : Vec3::UnitX();
        light.up = (up - light.direction * light.direction.dot(up)).normalized();
      }
    }
    e.light = light.id;
    scene->lights.push_back(light);
    scene->images.push_back(e);
  }
}

// Applies the recorded-but-wrong values of a stability study to a copy of the scene.
Scene Perturb(const Scene& truth, const SynthOptions& o, Rng& rng) {
  Scene s = truth;
  std::normal_distribution<double> g;
  for (ImageEntry& e : s.images) {
    if (o.pose_error_deg > 0) {
      const Eigen::AngleAxisd err(o.pose_error_deg * kPi / 180.0, RandomUnit(rng));
      e.cam_from_world.rotation = Eigen::Quaterniond(err) * e.cam_from_world.rotation;
    }
    if (o.pose_error_mm > 0) e.cam_from_world.translation += RandomUnit(rng) * o.pose_error_mm * 1e-3;
  }
  if (o.light_error_mm > 0)
    for (Light& l : s.lights)
      if (l.type != LightType::kDirectional) l.position += RandomUnit(rng) * o.light_error_mm * 1e-3;
  return s;
}

void ApplySensor(const SynthOptions& o, uint64_t stream, Image* img) {
  Rng rng(StreamSeed(o.seed, 0x5e75, stream));
  std::normal_distribution<double> g;
  const bool integer = o.format != "exr";
  for (float& v : img->pixels) {
    double x = v;
    if (o.noise > 0 || o.read_noise > 0)
      x += g(rng) * std::sqrt(o.noise * o.noise * std::max(0.0, x) + o.read_noise * o.read_noise);
    if (integer) x = std::min(1.0, std::max(0.0, x));  // the sensor clips at white
    v = static_cast<float>(std::max(0.0, x));
  }
}

void WriteCaptureImages(const SynthOptions& o, const Material& gt, const Scene& truth, const std::string& dir,
                        uint64_t stream, double* saturated, long* object_pixels) {
  RayTracer tracer(gt.mesh);
  MaterialShader shader(gt);
  RelightOptions ro;
  ro.samples_per_pixel = o.spp;
  ro.threads = o.threads;
  ro.seed = o.seed;
  ro.bounces = o.bounces;
  ro.bounce_samples = o.bounce_samples;
  for (size_t i = 0; i < truth.images.size(); ++i) {
    RenderedView v = RenderView(tracer, shader, truth, i, ro);
    ApplySensor(o, stream * 100000 + i, &v.color);
    const ImageEntry& e = truth.images[i];
    fs::create_directories(fs::path(dir) / fs::path(e.file).parent_path());
    fs::create_directories(fs::path(dir) / fs::path(e.mask).parent_path());
    const ColorSpace space = (o.format == "png8" || o.format == "jpg") ? ColorSpace::kSRGB : ColorSpace::kLinear;
    const PixelFormat format = o.format == "exr"     ? PixelFormat::kHalf
                               : o.format == "png16" ? PixelFormat::kUInt16
                                                     : PixelFormat::kUInt8;
    WriteImage((fs::path(dir) / e.file).string(), v.color, format, space);
    WriteImage((fs::path(dir) / e.mask).string(), v.mask, PixelFormat::kUInt8, ColorSpace::kLinear);
    if (o.format != "exr") {
      Image sat = v.color;
      sat.saturation_level = 1.0f;
      const long n = std::count_if(v.mask.pixels.begin(), v.mask.pixels.end(), [](float m) { return m > 0; });
      *saturated += SaturatedFraction(sat, &v.mask) * n;
      *object_pixels += n;
    }
  }
}

}  // namespace

SynthReport Synthesize(const SynthOptions& o, const std::string& out_dir) {
  o.Check();
  const auto t0 = std::chrono::steady_clock::now();
  OutputFolder out(out_dir);
  const fs::path tmp = out.path();
  fs::create_directories(tmp / "lights");

  Mesh mesh = o.mesh_file.empty() ? MakeShape(o.object, o.detail) : LoadShapeFromFile(o.mesh_file, o.material.texture_size);
  GroundTruthOptions gto = o.material;
  gto.seed = StreamSeed(o.seed, 1, o.material.seed);
  gto.cover_small_triangles = !o.mesh_file.empty();
  Material gt = MakeGroundTruth(mesh, gto);
  SaveMaterial(gt, (tmp / "gt").string());
    WriteFileAtomic((tmp / "lights" / "lamp.ies").string(), kLampIes);

  Rng rng(StreamSeed(o.seed, 2));
  Scene truth;
  truth.dir = tmp.string();
  truth.mesh = "mesh.obj";
  truth.images_color_space = (o.format == "png8" || o.format == "jpg") ? ColorSpace::kSRGB : ColorSpace::kLinear;
  AddViews(o, 0, o.num_images, rng, false, &truth);

  SynthReport report;
  long object_pixels = 0;
  double saturated = 0;
  WriteCaptureImages(o, gt, truth, tmp.string(), 0, &saturated, &object_pixels);

  // What the capture records: possibly wrong poses, lights and geometry.
  Scene recorded = Perturb(truth, o, rng);
  Mesh recorded_mesh = mesh;
  if (o.geometry_noise_mm > 0) {
    std::normal_distribution<double> g;
    for (size_t v = 0; v < recorded_mesh.positions.size(); ++v)
      recorded_mesh.positions[v] += recorded_mesh.normals[v] * g(rng) * o.geometry_noise_mm * 1e-3;
    recorded_mesh.ComputeNormals(NormalWeighting::kArea);  // as the shapes (shapes.h)
  }
  if (!o.mesh_uvs) recorded_mesh.texcoords.clear(), recorded_mesh.face_uvs.clear();  // as a scan comes
  // With vn: the normals the photos were shaded with (a reader would compute angle-weighted ones).
  SaveObj(recorded_mesh, (tmp / "mesh.obj").string(), /*write_normals=*/true);
  recorded.ground_truth = {{"material", "gt"},
                           {"material_id", "gt/material_id.png"},
                           {"heldout_scene", o.num_heldout > 0 ? "heldout/scene.json" : ""},
                           {"synth_options", o.ToJson()}};
  SaveScene(recorded, (tmp / "scene.json").string());

  if (o.num_heldout > 0) {
    // Held-out views and lights, never given to the reconstruction: the true
    // poses and mesh, no sensor noise, linear EXR.
    SynthOptions ho = o;
    ho.format = "exr";
    ho.noise = ho.read_noise = 0;
    Scene held;
    held.dir = (tmp / "heldout").string();
    held.mesh = "../gt/mesh.obj";
    Rng hrng(StreamSeed(o.seed, 3));
    AddViews(ho, o.num_images, o.num_heldout, hrng, true, &held);
    WriteCaptureImages(ho, gt, held, held.dir, 1, &saturated, &object_pixels);
    SaveScene(held, (tmp / "heldout" / "scene.json").string());
  }

  out.Commit();
  report.images = o.num_images;
  report.saturated_fraction = object_pixels > 0 ? saturated / object_pixels : 0.0;
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

}  // namespace svbrdf
