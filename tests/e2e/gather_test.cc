// Gathered samples agree with the ground truth that rendered the capture:
// catches any disagreement of frames, conventions or light units between
// synth/relight and gather.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/error.h"
#include "gather/gather.h"
#include "relight/shader.h"
#include "synth/capture.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;

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
    const Vec2 uv((tx.x + 0.5) / g.atlas.width, 1.0 - (tx.y + 0.5) / g.atlas.height);
    const Frame f = Frame::FromNormalTangent(tx.normal, tx.tangent);
    const Vec3 wi(g.samples.wi[0][i], g.samples.wi[1][i], g.samples.wi[2][i]);
    const Vec3 wo(g.samples.wo[0][i], g.samples.wo[1][i], g.samples.wo[2][i]);
    const Rgb pred = shader.Eval(uv, f, f.ToWorld(wi), f.ToWorld(wo)) * g.samples.geom[i];
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
  // Mesh not in view: every camera looks away.
  Scene away = scene;
  for (auto& im : away.images) im.cam_from_world.translation.z() = -100;
  EXPECT_THROW(Gather(away, go), Error);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace svbrdf
