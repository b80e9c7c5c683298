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

}  // namespace
}  // namespace svbrdf
