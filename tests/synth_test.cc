// Synthetic captures: valid contract files, ground truth that re-reads
// identically, determinism with a seed, procedural shapes with atlases.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "atlas/atlas.h"
#include "brdf/fresnel.h"
#include "brdf/metals.h"
#include "core/error.h"
#include "io/material.h"
#include "io/scene.h"
#include "synth/capture.h"
#include "synth/ground_truth.h"
#include "synth/shapes.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("svbrdf_synth_test_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(p);
  return p.string();
}

SynthOptions Small() {
  SynthOptions o = SynthPreset("tiny");
  o.num_images = 4;
  o.num_heldout = 1;
  o.width = 64;
  o.height = 48;
  o.material.texture_size = 32;
  o.detail = 24;
  return o;
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(Synth, ShapesHaveAtlasAndOutwardNormals) {
  for (const std::string name : {"sphere", "torus", "blob", "cube"}) {
    const Mesh m = MakeShape(name, 32);
    ASSERT_TRUE(m.HasUVs()) << name;
    m.Validate(name);
    for (const Vec2& uv : m.texcoords) {
      EXPECT_GE(uv.x(), 0.0);
      EXPECT_LE(uv.x(), 1.0);
      EXPECT_GE(uv.y(), 0.0);
      EXPECT_LE(uv.y(), 1.0);
    }
    // Face normals agree with the smooth vertex normals (consistent, outward winding).
    int agree = 0;
    for (const Vec3i& f : m.faces) {
      const Vec3 n = (m.positions[f[1]] - m.positions[f[0]]).cross(m.positions[f[2]] - m.positions[f[0]]);
      agree += n.dot(m.normals[f[0]] + m.normals[f[1]] + m.normals[f[2]]) > 0;
    }
    EXPECT_EQ(agree, int(m.faces.size())) << name;
    const Atlas a = BuildAtlas(m, 64, 64);
    EXPECT_GT(a.texels.size(), 64u * 64u / 4) << name << ": atlas covers too little";
  }
  EXPECT_THROW(MakeShape("teapot", 32), Error);
}

TEST(Synth, CaptureIsValidAndReReadsIdentically) {
  const std::string dir = TempDir("valid");
  const SynthReport r = Synthesize(Small(), dir);
  EXPECT_EQ(r.images, 4);
  const Scene s = LoadScene(dir + "/scene.json");
  EXPECT_EQ(s.images.size(), 4u);
  EXPECT_TRUE(s.ground_truth.is_object());
  for (const ImageEntry& e : s.images) {
    const Image img = ReadImage(s.Resolve(e.file));
    EXPECT_EQ(img.width, 64);
    const Image mask = ReadImage(s.Resolve(e.mask));
    long on = 0;
    for (float v : mask.pixels) on += v > 0;
    EXPECT_GT(on, 100) << e.file << ": the object should be in view";
  }
  // scene.json: write what was read, read it again: the same scene (numbers
  // equal to 1e-12: the reader re-normalises quaternions), and from then on
  // byte-identical files.
  SaveScene(s, dir + "/copy.json");
  const Scene again = LoadScene(dir + "/copy.json");
  ASSERT_EQ(again.images.size(), s.images.size());
  for (size_t i = 0; i < s.images.size(); ++i) {
    EXPECT_EQ(again.images[i].file, s.images[i].file);
    EXPECT_NEAR(again.images[i].cam_from_world.rotation.angularDistance(s.images[i].cam_from_world.rotation), 0, 1e-12);
    EXPECT_LT((again.images[i].cam_from_world.translation - s.images[i].cam_from_world.translation).norm(), 1e-12);
  }
  ASSERT_EQ(again.lights.size(), s.lights.size());
  for (size_t i = 0; i < s.lights.size(); ++i) {
    EXPECT_EQ(again.lights[i].type, s.lights[i].type);
    EXPECT_LT((again.lights[i].position - s.lights[i].position).norm(), 1e-12);
  }
  EXPECT_EQ(again.ground_truth.dump(), s.ground_truth.dump());
  SaveScene(again, dir + "/copy2.json");
  EXPECT_EQ(SceneToJson(again).dump(), SceneToJson(LoadScene(dir + "/copy2.json")).dump());
  // Ground truth material: load, save elsewhere, load: same basis and maps.
  const Material gt = LoadMaterial(dir + "/gt");
  EXPECT_EQ(gt.basis.size(), 3u);
  SaveMaterial(gt, dir + "/gt_copy");
  const Material gt2 = LoadMaterial(dir + "/gt_copy");
  ASSERT_EQ(gt2.basis.size(), gt.basis.size());
  for (size_t k = 0; k < gt.basis.size(); ++k) {
    EXPECT_EQ(gt.basis[k].spec.Label(), gt2.basis[k].spec.Label());
    EXPECT_EQ(gt.basis[k].params, gt2.basis[k].params);
    EXPECT_EQ(gt.weights[k].pixels, gt2.weights[k].pixels);
  }
  EXPECT_EQ(gt.material_id.pixels, gt2.material_id.pixels);
  // Soft regions: every material owns some texels.
  std::vector<int> count(3, 0);
  for (float id : gt.material_id.pixels)
    if (id >= 0) count[int(id)]++;
  for (int c : count) EXPECT_GT(c, 20);
  fs::remove_all(dir);
}

TEST(Synth, DeterministicWithSeed) {
  SynthOptions o = Small();
  o.noise = 0.01;
  const std::string a = TempDir("det_a"), b = TempDir("det_b"), c = TempDir("det_c");
  Synthesize(o, a);
  o.threads = 1;
  Synthesize(o, b);
  o.seed = 12345;
  Synthesize(o, c);
  // Pixels, not file bytes: EXR headers carry a capture date.
  const std::string f = "/images/0001.exr";
  EXPECT_EQ(ReadImage(a + f).pixels, ReadImage(b + f).pixels);
  EXPECT_EQ(Slurp(a + "/scene.json"), Slurp(b + "/scene.json"));
  EXPECT_NE(ReadImage(a + f).pixels, ReadImage(c + f).pixels);
  for (const auto& d : {a, b, c}) fs::remove_all(d);
}

TEST(Synth, FaultsAreWrittenIntoTheRecordedScene) {
  SynthOptions o = Small();
  const std::string a = TempDir("clean"), b = TempDir("faulty");
  Synthesize(o, a);
  o.pose_error_deg = 1.0;
  o.light_error_mm = 20;
  o.format = "png8";
  o.exposure = 4.0;  // overexposed: highlights clip
  Synthesize(o, b);
  const Scene sa = LoadScene(a + "/scene.json"), sb = LoadScene(b + "/scene.json");
  const double angle = sa.images[0].cam_from_world.rotation.angularDistance(sb.images[0].cam_from_world.rotation);
  EXPECT_NEAR(angle * 180 / kPi, 1.0, 1e-6);
  EXPECT_EQ(sb.images_color_space, ColorSpace::kSRGB);
  const Image img = ReadImage(sb.Resolve(sb.images[0].file), sb.images_color_space);
  EXPECT_GT(SaturatedFraction(img), 0.0);
  for (const auto& d : {a, b}) fs::remove_all(d);
}

TEST(Synth, RejectsBadOptions) {
  SynthOptions o = Small();
  o.object = "teapot";
  EXPECT_THROW(o.Check(), Error);
  EXPECT_THROW(SynthPreset("nope"), Error);
  EXPECT_THROW(SynthOptions::FromJson(nlohmann::json{{"num_imagez", 3}}, "x.json"), Error);
}

TEST(Synth, EveryPresetParses) {
  const std::vector<std::string> names = SynthPresetNames();
  for (const char* wanted : {"default", "default_bump", "tiny", "standard", "mixed", "mixed_tiny", "metals_rough", "metals_polished",
                             "coated_plastic"})
    EXPECT_NE(std::find(names.begin(), names.end(), wanted), names.end()) << wanted;
  for (const std::string& name : names) EXPECT_NO_THROW(SynthPreset(name)) << name;
  const SynthOptions mixed = SynthPreset("mixed");
  EXPECT_EQ(mixed.num_images, 40);
  EXPECT_EQ(mixed.width, 800);
  EXPECT_EQ(mixed.noise, 0.01);
  ASSERT_EQ(mixed.material.params.size(), 3u);
  EXPECT_EQ(mixed.material.params[0].metal, "copper");
  EXPECT_GT(mixed.material.bump, 0);
}

// Per-material parameters: published metals become eta/kappa (exact Fresnel)
// or the matching f0 and F82 tint; plain values override; the options
// survive the JSON round trip that scene.json records.
TEST(Synth, MaterialParamsSetMetalsAndValues) {
  GroundTruthOptions g;
  g.num_materials = 3;
  g.texture_size = 16;
  g.models = {"conductor-ggx", "conductor-beckmann-f82", "coated-ggx"};
  g.params = {{"gold", {{"roughness", 0.05}}}, {"aluminium", {}}, {"", {{"rd_r", 0.7}, {"ior", 1.4}}}};
  const Material m = MakeGroundTruth(MakeShape("sphere", 16), g);
  const brdf::MetalConstants& gold = *brdf::FindMetal("gold");
  const brdf::MetalConstants& al = *brdf::FindMetal("aluminium");
  EXPECT_EQ(GetParam(m.basis[0], "eta_r"), gold.eta[0]);
  EXPECT_EQ(GetParam(m.basis[0], "kappa_b"), gold.kappa[2]);
  EXPECT_EQ(GetParam(m.basis[0], "roughness"), 0.05);
  EXPECT_DOUBLE_EQ(GetParam(m.basis[1], "f0_g"), brdf::ConductorF0(al.eta[1], al.kappa[1]));
  EXPECT_DOUBLE_EQ(GetParam(m.basis[1], "f82_tint_r"), brdf::ConductorF82Tint(al.eta[0], al.kappa[0]));
  EXPECT_EQ(GetParam(m.basis[2], "rd_r"), 0.7);
  EXPECT_EQ(GetParam(m.basis[2], "ior"), 1.4);

  SynthOptions o = Small();
  o.material = g;
  const SynthOptions back = SynthOptions::FromJson(o.ToJson(), "round trip");
  ASSERT_EQ(back.material.params.size(), 3u);
  EXPECT_EQ(back.material.params[0].metal, "gold");
  EXPECT_EQ(back.material.params[0].values, g.params[0].values);
  EXPECT_EQ(back.material.params[2].values, g.params[2].values);
}

TEST(Synth, RejectsBadMaterialParams) {
  auto make = [](const std::string& model, const MaterialParams& p) {
    GroundTruthOptions g;
    g.num_materials = 1;
    g.texture_size = 16;
    g.models = {model};
    g.params = {p};
    return MakeGroundTruth(MakeShape("sphere", 16), g);
  };
  EXPECT_THROW(make("conductor-ggx", {"silver", {}}), Error);                 // unknown metal
  EXPECT_THROW(make("lambert", {"gold", {}}), Error);                         // not a conductor
  EXPECT_THROW(make("conductor-ggx", {"", {{"roughness", 2.0}}}), Error);     // out of range
  EXPECT_THROW(make("coated-ggx", {"", {{"f0_r", 0.5}}}), Error);             // no such parameter
  GroundTruthOptions g;
  g.num_materials = 2;
  g.params = {{}};
  EXPECT_THROW(g.Check(), Error);  // one entry per material
  const nlohmann::json bad = {{"material", {{"num_materials", 1}, {"params", {{{"metal", 3}}}}}}};
  EXPECT_THROW(SynthOptions::FromJson(bad, "x.json"), Error);
}

}  // namespace
}  // namespace svbrdf
