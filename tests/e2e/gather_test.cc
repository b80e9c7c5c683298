// Gathered samples agree with the ground truth that rendered the capture:
// catches any disagreement of frames, conventions or light units between
// synth/relight and gather.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>

#include "core/error.h"
#include "gather/gather.h"
#include "relight/shader.h"
#include "synth/capture.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;

// What the ground-truth material predicts for gathered sample i (its texel's
// centre, frame and the sample's directions and geometry factor).
Rgb TruthPrediction(const GatherResult& g, const MaterialShader& shader, int64_t i) {
  const Texel& tx = g.atlas.texels[g.samples.texel[i]];
  const Vec2 uv((tx.x + 0.5) / g.atlas.width, 1.0 - (tx.y + 0.5) / g.atlas.height);
  const Frame f = Frame::FromNormalTangent(tx.normal, tx.tangent);
  const Vec3 wi(g.samples.wi[0][i], g.samples.wi[1][i], g.samples.wi[2][i]);
  const Vec3 wo(g.samples.wo[0][i], g.samples.wo[1][i], g.samples.wo[2][i]);
  return shader.Eval(uv, f, f.ToWorld(wi), f.ToWorld(wo)) * g.samples.geom[i];
}

// The same averaged over the sample's footprint sub-samples (as
// PredictSample does): each lookup pixel's normal as a tilt of the texel's.
Rgb TruthFootprintPrediction(const GatherResult& g, const MaterialShader& shader, int64_t i) {
  const Texel& tx = g.atlas.texels[g.samples.texel[i]];
  const Vec2 uv((tx.x + 0.5) / g.atlas.width, 1.0 - (tx.y + 0.5) / g.atlas.height);
  const Frame f = Frame::FromNormalTangent(tx.normal, tx.tangent);
  const Vec3 wi(g.samples.wi[0][i], g.samples.wi[1][i], g.samples.wi[2][i]);
  const Vec3 wo(g.samples.wo[0][i], g.samples.wo[1][i], g.samples.wo[2][i]);
  const float* fp = &g.samples.footprint[size_t(i) * 3 * SampleSet::kFootprintSubsamples];
  Rgb sum = Rgb::Zero();
  for (int j = 0; j < SampleSet::kFootprintSubsamples; ++j, fp += 3) {
    Vec3 wi_t, wo_t;
    double ratio;
    if (!(fp[2] > 0) || !TiltedSampleDirections(wi, wo, double(fp[0]), double(fp[1]), &wi_t, &wo_t, &ratio)) continue;
    const Frame tilted = Frame::FromNormalTangent(f.ToWorld(Vec3(fp[0], fp[1], 1).normalized()), tx.tangent);
    sum += fp[2] * ratio * shader.Eval(uv, tilted, f.ToWorld(wi), f.ToWorld(wo));
  }
  return sum * g.samples.geom[i];
}

// A tiny synthetic capture (SynthPreset("tiny") changed by `adjust`) in a
// fresh temporary folder `name`<pid>; returns the folder.
std::string TinyCapture(const std::string& name, const std::function<void(SynthOptions&)>& adjust) {
  const std::string dir = (fs::temp_directory_path() / (name + std::to_string(getpid()))).string();
  SynthOptions o = SynthPreset("tiny");
  adjust(o);
  Synthesize(o, dir);
  return dir;
}

TEST(Gather, SamplesMatchGroundTruthBrdf) {
  const std::string dir = (fs::temp_directory_path() / ("svbrdf_gather_" + std::to_string(getpid()))).string();
  SynthOptions o = SynthPreset("tiny");
  o.noise = 0;
  o.spp = 1;
  Synthesize(o, dir);
  const Scene scene = LoadScene(dir + "/scene.json");
  GatherOptions go;
  go.texture_size = o.material.texture_size;
  go.progress = false;
  const GatherResult g = Gather(scene, go);
  ASSERT_GT(g.samples.size(), 1000);
  const Material gt = LoadMaterial(dir + "/gt");
  MaterialShader shader(gt);
  double se = 0, sy = 0;
  for (int64_t i = 0; i < g.samples.size(); ++i) {
    const Texel& tx = g.atlas.texels[g.samples.texel[i]];
    if (!tx.interior) continue;
    const Rgb pred = TruthPrediction(g, shader, i);
    for (int c = 0; c < 3; ++c) {
      se += (pred[c] - g.samples.y[c][i]) * (pred[c] - g.samples.y[c][i]);
      sy += g.samples.y[c][i] * g.samples.y[c][i];
    }
  }
  const double rel = std::sqrt(se / sy);
  std::printf("gathered vs ground truth: relative RMSE %.4f over %ld samples (%s)\n", rel, long(g.samples.size()),
              g.stats.Report().c_str());
  EXPECT_LT(rel, 0.02);
  fs::remove_all(dir);
}

// Median relative disagreement of the gathered samples of interior texels
// with the ground-truth BRDF (mean over channels), predicted by
// predict(g, shader, i) (default: at the texel centre); `count`: the samples
// it is the median of.
using TruthPredictor = Rgb (*)(const GatherResult&, const MaterialShader&, int64_t);
double MedianRelativeError(const GatherResult& g, const Material& gt, TruthPredictor predict = TruthPrediction,
                           size_t* count = nullptr) {
  MaterialShader shader(gt);
  std::vector<double> rel;
  for (int64_t i = 0; i < g.samples.size(); ++i) {
    const Texel& tx = g.atlas.texels[g.samples.texel[i]];
    if (!tx.interior) continue;
    const Rgb pred = predict(g, shader, i);
    const double y = (g.samples.y[0][i] + g.samples.y[1][i] + g.samples.y[2][i]) / 3;
    if (y > 1e-3) rel.push_back(std::abs((pred[0] + pred[1] + pred[2]) / 3 - y) / y);
  }
  if (count) *count = rel.size();
  if (rel.empty()) return 1e9;
  std::nth_element(rel.begin(), rel.begin() + rel.size() / 2, rel.end());
  return rel[rel.size() / 2];
}

// Writes the bumpy sphere below to dir/bumpy.obj and an 8-view tiny capture
// of it, rendered with 4x4 samples per pixel, to dir/cap.
SynthOptions BumpySphereCapture(const std::string& dir) {
  fs::create_directories(dir);
  {
    // Lat-long sphere of radius 0.5 with UVs; radius modulated by bumps of
    // wavelength ~46 mm (tiny preset: ~11.5 mm per pixel) and slope ~20 deg.
    const int nu = 340, nv = 170;
    const double amp = 0.0015, ku = 68, kv = 34;
    std::string obj;
    for (int i = 0; i <= nv; ++i)
      for (int j = 0; j <= nu; ++j) {
        const double th = M_PI * i / nv, ph = 2 * M_PI * j / nu;
        const double r = 0.5 + amp * std::sin(kv * th) * std::sin(ku * ph);
        obj += Msg("v ", r * std::sin(th) * std::cos(ph), " ", r * std::cos(th), " ", -r * std::sin(th) * std::sin(ph), "\n");
        obj += Msg("vt ", double(j) / nu, " ", 1.0 - double(i) / nv, "\n");
      }
    const int w = nu + 1;
    for (int i = 0; i < nv; ++i)
      for (int j = 0; j < nu; ++j) {
        const int a = i * w + j + 1, b = a + 1, c = a + w, d = c + 1;
        if (i > 0) obj += Msg("f ", a, "/", a, " ", c, "/", c, " ", b, "/", b, "\n");
        if (i < nv - 1) obj += Msg("f ", b, "/", b, " ", c, "/", c, " ", d, "/", d, "\n");
      }
    std::ofstream(dir + "/bumpy.obj") << obj;
  }
  SynthOptions o = SynthPreset("tiny");
  o.mesh_file = dir + "/bumpy.obj";
  o.noise = 0;
  o.spp = 4;
  o.num_images = 8;
  o.num_heldout = 0;
  Synthesize(o, dir + "/cap");
  return o;
}

// The bumpy sphere's capture (BumpySphereCapture) loaded, with its true
// material and gather options at its texture size; removes its folder when
// the test ends.
struct BumpySphereCase {
  explicit BumpySphereCase(const std::string& name)
      : dir((fs::temp_directory_path() / (name + std::to_string(getpid()))).string()),
        options(BumpySphereCapture(dir)),
        scene(LoadScene(dir + "/cap/scene.json")),
        gt(LoadMaterial(dir + "/cap/gt")) {
    go.texture_size = options.material.texture_size;
    go.progress = false;
  }
  ~BumpySphereCase() { fs::remove_all(dir); }
  const std::string dir;
  const SynthOptions options;
  const Scene scene;
  const Material gt;
  GatherOptions go;
};

// A scan-like surface whose normal turns within a pixel (a sphere with
// bumps of ~4 pixels' wavelength, rendered with 4x4 samples per pixel as a
// camera integrates them): the samples' frames from the footprint's mean
// normal must describe the measured values better than the texel-centre
// normal.
TEST(Gather, FootprintNormalsFollowSubPixelBumps) {
  BumpySphereCase c("svbrdf_gather_bumps_");
  c.go.footprint_subsamples = 0;  // the frames' normal alone (the sub-samples are tested below)
  c.go.footprint_rays = 0;
  const double centre = MedianRelativeError(Gather(c.scene, c.go), c.gt);
  c.go.footprint_rays = 2;
  const double footprint = MedianRelativeError(Gather(c.scene, c.go), c.gt);
  std::printf("median relative sample error: texel-centre normal %.4f, footprint normal %.4f\n", centre, footprint);
  EXPECT_LT(footprint, 0.7 * centre);
}

// The footprint sub-samples (GatherOptions::footprint_subsamples) on the same
// bumpy sphere: the true material averaged over the four lookup pixels'
// normals (as PredictSample does) describes the samples better than at the
// texel-centre normal; the weights sum to 1.
TEST(Gather, FootprintSubsamplesPredictSubPixelBumps) {
  BumpySphereCase c("svbrdf_gather_subs_");
  const Scene& scene = c.scene;
  const Material& gt = c.gt;
  GatherOptions& go = c.go;
  go.footprint_subsamples = 0;
  EXPECT_FALSE(Gather(scene, go).samples.HasFootprint());
  go.footprint_subsamples = 2;
  go.footprint_min_tilt_deg = 90;  // the median tilt is below: dropped
  const GatherResult smooth = Gather(scene, go);
  EXPECT_FALSE(smooth.samples.HasFootprint());
  EXPECT_FALSE(smooth.stats.footprint_kept);
  go.footprint_min_tilt_deg = GatherOptions().footprint_min_tilt_deg;
  const GatherResult g = Gather(scene, go);
  EXPECT_TRUE(g.stats.footprint_kept);
  EXPECT_GT(g.stats.footprint_median_tilt_deg, go.footprint_min_tilt_deg);
  ASSERT_EQ(g.samples.footprint.size(), size_t(g.samples.size()) * 3 * SampleSet::kFootprintSubsamples);
  for (int64_t i = 0; i < g.samples.size(); ++i) {
    double weights = 0;
    const float* fp = &g.samples.footprint[size_t(i) * 3 * SampleSet::kFootprintSubsamples];
    for (int j = 0; j < SampleSet::kFootprintSubsamples; ++j) weights += fp[3 * j + 2];
    EXPECT_NEAR(weights, 1.0, 1e-5);
  }
  size_t count = 0;
  const double centre = MedianRelativeError(g, gt, TruthPrediction, &count);
  const double footprint = MedianRelativeError(g, gt, TruthFootprintPrediction);
  ASSERT_GT(count, 1000u);
  std::printf("median relative sample error: texel-centre normal %.4f, footprint sub-samples %.4f\n", centre, footprint);
  EXPECT_LT(footprint, 0.6 * centre);
}

// Samples whose pixel footprint spans a large turn of the mesh normal are
// the ones the texel-centre frame describes worst; rejecting them
// (GatherOptions::max_footprint_turn_deg) leaves samples that agree better
// with the true BRDF, and rejects none on a smooth sphere.
TEST(Gather, SamplesWhereTheNormalTurnsWithinThePixelAreRejected) {
  BumpySphereCase c("svbrdf_gather_turn_");
  const std::string& dir = c.dir;
  const Scene& scene = c.scene;
  const Material& gt = c.gt;
  GatherOptions& go = c.go;
  const GatherResult all = Gather(scene, go);
  go.max_footprint_turn_deg = 12;
  const GatherResult kept = Gather(scene, go);
  const double e_all = MedianRelativeError(all, gt), e_kept = MedianRelativeError(kept, gt);
  std::printf("median relative sample error: all %.4f (%ld samples), normal turn <= 12 deg per footprint %.4f (%ld)\n",
              e_all, long(all.samples.size()), e_kept, long(kept.samples.size()));
  EXPECT_EQ(all.stats.turning, 0);
  EXPECT_GT(kept.stats.turning, 0);
  EXPECT_GT(kept.samples.size(), 100);
  EXPECT_LT(e_kept, 0.8 * e_all);
  // A smooth sphere (the tiny preset's) loses no sample.
  SynthOptions smooth = SynthPreset("tiny");
  smooth.num_images = 4;
  smooth.num_heldout = 0;
  Synthesize(smooth, dir + "/smooth");
  EXPECT_EQ(Gather(LoadScene(dir + "/smooth/scene.json"), go).stats.turning, 0);
}

// Where the photo changes steeply within a sample's bilinear lookup (here:
// the bumps' highlights, which turn within a pixel), the interpolated value
// is not the texel centre's; rejecting such samples
// (GatherOptions::max_lookup_contrast) leaves samples that
// agree better with the true BRDF, and rejects almost none on a smooth
// sphere, whose mesh does not turn within a pixel.
TEST(Gather, SamplesWhosePhotoChangesSteeplyWithinTheLookupAreRejected) {
  BumpySphereCase c("svbrdf_gather_contrast_");
  const std::string& dir = c.dir;
  const Scene& scene = c.scene;
  const Material& gt = c.gt;
  GatherOptions& go = c.go;
  go.max_lookup_contrast = 0.3;
  const GatherResult kept = Gather(scene, go);
  GatherOptions off = go;
  off.max_lookup_contrast = 1;
  const GatherResult all = Gather(scene, off);
  const double e_all = MedianRelativeError(all, gt), e_kept = MedianRelativeError(kept, gt);
  std::printf("median relative sample error: all %.4f (%ld samples), lookup contrast <= 0.3 %.4f (%ld)\n", e_all,
              long(all.samples.size()), e_kept, long(kept.samples.size()));
  EXPECT_EQ(all.stats.contrast, 0);
  EXPECT_GT(kept.stats.contrast, 0);
  EXPECT_GT(kept.samples.size(), 100);
  EXPECT_LT(e_kept, 0.93 * e_all);
  // A smooth sphere loses few samples (at its silhouette, where a pixel's
  // footprint spans much of the coarse mesh's turn), and none where its
  // mesh turns less than the condition within a pixel (its contrast there is
  // the material's signal).
  SynthOptions smooth = SynthPreset("tiny");
  smooth.num_images = 4;
  smooth.num_heldout = 0;
  Synthesize(smooth, dir + "/smooth");
  const Scene smooth_scene = LoadScene(dir + "/smooth/scene.json");
  const GatherResult s = Gather(smooth_scene, go);
  std::printf("smooth sphere: %ld of %ld samples rejected for contrast\n", s.stats.contrast,
              long(s.stats.kept + s.stats.contrast));
  EXPECT_LT(s.stats.contrast, 0.05 * (s.stats.kept + s.stats.contrast));
  GatherOptions flat_only = go;
  flat_only.contrast_min_turn_deg = 90;
  EXPECT_EQ(Gather(smooth_scene, flat_only).stats.contrast, 0);
}

// The footprint probe (GatherOptions::probe_rays) sees what the texel centre
// cannot: samples whose footprint is partly unlit (shadow boundary or
// terminator) or partly on another surface (silhouette, occluding edge)
// agree worse with the true BRDF than the others, and rejecting them by
// their shares counts them and removes them.
TEST(Gather, FootprintProbeFindsShadowBoundariesAndEdges) {
  const std::string dir = (fs::temp_directory_path() / ("svbrdf_gather_probe_" + std::to_string(getpid()))).string();
  SynthOptions o = SynthPreset("tiny");
  o.noise = 0;
  o.spp = 4;
  o.num_images = 6;
  o.num_heldout = 0;
  Synthesize(o, dir);
  const Scene scene = LoadScene(dir + "/scene.json");
  const Material gt = LoadMaterial(dir + "/gt");
  MaterialShader shader(gt);
  GatherOptions go;
  go.texture_size = o.material.texture_size;
  go.progress = false;
  go.probe_rays = 0;  // off (the default is 2): no probes
  const GatherResult plain = Gather(scene, go);
  EXPECT_TRUE(plain.probes.empty());
  go.probe_rays = 2;
  const GatherResult g = Gather(scene, go);
  ASSERT_EQ(g.probes.size(), size_t(g.samples.size()));
  EXPECT_EQ(g.samples.size(), plain.samples.size());  // probing alone rejects nothing
  // The probe keeps each sample's lookup contrast beside its own measures.
  float max_contrast = 0;
  for (const SampleProbe& p : g.probes) max_contrast = std::max(max_contrast, p.contrast);
  EXPECT_GT(max_contrast, 0.05f);
  // Relative error of clean samples and of those at an edge or shadow boundary.
  double se[2] = {0, 0}, sy[2] = {0, 0};
  long n[2] = {0, 0};
  for (int64_t i = 0; i < g.samples.size(); ++i) {
    const int k = g.probes[i].foreign > 0 || g.probes[i].unlit > 0;
    const Rgb pred = TruthPrediction(g, shader, i);
    for (int c = 0; c < 3; ++c) {
      se[k] += (pred[c] - g.samples.y[c][i]) * (pred[c] - g.samples.y[c][i]);
      sy[k] += g.samples.y[c][i] * g.samples.y[c][i];
    }
    ++n[k];
  }
  const double clean = std::sqrt(se[0] / sy[0]), edge = std::sqrt(se[1] / sy[1]);
  std::printf("relative RMSE vs truth: clean %.4f (%ld samples), edge or shadow boundary in the footprint %.4f (%ld)\n",
              clean, n[0], edge, n[1]);
  EXPECT_GT(n[1], 20);
  EXPECT_GT(edge, 2 * clean);
  go.max_unlit_share = 0;
  go.max_probe_foreign_share = 0;
  const GatherResult strict = Gather(scene, go);
  EXPECT_EQ(strict.stats.probe_unlit + strict.stats.probe_foreign, n[1]);
  EXPECT_EQ(strict.samples.size(), n[0]);
  fs::remove_all(dir);
}

// Meshes without UVs get a chart atlas; texels outside every UV triangle
// (dilation rings, texels claimed by sub-texel triangles) whose measured
// point is clamped more than half a texel away take no samples.
TEST(Gather, ChartAtlasBorderTexelsTakeNoSamples) {
  const std::string dir = TinyCapture("svbrdf_gather_noUV_", [](SynthOptions& o) {
    o.mesh_uvs = false;
    o.num_images = 6;
    o.num_heldout = 0;
  });
  const Scene scene = LoadScene(dir + "/scene.json");
  GatherOptions go;
  go.progress = false;
  go.footprint_rays = 0;
  go.border_texel_samples = false;
  // Samples on texels outside every UV triangle whose measured (clamped)
  // point lies farther than half a texel from the texel centre.
  auto border_samples = [](const GatherResult& g) {
    long n = 0;
    for (int64_t i = 0; i < g.samples.size(); ++i) {
      const Texel& tx = g.atlas.texels[g.samples.texel[i]];
      if (tx.interior) continue;
      n += (UvToTexel(TexelUv(g.mesh, tx), g.atlas.width, g.atlas.height) - Vec2(tx.x + 0.5, tx.y + 0.5)).norm() > 0.5;
    }
    return n;
  };
  const GatherResult g = Gather(scene, go);
  ASSERT_TRUE(g.made_uvs);
  EXPECT_GT(g.samples.size(), 1000);
  EXPECT_GT(g.stats.border_texel, 0);
  EXPECT_EQ(border_samples(g), 0);
  go.border_texel_samples = true;  // the old behaviour samples them
  const GatherResult all = Gather(scene, go);
  EXPECT_EQ(all.stats.border_texel, 0);
  EXPECT_GT(border_samples(all), 0);
  fs::remove_all(dir);
}

// A square of side 2 whose UVs span [0, 1]^2 (surface / UV area 4): a
// texel 0.01 long needs 200 texels a side; the size is clamped below and
// above; UVs without area give 0.
TEST(Gather, UvTextureSizeFollowsTheTexelLength) {
  Mesh m;
  m.positions = {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(2, 2, 0), Vec3(0, 2, 0)};
  m.faces = {Vec3i(0, 1, 2), Vec3i(0, 2, 3)};
  m.texcoords = {Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(0, 1)};
  m.face_uvs = m.faces;
  EXPECT_EQ(UvTextureSize(m, 0.01, 1024), 200);
  EXPECT_EQ(UvTextureSize(m, 0.01, 128), 128);
  EXPECT_EQ(UvTextureSize(m, 1.0, 1024), 16);
  // The area-weighted median: a second square with a 4x finer UV scale but
  // a tenth of the surface does not move it.
  const int n = int(m.positions.size());
  for (const Vec3& p : {Vec3(5, 0, 0), Vec3(5.2, 0, 0), Vec3(5.2, 0.2, 0), Vec3(5, 0.2, 0)}) m.positions.push_back(p);
  m.faces.push_back(Vec3i(n, n + 1, n + 2));
  m.faces.push_back(Vec3i(n, n + 2, n + 3));
  m.face_uvs = {Vec3i(0, 1, 2), Vec3i(0, 2, 3), Vec3i(0, 1, 2), Vec3i(0, 2, 3)};
  EXPECT_EQ(UvTextureSize(m, 0.01, 1024), 200);
  m.texcoords = {Vec2(0, 0), Vec2(0, 0), Vec2(0, 0), Vec2(0, 0)};
  EXPECT_EQ(UvTextureSize(m, 0.01, 1024), 0);
}

// With texture size 0 a mesh with UVs gets the atlas whose texel covers
// texel_footprint pixel footprints (not a fixed size), and an explicit size
// is kept.
TEST(Gather, UvMeshAtlasSizeFollowsThePixelFootprint) {
  const std::string dir = TinyCapture("svbrdf_gather_auto_", [](SynthOptions& o) {
    o.num_images = 4;
    o.num_heldout = 0;
  });
  const Scene scene = LoadScene(dir + "/scene.json");
  GatherOptions go;
  go.progress = false;
  go.footprint_rays = 0;
  go.texture_size = 0;
  const GatherResult g = Gather(scene, go);
  ASSERT_FALSE(g.made_uvs);
  const Mesh mesh = LoadMesh(scene.Resolve(scene.mesh));
  const int expected = UvTextureSize(mesh, go.texel_footprint * MedianPixelFootprint(scene, mesh, go.min_cos),
                                     go.max_atlas_size);
  EXPECT_GT(expected, 16);
  EXPECT_EQ(g.atlas.width, expected);
  go.texel_footprint = 1;  // finer texels: a larger atlas
  EXPECT_GT(Gather(scene, go).atlas.width, expected);
  go.texture_size = 24;
  EXPECT_EQ(Gather(scene, go).atlas.width, 24);
  go.texture_size = 2;
  EXPECT_THROW(Gather(scene, go), Error);
  fs::remove_all(dir);
}

TEST(Gather, BadCapturesFailClearly) {
  const std::string dir = (fs::temp_directory_path() / ("svbrdf_gather_bad_" + std::to_string(getpid()))).string();
  SynthOptions o = SynthPreset("tiny");
  o.num_images = 2;
  o.num_heldout = 0;
  Synthesize(o, dir);
  Scene scene = LoadScene(dir + "/scene.json");
  GatherOptions go;
  go.progress = false;
  // A view whose size disagrees with its camera.
  Scene wrong = scene;
  wrong.cameras[0].width += 2;
  try {
    Gather(wrong, go);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("images[0]"), std::string::npos) << e.what();
  }
  // Every photo overexposed: a half EXR clips at 65504. The error says so and
  // names the views.
  {
    const std::string sat_dir = dir + "_saturated";
    fs::remove_all(sat_dir);
    fs::copy(dir, sat_dir, fs::copy_options::recursive);
    const Scene sat = LoadScene(sat_dir + "/scene.json");
    for (const ImageEntry& e : sat.images) {
      const Image photo = ReadImage(sat.Resolve(e.file));
      WriteImage(sat.Resolve(e.file), Image(photo.width, photo.height, photo.channels, 65504.0f), PixelFormat::kHalf);
    }
    try {
      Gather(sat, go);
      FAIL() << "expected an error";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("saturated"), std::string::npos) << what;
      EXPECT_NE(what.find("images[1] (" + sat.images[1].file + ")"), std::string::npos) << what;
    }
    fs::remove_all(sat_dir);
  }
  // Mesh not in view: every camera looks away.
  Scene away = scene;
  for (auto& im : away.images) im.cam_from_world.translation.z() = -100;
  EXPECT_THROW(Gather(away, go), Error);
  fs::remove_all(dir);
}

// GatherOptions::sample_texel: only the requested texels take samples, the
// same samples an unrestricted gather gives them, and the others are not
// counted as candidates (the fine-weights stage gathers a band along the
// material borders this way).
TEST(Gather, SampleTexelGathersOnlyTheRequestedTexels) {
  const std::string dir = TinyCapture("svbrdf_gather_requested_", [](SynthOptions& o) {
    o.num_images = 6;
    o.num_heldout = 0;
  });
  const Scene scene = LoadScene(dir + "/scene.json");
  GatherOptions go;
  go.texture_size = 32;
  go.progress = false;
  const GatherResult all = Gather(scene, go);
  go.sample_texel = [](const Texel& t) { return t.x < 16; };
  const GatherResult left = Gather(scene, go);
  ASSERT_EQ(left.atlas.texels.size(), all.atlas.texels.size());
  ASSERT_GT(left.samples.size(), 100);
  EXPECT_LT(left.samples.size(), all.samples.size());
  EXPECT_LT(left.stats.candidates, all.stats.candidates);
  EXPECT_EQ(left.stats.kept, left.samples.size());
  for (int t = 0; t < left.samples.num_texels; ++t) {
    const int64_t n = left.samples.texel_begin[t + 1] - left.samples.texel_begin[t];
    if (left.atlas.texels[t].x >= 16) {
      EXPECT_EQ(n, 0) << "texel " << t;
      continue;
    }
    ASSERT_EQ(n, all.samples.texel_begin[t + 1] - all.samples.texel_begin[t]) << "texel " << t;
    for (int64_t j = 0; j < n; ++j)
      EXPECT_EQ(left.samples.y[0][left.samples.texel_begin[t] + j], all.samples.y[0][all.samples.texel_begin[t] + j]);
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace svbrdf
