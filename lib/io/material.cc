// material.json, "svbrdf-material/1":
//   {"format": "svbrdf-material/1", "mesh": "mesh.obj", "resolution": [W, H],
//    "basis": [{"name": "m0", "model": "lafortune", "label": "lafortune-2",
//               "params": {"rd_r": 0.3, ...}}, ...],
//    "weights": ["weights/m0.exr", ...],          // 3-channel EXR, one per basis material
//    "normal_map": "normal.exr",                  // optional, unit normals (RGB = xyz) in:
//    "normal_map_space": "tangent",               // optional, "world" (absent) or "tangent" (io/normal_map_space.h)
//    "confidence": "confidence.exr",              // optional, 1 channel
//    "material_id": "material_id.png",            // optional, integer basis index per texel
//    "texture_filter": "nearest",                 // optional, "bilinear" (absent) or "nearest"
//    "light_transfer": ["transfer/t0.exr", ...],  // optional, 4, 9 or 16 RGB maps: light transfer beyond the BRDF (material.h)
//    "light_residuals": {"directions": [[x, y, z], ...],   // optional, world unit vectors, one per map
//                        "maps": ["transfer/r0.exr", ...]}, // RGB residual radiance per unit irradiance (material.h)
//    "info": {...}}                               // optional, free-form provenance
#include "io/material.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <set>

#include "core/error.h"
#include "io/json_field.h"
#include "io/output_folder.h"
#include "io/scene.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
constexpr const char* kMaterialFormat = "svbrdf-material/1";

// Checks a loaded (or to-be-written) map against the material's resolution.
void CheckMap(const Image& img, int width, int height, int channels, const std::string& where) {
  if (img.width != width || img.height != height || img.channels != channels)
    throw Error(Msg(where, ": expected ", width, "x", height, " with ", channels, " channel(s), got ", img.width, "x",
                    img.height, " with ", img.channels));
}

// Every value finite and in [lo, hi] (weights must not be negative or NaN:
// the BRDF they mix must stay positive).
void CheckValues(const Image& img, float lo, float hi, const std::string& where) {
  for (size_t i = 0; i < img.pixels.size(); ++i)
    if (!(img.pixels[i] >= lo && img.pixels[i] <= hi)) {
      const size_t px = i / img.channels;
      throw Error(Msg(where, ": value ", img.pixels[i], " at pixel (", px % img.width, ", ", px / img.width,
                      ") is outside [", lo, ", ", hi, "] or not finite"));
    }
}

BasisMaterial BasisFromField(const JsonField& f) {
  f.AllowOnly({"name", "model", "label", "params"});
  BasisMaterial b;
  b.name = f.Get<std::string>("name");
  const std::string label = f.Get<std::string>("label");
  try {
    b.spec = ModelSpec::FromLabel(label);
  } catch (const Error& e) {
    f.FailAt("label", e.what());
  }
  const std::string model = f.Get<std::string>("model");
  if (model != b.spec.Name())
    f.FailAt("model", Msg("\"", model, "\" does not match label \"", label, "\" (expected \"", b.spec.Name(), "\")"));
  const JsonField params = f.Member("params", "object of parameter values by name");
  const std::vector<ParamInfo> infos = b.spec.Params();
  std::string expected, missing;
  for (const ParamInfo& p : infos) {
    expected += (expected.empty() ? "" : ", ") + p.name;
    if (!params.Has(p.name)) missing += (missing.empty() ? "" : ", ") + p.name;
  }
  for (const auto& [key, value] : params.json().items()) {
    bool known = false;
    for (const ParamInfo& p : infos) known = known || p.name == key;
    if (!known) params.FailAt(key, Msg("unknown parameter for ", label, " (expected ", expected, ")"));
  }
  if (!missing.empty()) f.FailAt("params", Msg("missing parameter(s) ", missing, " for ", label));
  for (const ParamInfo& p : infos) {
    b.params.push_back(params.Get<double>(p.name));
    // Outside the model's documented range a BRDF can turn negative or infinite.
    if (!(b.params.back() >= p.lower && b.params.back() <= p.upper))
      params.FailAt(p.name, Msg(b.params.back(), " is outside the range [", p.lower, ", ", p.upper, "] of ", label));
  }
  return b;
}

// Reads an optional map named by `key`; leaves `img` empty when absent.
void LoadOptionalMap(const JsonField& root, const std::string& dir, const std::string& key, int channels, int width,
                     int height, bool labels, Image* img) {
  if (!root.Has(key)) return;
  const std::string path = (fs::path(dir) / root.Get<std::string>(key)).string();
  try {
    *img = labels ? ReadLabelImage(path) : ReadImage(path);
    CheckMap(*img, width, height, channels, path);
  } catch (const Error& e) {
    root.FailAt(key, e.what());
  }
}

}  // namespace

json BasisToJson(const BasisMaterial& b) {
  const std::vector<ParamInfo> infos = b.spec.Params();
  if (b.params.size() != infos.size())
    throw Error(Msg("basis material '", b.name, "': ", b.params.size(), " parameters for ", b.spec.Label(),
                    " which has ", infos.size()));
  json params = json::object();
  for (size_t i = 0; i < infos.size(); ++i) params[infos[i].name] = b.params[i];
  return {{"name", b.name}, {"model", b.spec.Name()}, {"label", b.spec.Label()}, {"params", params}};
}

BasisMaterial BasisFromJson(const json& j, const std::string& context) { return BasisFromField(JsonField(j, context)); }

namespace {

// An RGB map of light transfer or residuals (radiance per unit irradiance)
// named by `file`; errors name that field.
Image ReadTransferMap(const JsonField& file, const std::string& dir, int width, int height) {
  const std::string path = (fs::path(dir) / file.As<std::string>()).string();
  try {
    Image map = ReadImage(path);
    CheckMap(map, width, height, 3, path);
    CheckValues(map, -1e4f, 1e4f, path);
    return map;
  } catch (const Error& e) {
    file.Fail(e.what());
  }
}

}  // namespace

int LightResidualNeighbours(const std::vector<Vec3>& dirs, const Vec3& d, int exclude, int* index, double* weight) {
  // The nearest in angle are the largest cosines; a small insertion list.
  double best_cos[kLightResidualNeighbours];
  int n = 0;
  for (int j = 0; j < int(dirs.size()); ++j) {
    if (j == exclude) continue;
    const double c = dirs[j].dot(d);
    int at = n < kLightResidualNeighbours ? n++ : kLightResidualNeighbours;
    while (at > 0 && best_cos[at - 1] < c) {
      if (at < kLightResidualNeighbours) best_cos[at] = best_cos[at - 1], index[at] = index[at - 1];
      --at;
    }
    if (at < kLightResidualNeighbours) best_cos[at] = c, index[at] = j;
  }
  double sum = 0;
  for (int k = 0; k < n; ++k) {
    weight[k] = 1.0 / std::max(std::acos(std::clamp(best_cos[k], -1.0, 1.0)), 1e-6);
    sum += weight[k];
  }
  for (int k = 0; k < n; ++k) weight[k] /= sum;
  return n;
}

Material LoadMaterial(const std::string& dir) {
  const std::string file = (fs::path(dir) / "material.json").string();
  const json j = ReadJsonFile(file);
  const JsonField root(j, file);
  root.AllowOnly({"format", "mesh", "resolution", "basis", "weights", "normal_map", "normal_map_space", "confidence",
                  "material_id", "texture_filter", "light_transfer", "light_residuals", "info"});
  const std::string format = root.Get<std::string>("format");
  if (format != kMaterialFormat) root.FailAt("format", Msg("expected \"", kMaterialFormat, "\", got \"", format, "\""));

  Material m;
  m.dir = dir;
  m.mesh_file = root.Get<std::string>("mesh");
  try {
    m.mesh = LoadMesh((fs::path(dir) / m.mesh_file).string());
  } catch (const Error& e) {
    root.FailAt("mesh", e.what());
  }
  if (!m.mesh.HasUVs()) root.FailAt("mesh", "mesh has no texture coordinates (the maps need them)");
  const Vec2 res = root.Get<Vec2>("resolution");
  // Range first: converting an out-of-range double to int is undefined.
  if (!(res.x() >= 1 && res.y() >= 1 && res.x() <= 65536 && res.y() <= 65536) || res.x() != std::floor(res.x()) ||
      res.y() != std::floor(res.y()))
    root.FailAt("resolution", Msg("expected [width, height] of integers in [1, 65536], got [", res.x(), ", ", res.y(), "]"));
  m.width = static_cast<int>(res.x());
  m.height = static_cast<int>(res.y());

  const std::vector<JsonField> basis = root.Items("basis");
  if (basis.empty()) root.FailAt("basis", "expected at least one basis material");
  std::set<std::string> names;
  for (const JsonField& f : basis) {
    m.basis.push_back(BasisFromField(f));
    if (!names.insert(m.basis.back().name).second) f.FailAt("name", Msg("duplicate name \"", m.basis.back().name, "\""));
  }
  const std::vector<JsonField> weights = root.Items("weights");
  if (weights.size() != basis.size())
    root.FailAt("weights", Msg("expected one map per basis material (", basis.size(), "), got ", weights.size()));
  for (const JsonField& w : weights) {
    const std::string path = (fs::path(dir) / w.As<std::string>()).string();
    try {
      m.weights.push_back(ReadImage(path));
      CheckMap(m.weights.back(), m.width, m.height, 3, path);
      // Mixing weights are fractions (times a brightness near 1); 1e4 is far beyond any fit.
      CheckValues(m.weights.back(), 0, 1e4f, path);
    } catch (const Error& e) {
      w.Fail(e.what());
    }
  }
  LoadOptionalMap(root, dir, "normal_map", 3, m.width, m.height, false, &m.normal_map);
  if (root.Has("normal_map_space")) {
    const std::string space = root.Get<std::string>("normal_map_space");
    if (!ParseNormalMapSpace(space, &m.normal_map_space))
      root.FailAt("normal_map_space", Msg("expected \"world\" or \"tangent\", got \"", space, "\""));
    if (!m.normal_map.width) root.FailAt("normal_map_space", "given without a \"normal_map\"");
  }
  LoadOptionalMap(root, dir, "confidence", 1, m.width, m.height, false, &m.confidence);
  try {
    if (m.normal_map.width) CheckValues(m.normal_map, -1.001f, 1.001f, (fs::path(dir) / root.Get<std::string>("normal_map")).string());
    if (m.confidence.width) CheckValues(m.confidence, 0, 1, (fs::path(dir) / root.Get<std::string>("confidence")).string());
  } catch (const Error& e) {
    throw Error(Msg(file, ": ", e.what()));
  }
  LoadOptionalMap(root, dir, "material_id", 1, m.width, m.height, true, &m.material_id);
  if (root.Has("light_transfer")) {
    const std::vector<JsonField> files = root.Items("light_transfer");
    if (!ValidLightTransferTerms(int(files.size())))
      root.FailAt("light_transfer", Msg("expected 4, 9 or 16 maps, got ", files.size()));
    for (const JsonField& file : files) m.light_transfer.push_back(ReadTransferMap(file, dir, m.width, m.height));
  }
  if (root.Has("light_residuals")) {
    const JsonField r = root.Member("light_residuals");
    r.AllowOnly({"directions", "maps"});
    const std::vector<JsonField> dirs = r.Items("directions"), files = r.Items("maps");
    if (dirs.size() != files.size() || dirs.empty())
      r.Fail(Msg("expected as many directions as maps (at least one), got ", dirs.size(), " and ", files.size()));
    for (const JsonField& d : dirs) {
      const Vec3 v = d.As<Vec3>();
      if (!(std::abs(v.norm() - 1.0) < 1e-3)) d.Fail(Msg("expected a unit vector, got length ", v.norm()));
      m.light_residual_directions.push_back(v.normalized());
    }
    for (const JsonField& file : files) m.light_residuals.push_back(ReadTransferMap(file, dir, m.width, m.height));
  }
  if (root.Has("texture_filter")) {
    const std::string filter = root.Get<std::string>("texture_filter");
    if (filter == "nearest") m.texture_filter = TextureFilter::kNearest;
    else if (filter != "bilinear") root.FailAt("texture_filter", Msg("expected \"bilinear\" or \"nearest\", got \"", filter, "\""));
  }
  if (root.Has("info")) m.extra = j["info"];
  return m;
}

void SaveMaterial(const Material& m, const std::string& dir_in) {
  // Without a trailing slash, so the temporary folder is a sibling.
  const fs::path dir = fs::path(dir_in).lexically_normal().parent_path() / fs::path(dir_in).lexically_normal().filename();
  const std::string where = (dir / "material.json").string();
  if (m.basis.empty()) throw Error(Msg(where, ": material has no basis materials"));
  if (m.weights.size() != m.basis.size())
    throw Error(Msg(where, ": ", m.weights.size(), " weight maps for ", m.basis.size(), " basis materials"));
  if (!m.mesh.HasUVs()) throw Error(Msg(where, ": mesh has no texture coordinates"));
  for (size_t i = 0; i < m.weights.size(); ++i) CheckMap(m.weights[i], m.width, m.height, 3, Msg(where, ": weights[", i, "]"));
  if (m.normal_map.width) CheckMap(m.normal_map, m.width, m.height, 3, where + ": normal_map");
  if (m.confidence.width) CheckMap(m.confidence, m.width, m.height, 1, where + ": confidence");
  if (m.material_id.width) CheckMap(m.material_id, m.width, m.height, 1, where + ": material_id");
  if (!m.light_transfer.empty() && !ValidLightTransferTerms(int(m.light_transfer.size())))
    throw Error(Msg(where, ": light_transfer has ", m.light_transfer.size(), " maps, expected 4, 9 or 16"));
  for (const Image& t : m.light_transfer) CheckMap(t, m.width, m.height, 3, where + ": light_transfer");
  if (m.light_residuals.size() != m.light_residual_directions.size())
    throw Error(Msg(where, ": ", m.light_residuals.size(), " light residual maps for ", m.light_residual_directions.size(),
                    " directions"));
  for (const Image& r : m.light_residuals) CheckMap(r, m.width, m.height, 3, where + ": light_residuals");

  OutputFolder out(dir.string());
  const fs::path tmp = out.path();
  try {
    fs::create_directories(tmp / "weights");
    json j = {{"format", kMaterialFormat}, {"mesh", m.mesh_file}, {"resolution", {m.width, m.height}}};
    fs::create_directories((tmp / m.mesh_file).parent_path());
    // With its normals: relight must shade with the ones the reconstruction used (LoadMesh).
    SaveObj(m.mesh, (tmp / m.mesh_file).string(), /*write_normals=*/true);
    j["basis"] = json::array();
    j["weights"] = json::array();
    for (size_t i = 0; i < m.basis.size(); ++i) {
      BasisMaterial b = m.basis[i];
      if (b.name.empty()) b.name = Msg("m", i);
      j["basis"].push_back(BasisToJson(b));
      const std::string rel = Msg("weights/m", i, ".exr");
      WriteImage((tmp / rel).string(), m.weights[i], PixelFormat::kFloat);
      j["weights"].push_back(rel);
    }
    if (m.normal_map.width) {
      WriteImage((tmp / "normal.exr").string(), m.normal_map, PixelFormat::kFloat);
      j["normal_map"] = "normal.exr";
      // World maps leave the field out: such folders read as before in
      // programs that predate it.
      if (m.normal_map_space != NormalMapSpace::kWorld) j["normal_map_space"] = NormalMapSpaceName(m.normal_map_space);
    }
    if (m.confidence.width) {
      WriteImage((tmp / "confidence.exr").string(), m.confidence, PixelFormat::kFloat);
      j["confidence"] = "confidence.exr";
    }
    if (m.material_id.width) {
      WriteLabelImage((tmp / "material_id.png").string(), m.material_id);
      j["material_id"] = "material_id.png";
    }
    if (m.texture_filter == TextureFilter::kNearest) j["texture_filter"] = "nearest";
    if (!m.light_transfer.empty()) {
      fs::create_directories(tmp / "transfer");
      j["light_transfer"] = json::array();
      for (size_t k = 0; k < m.light_transfer.size(); ++k) {
        const std::string rel = Msg("transfer/t", k, ".exr");
        WriteImage((tmp / rel).string(), m.light_transfer[k], PixelFormat::kFloat);
        j["light_transfer"].push_back(rel);
      }
    }
    if (!m.light_residuals.empty()) {
      fs::create_directories(tmp / "transfer");
      json dirs = json::array(), maps = json::array();
      for (size_t k = 0; k < m.light_residuals.size(); ++k) {
        const Vec3& d = m.light_residual_directions[k];
        dirs.push_back({d.x(), d.y(), d.z()});
        const std::string rel = Msg("transfer/r", k, ".exr");
        WriteImage((tmp / rel).string(), m.light_residuals[k], PixelFormat::kFloat);
        maps.push_back(rel);
      }
      j["light_residuals"] = {{"directions", dirs}, {"maps", maps}};
    }
    if (!m.extra.is_null()) j["info"] = m.extra;
    WriteFileAtomic((tmp / "material.json").string(), j.dump(2) + "\n");
  } catch (const fs::filesystem_error& e) {
    throw Error(Msg(where, ": cannot write material folder: ", e.what()));
  }
  // Replace the destination only once everything is written.
  out.Commit();
}

int MaterialBounces(const Material& material) {
  const nlohmann::json& x = material.extra;
  if (!x.is_object() || !x.contains("interreflection") || !x["interreflection"].is_object()) return 0;
  const nlohmann::json& b = x["interreflection"].value("bounces", nlohmann::json(0));
  if (!b.is_number_integer() || b.get<int>() < 0 || b.get<int>() > 64)
    throw Error(Msg(material.dir, "/material.json: info.interreflection.bounces must be an integer in [0, 64]"));
  return b.get<int>();
}

void SetMaterialBounces(Material* material, int bounces) {
  if (!material->extra.is_object()) material->extra = nlohmann::json::object();
  material->extra["interreflection"] = {
      {"bounces", bounces},
      {"meaning", "fitted to direct light: the photos' indirect light over this many bounces was removed"}};
}

}  // namespace svbrdf
