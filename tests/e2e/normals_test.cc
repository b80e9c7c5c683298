// End to end: normal refinement on a small bump-mapped capture (the default
// preset's sphere and materials, with a ground-truth normal map, at test size):
// the held-out relit error with refined normals is lower than without, the
// refined normals are closer to the truth than the mesh normals, and the
// material folder carries the normal map that relight uses.
#include <gtest/gtest.h>

#include <filesystem>

#include "atlas/atlas.h"
#include "evaluate/metrics.h"
#include "heldout.h"
#include "normals/normal_map.h"
#include "io/scene.h"
#include "pipeline/normal_stage.h"
#include "pipeline/reconstruction.h"
#include "synth/capture.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;

struct Outcome {
  double psnr = 0;
  nlohmann::json summary;
  Material material;
};

Outcome Reconstruct(const std::string& dir, const std::string& mode) {
  ReconstructionJob job;
  job.scene_path = dir + "/capture/scene.json";
  job.out_dir = dir + "/material_" + mode;
  job.gather.texture_size = 64;
  job.gather.progress = false;
  job.estimate.progress = getenv("SVBRDF_VERBOSE") != nullptr;
  // Kept small for a fast test: the count is given (the split search is
  // tested elsewhere), three candidate models, fewer samples per fit.
  job.estimate.force_clusters = 3;
  job.estimate.candidate_models = {"lambert", "lafortune-1", "cook_torrance-beckmann"};
  job.estimate.fit.max_samples = 5000;
  job.normals.mode = mode;
  job.report = false;
  Outcome r;
  r.summary = RunReconstruction(job);
  r.material = LoadMaterial(job.out_dir);
  r.psnr = e2e::HeldOutComparison(r.material, dir + "/capture", dir + "/relit_" + mode).mean_psnr_srgb;
  return r;
}

TEST(NormalRefinement, LowersHeldOutErrorOnABumpMappedCapture) {
  const std::string dir = (fs::temp_directory_path() / ("svbrdf_e2e_normals_" + std::to_string(getpid()))).string();
  fs::remove_all(dir);
  SynthOptions o = SynthPreset("default");
  o.width = 160, o.height = 120;
  o.num_images = 20;
  o.num_heldout = 3;
  o.spp = 1;
  o.material.texture_size = 64;
  o.material.bump = 0.15;
  Synthesize(o, dir + "/capture");

  const Outcome off = Reconstruct(dir, "off");
  const Outcome on = Reconstruct(dir, "on");
  std::printf("held-out PSNR: mesh normals %.2f dB, refined %.2f dB; %s\n", off.psnr, on.psnr,
              on.summary["normals"].dump().c_str());
  EXPECT_EQ(off.material.normal_map.width, 0);
  ASSERT_TRUE(on.summary["normals"]["kept"].get<bool>());
  ASSERT_EQ(on.material.normal_map.width, 64);
  EXPECT_GT(on.psnr, off.psnr + 1.0);

  // Normals against the truth, over texels with their own normal.
  const Material truth = LoadMaterial(dir + "/capture/gt");
  const Atlas atlas = BuildAtlas(on.material.mesh, 64, 64, 0);
  std::vector<Vec3> refined, mesh;
  for (const Texel& tx : atlas.texels) {
    refined.push_back(MaterialNormal(on.material, tx, atlas));
    mesh.push_back(tx.normal);
  }
  const NormalErrors er = CompareNormals(atlas, refined, truth), em = CompareNormals(atlas, mesh, truth);
  std::printf("normal error: refined mean %.2f median %.2f deg, mesh mean %.2f median %.2f deg\n", er.mean_deg,
              er.median_deg, em.mean_deg, em.median_deg);
  EXPECT_LT(er.median_deg, 0.5 * em.median_deg);
  fs::remove_all(dir);
}

// The photo check of a kept normal map (pipeline/normal_stage.h): on a
// bump-mapped capture the refined normals' map lowers the held-out photos'
// error, a map tilted 8 degrees everywhere raises it.
TEST(NormalRefinement, PhotoCheckTellsARightMapFromAWrongOne) {
  const std::string dir = (fs::temp_directory_path() / ("svbrdf_e2e_photo_check_" + std::to_string(getpid()))).string();
  fs::remove_all(dir);
  SynthOptions o = SynthPreset("default");
  o.width = 160, o.height = 120;
  o.num_images = 20;
  o.num_heldout = 1;
  o.spp = 1;
  o.material.texture_size = 64;
  o.material.bump = 0.15;
  Synthesize(o, dir + "/capture");
  const Scene scene = LoadScene(dir + "/capture/scene.json");
  GatherOptions go;
  go.texture_size = 64;
  go.progress = false;
  const GatherResult g = Gather(scene, go);
  ReconstructOptions eo;
  eo.progress = false;
  eo.force_clusters = 3;
  eo.candidate_models = {"lambert", "lafortune-1", "cook_torrance-beckmann"};
  eo.fit.max_samples = 5000;
  const SvbrdfEstimate est = EstimateSvbrdf(g.samples, g.atlas, eo);
  NormalOptions no;
  no.mode = "force";
  no.progress = false;
  no.holdout_fraction = eo.holdout_fraction;
  no.seed = eo.seed;
  NormalRefinement nr = RefineNormals(g.samples, g.atlas, est, no);
  SvbrdfEstimate refined = est;
  refined.weights = nr.weights;
  const PhotoCheck right = CheckNormalMapOnPhotos(scene, g, eo, est, refined, nr);
  for (size_t t = 0; t < g.atlas.texels.size(); ++t) {
    const Texel& tx = g.atlas.texels[t];
    const Frame f = Frame::FromNormalTangent(tx.normal, tx.tangent);
    nr.normal[t] = f.ToWorld(Vec3(std::tan(8.0 * kPi / 180), 0, 1).normalized());
  }
  const PhotoCheck wrong = CheckNormalMapOnPhotos(scene, g, eo, est, est, nr);
  std::printf("photo check on %d photos: without a map %g, refined map %g, tilted map %g\n", right.photos,
              right.error_without_map, right.error_with_map, wrong.error_with_map);
  ASSERT_GT(right.photos, 0);
  EXPECT_LT(right.error_with_map, 0.8 * right.error_without_map);
  EXPECT_GT(wrong.error_with_map, 1.5 * wrong.error_without_map);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace svbrdf
