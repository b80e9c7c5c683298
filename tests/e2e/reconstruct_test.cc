// End-to-end regression on small synthetic captures with exact ground truth:
// synth -> reconstruct -> relight the held-out views -> compare. Thresholds
// are on ground truth: held-out relit PSNR, chosen counts and models, cluster
// map agreement (adjusted Rand index), diffuse albedo error.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>

#include "atlas/atlas.h"
#include "brdf/fresnel.h"
#include "brdf/principled.h"
#include "core/error.h"
#include "evaluate/metrics.h"
#include "heldout.h"
#include "pipeline/reconstruction.h"
#include "relight/relight.h"
#include "synth/capture.h"
#include "synth/ground_truth.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;

struct Outcome {
  int clusters = 0;
  std::vector<std::string> labels;
  double psnr_mean = 0, psnr_min = 0;
  double ari = 0;
  double max_rd_error = 0;  // relative error of the diffuse albedo of matched basis materials
  std::vector<BasisMaterial> basis, truth;  // reconstructed basis materials, and the true one each overlaps most
};

// Normal-incidence reflectance per channel of a metal: a conductor's (any
// Fresnel form), or a metallic-roughness material's lobe (Schlick with
// F0 = 0.04 (1 - metallic) + metallic base, gltf_pbr.h).
Rgb ConductorF0Of(const BasisMaterial& b) {
  Rgb f0;
  const char* ch[3] = {"_r", "_g", "_b"};
  for (int c = 0; c < 3; ++c) {
    if (b.spec.family == Family::kGltf) {
      const double m = GetParam(b, "metallic");
      f0[c] = 0.04 * (1 - m) + m * GetParam(b, std::string("base_color") + ch[c]);
    } else if (b.spec.family == Family::kPrincipled) {  // principled.h at normal incidence
      const double m = GetParam(b, "metallic");
      const double eta = brdf::PrincipledEta(GetParam(b, "specular"));
      f0[c] = brdf::FresnelDielectric(1.0, eta) * (1 - m) + m * GetParam(b, std::string("base_color") + ch[c]);
    } else {
      f0[c] = HasParam(b, "f0_r") ? GetParam(b, std::string("f0") + ch[c])
                                  : brdf::ConductorF0(GetParam(b, std::string("eta") + ch[c]),
                                                      GetParam(b, std::string("kappa") + ch[c]));
    }
  }
  return f0;
}

// A metal: a conductor, or a metallic-roughness or principled material that
// is (nearly) all metal, whose lobe is then a Schlick conductor's with no
// diffuse.
bool IsMetal(const BasisMaterial& b) {
  return b.spec.family == Family::kConductor ||
         ((b.spec.family == Family::kGltf || b.spec.family == Family::kPrincipled) && GetParam(b, "metallic") >= 0.95);
}

// mixed_tiny: held-out PSNR measured 36.98 dB (MixedMaterialsRightCountAndMetal;
// minus 2 dB margin; 34.24 dB at 00fa9c6, before the tilt fit solved the
// weights with it; main's few-photo clustering, 34.32 dB by its commit
// d66748f, models the matte as a lambert again); the goal for the
// metal's F0 is 5 % (measured
// 2.8, 3.0, 3.2 % low in r, g, b: the brightness F0 shares with the mixing
// weights; 7 % low before main's model-selection changes at f83a319).
// With the basis polished jointly with the tilts (lib/normals/basis_polish.h):
// 44.69 dB (min 37.13), max rd error 0.017; main before it (821b142)
// 42.76 dB, max rd error 0.085. The floor is 1.7 dB below. Since the
// metallic-roughness model is a candidate the copper takes it (metallic
// 0.9999, F0 within 0.1 %): 48.33 dB (min 43.74); the floor stays.
constexpr double kMixedTinyMinPsnr = 43.0;
constexpr double kMixedTinyF0Tolerance = 0.05;
// The coated plastic's ior (true 1.5): 1.426 before the material rounds
// fitted the basis jointly with the tilts (lib/normals/basis_polish.h; the
// normals refined against a basis fitted under the mesh normals absorbed
// its error), 1.510 with it (CLI, `synth --preset mixed_tiny`; held-out
// 40.68 -> 42.04 dB there).
constexpr double kMixedTinyIorTolerance = 0.04;

std::string Scratch(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("svbrdf_e2e_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(p);
  return p.string();
}

// A reconstruction of DIR/capture into DIR/NAME without progress or report.
ReconstructionJob QuietJob(const std::string& dir, const std::string& name) {
  ReconstructionJob job;
  job.scene_path = dir + "/capture/scene.json";
  job.out_dir = dir + "/" + name;
  job.gather.progress = false;
  job.estimate.progress = false;
  job.interreflection.progress = false;
  job.report = false;
  return job;
}

Outcome RunCase(const std::string& name, SynthOptions o, ReconstructOptions ro = {}, bool strip_uvs = false) {
  const std::string dir = Scratch(name);
  Synthesize(o, dir + "/capture");
  if (strip_uvs) {  // as a scanned mesh comes: no texture coordinates
    Mesh m = LoadMesh(dir + "/capture/mesh.obj");
    m.texcoords.clear();
    m.face_uvs.clear();
    SaveObj(m, dir + "/capture/mesh.obj", /*write_normals=*/true);  // the normals it was shaded with
  }
  ReconstructionJob job;
  job.scene_path = dir + "/capture/scene.json";
  job.out_dir = dir + "/material";
  job.gather.texture_size = o.material.texture_size;
  job.gather.progress = false;
  ro.progress = getenv("SVBRDF_VERBOSE") != nullptr;
  job.estimate = ro;
  job.report = false;
  job.fine_weights = false;  // the maps are compared texel by texel with the truth's, at its resolution
  RunReconstruction(job);

  Outcome out;
  const Material rec = LoadMaterial(job.out_dir), gt = LoadMaterial(dir + "/capture/gt");
  out.clusters = static_cast<int>(rec.basis.size());
  for (const auto& b : rec.basis) out.labels.push_back(b.spec.Label());
  const SceneComparison cmp = e2e::HeldOutComparison(rec, dir + "/capture", dir + "/relit");
  out.psnr_mean = cmp.mean_psnr_srgb;
  out.psnr_min = cmp.min_psnr_srgb;

  if (strip_uvs) {  // the maps use the reconstruction's own atlas: no texel-wise comparison
    std::printf("%s: %d clusters, held-out PSNR mean %.2f min %.2f dB\n", name.c_str(), out.clusters, out.psnr_mean,
                out.psnr_min);
    fs::remove_all(dir);
    return out;
  }
  // Cluster map vs true ids over interior texels (same atlas resolution).
  const Atlas atlas = BuildAtlas(gt.mesh, gt.width, gt.height, 0);
  std::vector<int> a, b;
  std::map<int, std::map<int, int>> overlap;
  for (const Texel& t : atlas.texels) {
    const int ta = int(gt.material_id.at(t.x, t.y, 0)), tb = int(rec.material_id.at(t.x, t.y, 0));
    a.push_back(ta);
    b.push_back(tb);
    overlap[tb][ta]++;
  }
  out.ari = AdjustedRandIndex(a, b);
  // Each reconstructed basis against the true basis it overlaps most.
  for (int k = 0; k < out.clusters; ++k) {
    int best = 0, count = -1;
    for (auto& [id, n] : overlap[k])
      if (n > count) best = id, count = n;
    out.basis.push_back(rec.basis[k]);
    out.truth.push_back(gt.basis[best]);
    if (!HasParam(gt.basis[best], "rd_r") || !HasParam(rec.basis[k], "rd_r")) continue;  // metals: no diffuse
    for (const char* ch : {"rd_r", "rd_g", "rd_b"}) {
      const double truth = GetParam(gt.basis[best], ch), est = GetParam(rec.basis[k], ch);
      out.max_rd_error = std::max(out.max_rd_error, std::abs(est - truth) / std::max(0.05, truth));
    }
  }
  std::printf("%s: %d clusters (", name.c_str(), out.clusters);
  for (const auto& l : out.labels) std::printf(" %s", l.c_str());
  std::printf(" ), held-out PSNR mean %.2f min %.2f dB, ARI %.3f, max rd error %.3f\n", out.psnr_mean, out.psnr_min,
              out.ari, out.max_rd_error);
  fs::remove_all(dir);
  return out;
}

TEST(Reconstruct, TinyCaptureMeetsAccuracyThresholds) {
  const Outcome r = RunCase("tiny", SynthPreset("tiny"));
  EXPECT_EQ(r.clusters, 3);
  EXPECT_GE(r.psnr_mean, 40.0);
  EXPECT_GE(r.psnr_min, 36.0);
  EXPECT_GE(r.ari, 0.85);
  EXPECT_LE(r.max_rd_error, 0.15);
}

// Few photos (issue 8): the tiny capture with 8 photos instead of 20 keeps
// its 3 materials and their regions. Measured: 8 photos 44.67 dB (min
// 37.33), ARI 0.987; 20 photos 52.88 dB (min 51.31); with the basis refit
// on the weights (basis_refit.h) 8 photos 44.71, 20 photos 54.84 dB: the
// refit gains where the samples pin the materials. Before (texels needed 3
// training samples to take part, unseen texels kept stale labels, one
// hold-out for the model choice) 8 photos gave 2 materials at 27.60 dB. The
// issue's 3 dB is met on the default preset (bench_results/stability_images:
// 44.08 vs 45.55 dB); tiny's 160 x 120 photos at 8 of 20 lose more (8.2 dB,
// the worst view a dark spot in one region; 10.1 dB since the refit raised
// the 20-photo result), hence the wider bound here.
TEST(Reconstruct, FewPhotosKeepTheMaterialsAndCostLittle) {
  SynthOptions few = SynthPreset("tiny");
  few.num_images = 8;
  const Outcome r8 = RunCase("few8", few);
  const Outcome r20 = RunCase("few20", SynthPreset("tiny"));
  EXPECT_EQ(r8.clusters, 3);
  EXPECT_EQ(r20.clusters, 3);
  EXPECT_GE(r8.ari, 0.95);
  EXPECT_GE(r8.psnr_mean, 42.5);
  EXPECT_LE(r20.psnr_mean - r8.psnr_mean, 11.0);
}

TEST(Reconstruct, ChoosesOneAndFiveMaterialsWhenThatIsTheTruth) {
  for (int k : {1, 5}) {
    SynthOptions o = SynthPreset("tiny");
    o.material.num_materials = k;
    const Outcome r = RunCase("count" + std::to_string(k), o);
    EXPECT_EQ(r.clusters, k) << "true count " << k;
    EXPECT_GE(r.psnr_mean, 36.0);
  }
}

TEST(Reconstruct, SingleLobeTruthGetsNoExtraLobes) {
  SynthOptions o = SynthPreset("tiny");
  o.material.num_materials = 1;
  o.material.models = {"lafortune-1"};
  const Outcome r = RunCase("onelobe", o);
  ASSERT_EQ(r.clusters, 1);
  EXPECT_EQ(r.labels[0], "lafortune-1");
}

TEST(Reconstruct, MeshWithoutTextureCoordinatesGetsItsOwnAtlas) {
  // The no-UV case on a sphere: the same capture without texture
  // coordinates (chart atlas at the photos' resolution). The 1 dB criterion
  // of the issue is asserted on a real scan (ScannedMeshWithoutUvsMatchesItsUvTwin).
  // Here the two runs differ by a model-selection near-tie, not the atlas:
  // measured UV 52.61 dB (cluster 1 Cook-Torrance), no UVs 50.56 dB (cluster
  // 1 Lafortune: held-out 0.005081 vs Cook-Torrance 0.0050555 with its ior at
  // the bound, which the tie rule sets back). Before the new weights both
  // were 46.08 / 45.26 dB. Since border texels of generated atlases take no
  // samples (GatherOptions::border_texel_samples): no UVs 50.37 dB (52.68
  // with them: interior texels at chart borders lose their neighbours'
  // support in the weights; the Mitsuba bunny gains 4.7 dB without them).
  const Outcome with_uvs = RunCase("uv", SynthPreset("tiny"));
  const Outcome r = RunCase("nouv", SynthPreset("tiny"), {}, true);
  EXPECT_EQ(r.clusters, 3);
  EXPECT_GE(with_uvs.psnr_mean, 48.0);
  EXPECT_GE(r.psnr_mean, 48.0);
  EXPECT_GE(r.psnr_mean, with_uvs.psnr_mean - 2.5);
}

// Measured on main (texel footprint 2): UV twin 36.14 dB, without UVs
// 36.11 dB, 3 clusters each; ~35 s CPU for the test. With border texels
// unsampled, filled from their surface neighbours, and small charts merged
// (branch bunny): UV twin 36.19 dB, without UVs 38.81 dB (32.65 dB with the
// border texels unsampled but the old fill: charts of one sliver triangle
// had no texel with a value and relit black). The no-UV case needs
// the per-material normal decision's total-error guard (lib/normals): without
// it a material kept by a hair cost 4 dB (31.91).
TEST(Reconstruct, ScannedMeshWithoutUvsMatchesItsUvTwin) {
  // A real scan (Stanford bunny from CGAL's data, 2.7 k triangles): painted
  // by synth on a chart atlas; reconstructed once with those UVs and once
  // from the bare mesh.
  SynthOptions o = SynthPreset("tiny");
  o.mesh_file = std::string(SVBRDF_SOURCE_DIR) + "/tests/data/bunny_3k.obj";
  o.material.texture_size = 256;
  const Outcome with_uvs = RunCase("scan_uv", o, {}, false);
  const Outcome r = RunCase("scan_nouv", o, {}, true);
  EXPECT_GE(with_uvs.psnr_mean, 30.0);
  EXPECT_EQ(r.clusters, 3);
  EXPECT_GE(r.psnr_mean, with_uvs.psnr_mean - 1.0);
}

TEST(Reconstruct, TimeBudgetGivesACompleteMaterial) {
  // A budget far below what the reconstruction needs: the result must still
  // be a complete, valid material folder that relights (not a timed test).
  const std::string dir = Scratch("budget");
  Synthesize(SynthPreset("tiny"), dir + "/capture");
  ReconstructionJob job;
  job.scene_path = dir + "/capture/scene.json";
  job.out_dir = dir + "/material";
  job.gather.progress = false;
  job.estimate.progress = false;
  job.time_budget_s = 0.01;
  const nlohmann::json summary = RunReconstruction(job);
  ASSERT_TRUE(summary.contains("cut_by_time_budget"));
  EXPECT_FALSE(summary["cut_by_time_budget"].empty());
  EXPECT_TRUE(fs::exists(job.out_dir + "/report/summary.json"));
  const Material m = LoadMaterial(job.out_dir);
  ASSERT_GE(m.basis.size(), 1u);
  EXPECT_GT(e2e::HeldOutComparison(m, dir + "/capture", dir + "/relit").mean_psnr_srgb, 20.0);
  job.time_budget_s = -1;
  EXPECT_THROW(RunReconstruction(job), Error);
  fs::remove_all(dir);
}

// The fine-weights stage (pipeline/fine_weights_stage.h) on a capture whose
// material borders are sharp on a 256^2 map: the reconstruction without and
// with the stage (`adjust` sets the atlas of both), checked for what both
// tests below expect: the stage tried and kept by its held-out error, the
// same basis materials and sample counts, the maps finer (at most twice the
// side), and the held-out views relit better by more than 1 dB.
void CheckFineWeightsGain(const std::string& name, bool mesh_uvs, const std::function<void(ReconstructionJob&)>& adjust) {
  const std::string dir = Scratch(name);
  SynthOptions o = SynthPreset("tiny");
  o.material.texture_size = 256;
  o.material.blend = 0.005;  // metres: borders far sharper than the search's texels (~0.1 m on this 0.5 m sphere)
  o.mesh_uvs = mesh_uvs;
  Synthesize(o, dir + "/capture");
  auto run = [&](bool fine, const std::string& out, nlohmann::json* summary) {
    ReconstructionJob job;
    job.scene_path = dir + "/capture/scene.json";
    job.out_dir = dir + "/" + out;
    job.gather.progress = false;
    job.estimate.progress = false;
    adjust(job);
    job.fine_weights = fine;
    *summary = RunReconstruction(job);
    return LoadMaterial(job.out_dir);
  };
  nlohmann::json coarse_summary, fine_summary;
  const Material coarse = run(false, "coarse", &coarse_summary), fine = run(true, "fine", &fine_summary);
  ASSERT_TRUE(fine_summary["fine_weights"]["tried"].get<bool>());
  EXPECT_TRUE(fine_summary["fine_weights"]["kept"].get<bool>());
  EXPECT_LT(fine_summary["fine_weights"]["heldout_rmse_fine"].get<double>(),
            fine_summary["fine_weights"]["heldout_rmse_coarse"].get<double>());
  EXPECT_FALSE(coarse_summary["fine_weights"]["tried"].get<bool>());
  EXPECT_EQ(fine_summary["made_uvs"].get<bool>(), !mesh_uvs);
  EXPECT_GT(fine.width, coarse.width);
  EXPECT_LE(fine.width, 2 * coarse.width);
  // The summary's sample counts stay the search's (the fits saw those).
  EXPECT_EQ(fine_summary["samples"]["kept"].get<long>(), coarse_summary["samples"]["kept"].get<long>());
  ASSERT_EQ(fine.basis.size(), coarse.basis.size());
  for (size_t k = 0; k < fine.basis.size(); ++k) EXPECT_EQ(fine.basis[k].spec.Label(), coarse.basis[k].spec.Label());
  const double psnr_coarse = e2e::HeldOutComparison(coarse, dir + "/capture", dir + "/relit_coarse").mean_psnr_srgb;
  const double psnr_fine = e2e::HeldOutComparison(fine, dir + "/capture", dir + "/relit_fine").mean_psnr_srgb;
  std::printf("%s: %d^2 -> %d^2, held-out PSNR %.2f -> %.2f dB\n", name.c_str(), coarse.width, fine.width,
              psnr_coarse, psnr_fine);
  EXPECT_GT(psnr_fine, psnr_coarse + 1.0);
  fs::remove_all(dir);
}

// A mesh with texture coordinates searched on a 32^2 atlas; the band along
// the borders is gathered again on the automatic atlas at one pixel
// footprint a texel (about 200^2 at 160x120, capped at twice the side: 64^2).
TEST(Reconstruct, FineWeightsDrawSharpBordersFinerThanTheSearchAtlas) {
  CheckFineWeightsGain("fine_weights", true, [](ReconstructionJob& job) {
    job.gather.texture_size = 32;
    EXPECT_EQ(job.fine.texel_footprint, 1.0);  // the default
  });
}

// The same on a mesh without texture coordinates (a scan): its chart atlas
// has texels of 4 pixel footprints here, the band is gathered again on a
// chart atlas of 2-footprint texels.
TEST(Reconstruct, FineWeightsOnAChartAtlasDrawSharpBordersFiner) {
  CheckFineWeightsGain("fine_weights_charts", false, [](ReconstructionJob& job) {
    job.gather.texel_footprint = 4;
    job.fine.texel_footprint = 2;
  });
}

// The fine weights' gate by medians (fine_weights_stage.cc): on the demo's
// capture (the default preset) the metal's highlight texels hold most of the
// interiors' mean held-out error, so by means the borders look no worse than
// the interiors; by medians they are over twice as bad, and the stage, tried,
// is kept by its held-out error.
TEST(Reconstruct, FineWeightsGateSeesBordersThatAHighlightHidesFromTheMean) {
  const std::string dir = Scratch("fine_gate");
  Synthesize(SynthPreset("default"), dir + "/capture");
  const nlohmann::json f = RunReconstruction(QuietJob(dir, "material"))["fine_weights"];
  std::printf("border error x the interior's: mean %.3f, median %.3f; fine %.6g vs coarse %.6g\n",
              f["border_excess"].get<double>(), f["border_excess_median"].get<double>(),
              f["heldout_rmse_fine"].get<double>(), f["heldout_rmse_coarse"].get<double>());
  EXPECT_LT(f["border_excess"].get<double>(), 2.0);
  EXPECT_GE(f["border_excess_median"].get<double>(), 2.0);
  ASSERT_TRUE(f["tried"].get<bool>());
  EXPECT_TRUE(f["kept"].get<bool>());
  EXPECT_LT(f["heldout_rmse_fine"].get<double>(), f["heldout_rmse_coarse"].get<double>());
  fs::remove_all(dir);
}

// Checks the basis material(s) matched to the true metal: recognised as a
// metal (IsMetal), normal-incidence reflectance within `tolerance` (relative).
// Returns how many reconstructed materials matched the metal.
int CheckMetal(const Outcome& r, double tolerance) {
  int metals = 0;
  for (size_t k = 0; k < r.basis.size(); ++k) {
    if (r.truth[k].spec.family != Family::kConductor) continue;
    ++metals;
    EXPECT_TRUE(IsMetal(r.basis[k])) << r.basis[k].spec.Label();
    if (!IsMetal(r.basis[k])) continue;
    const Rgb f0 = ConductorF0Of(r.basis[k]), f0_true = ConductorF0Of(r.truth[k]);
    std::printf("metal: %s, F0 fitted %.4f %.4f %.4f, true %.4f %.4f %.4f\n", r.basis[k].spec.Label().c_str(), f0[0],
                f0[1], f0[2], f0_true[0], f0_true[1], f0_true[2]);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(f0[c], f0_true[c], tolerance * f0_true[c]) << "channel " << c;
  }
  return metals;
}

// Model selection recognises a metal: rough copper alone (mixed_tiny's metal,
// no bump map). Measured: conductor-ggx-schlick, F0 within 0.1 % of
// ConductorF0(eta, kappa) of copper, roughness 0.2006 (true 0.2), held-out
// 63.5 dB.
TEST(Reconstruct, MetalIsRecognisedAsConductor) {
  SynthOptions o = SynthPreset("mixed_tiny");
  o.material.num_materials = 1;
  o.material.models.resize(1);
  o.material.params.resize(1);
  o.material.bump = 0;
  ReconstructOptions ro;
  ro.force_clusters = 1;
  const Outcome r = RunCase("metal", o, ro);
  ASSERT_EQ(r.clusters, 1);
  EXPECT_EQ(CheckMetal(r, 0.02), 1);
  EXPECT_GE(r.psnr_mean, 55.0);
}

// A torus, half `metal_model` (a reflecting metal), half a lit diffuse paint,
// rendered with two bounces: the metal shows the other side of the ring.
SynthOptions MetalBesidePaintTorus(const std::string& metal_model, int bounce_samples) {
  SynthOptions o = SynthPreset("tiny");
  o.object = "torus";
  o.detail = 64;
  o.num_images = 24;
  o.num_heldout = 4;
  o.seed = 5;
  o.bounces = 2;
  o.bounce_samples = bounce_samples;
  o.material.num_materials = 2;
  o.material.models = {metal_model, "lambert"};
  o.material.params.resize(2);
  o.material.params[1].values = {{"rd_r", 0.6}, {"rd_g", 0.5}, {"rd_b", 0.4}};
  return o;
}

// The interreflection's second pass (pipeline/interreflection_stage.h): a
// copper torus beside a diffuse one, rendered with two bounces. Inside the
// ring the copper shows a blurred image of the opposite side, which the
// first (Lambertian-receiver) pass leaves in its samples; without the
// second pass the fits gave it a third material (measured on this capture:
// 3 materials, 32.18 dB without; 2, 32.24 dB with, relit with 2 bounces).
TEST(Reconstruct, GlossySelfReflectionIsNotTakenForAMaterial) {
  SynthOptions o = MetalBesidePaintTorus("conductor-ggx", 16);
  o.material.params[0].metal = "copper";
  o.material.params[0].values = {{"roughness", 0.15}};
  const std::string dir = Scratch("glossy_torus");
  Synthesize(o, dir + "/capture");
  const Scene held = LoadScene(dir + "/capture/heldout/scene.json");
  auto run = [&](bool second_pass, const std::string& name, nlohmann::json* summary) {
    ReconstructionJob job = QuietJob(dir, name);
    job.interreflection.refit = second_pass;
    *summary = RunReconstruction(job);
    const Material m = LoadMaterial(job.out_dir);
    RelightOptions rl;
    rl.progress = false;
    rl.bounces = 2;
    RelightScene(m, held, dir + "/relit_" + name, rl);
    return std::pair<int, double>(int(m.basis.size()), CompareToScene(held, dir + "/relit_" + name).mean_psnr_srgb);
  };
  nlohmann::json with_summary, without_summary;
  const auto [with_count, with_psnr] = run(true, "with", &with_summary);
  const auto [without_count, without_psnr] = run(false, "without", &without_summary);
  std::printf("second pass: %d materials, %.2f dB; without: %d materials, %.2f dB\n", with_count, with_psnr,
              without_count, without_psnr);
  EXPECT_EQ(with_count, 2);
  EXPECT_GE(with_psnr, without_psnr - 0.1);
  EXPECT_GT(with_summary["interreflection"]["second_pass"]["changed_share"].get<double>(), 0.005);
  EXPECT_TRUE(without_summary["interreflection"]["second_pass"].is_null());
  fs::remove_all(dir);
}

// A polished metal (the mirror model) on a torus whose other half is a
// lit diffuse paint: the photos show the mirror only through what it
// reflects. The mirror stage recognises it with its F0 (its held-out test
// without the worst 2 % of texels, as the split search's). With the
// reflection integrated over each pixel (--mirror-lookup-rays n) this
// renderer's photos push F0 up and the mirror loses its test (n = 2: F0
// 0.95 / 0.73 / 0.52, not taken), while on a Mitsuba torus n = 2 came
// closer to the truth: the comparison stays here to tell when that changes.
TEST(Reconstruct, PolishedMetalIsRecognisedByWhatItReflects) {
  SynthOptions o = MetalBesidePaintTorus("mirror", 8);
  o.material.params[0].values = {{"f0_r", 0.9}, {"f0_g", 0.7}, {"f0_b", 0.5}};
  const std::string dir = Scratch("polished_torus");
  Synthesize(o, dir + "/capture");
  auto run = [&](int lookup_rays, const std::string& name) {
    ReconstructionJob job = QuietJob(dir, name);
    job.mirror.lookup_rays = lookup_rays;
    const nlohmann::json summary = RunReconstruction(job);
    const Material m = LoadMaterial(job.out_dir);
    double f0_error = 1.0;  // of the mirror, largest over the channels
    for (const BasisMaterial& b : m.basis)
      if (b.spec.family == Family::kMirror)
        f0_error = std::max({std::abs(b.params[0] - 0.9), std::abs(b.params[1] - 0.7), std::abs(b.params[2] - 0.5)});
    std::printf("lookup rays %d: %s; mirror F0 error %.3f\n", lookup_rays, summary["mirrors"].dump().c_str(),
                f0_error);
    return std::make_pair(summary["mirrors"]["replaced"].get<int>(), f0_error);
  };
  const auto [replaced, f0_error] = run(0, "default");
  EXPECT_EQ(replaced, 1);
  EXPECT_LT(f0_error, 0.05);
  const auto [replaced_integrated, f0_error_integrated] = run(2, "integrated");
  EXPECT_GT(f0_error_integrated, f0_error);  // (see above; 1 when not taken)
  (void)replaced_integrated;
  fs::remove_all(dir);
}

// Real materials (issue 8): rough copper, a coated plastic and matte paint
// with soft borders and a bump map (mixed_tiny), with the whole default
// pipeline: the right count, the copper recognised as a conductor with F0
// within the 5 %, and a held-out PSNR floor. History: 1-2 basis
// materials and 23-26.7 dB at e6a5456; 3 materials but the copper a
// Cook-Torrance (rs at its bound 1) and 31.3 dB at f9b9b4c (this test was
// disabled then). Measured at the per-material normal decision with main
// at f83a319 merged: 3 materials (coated-ggx, coated-ggx,
// conductor-ggx-schlick, F0 within 3.2 %), 34.24 dB (min 27.95), ARI 0.983,
// 15 s CPU. The floor is 2 dB below; the 45 dB is for the standard size, and on
// this capture the true material relit with mesh normals scores 32.05 dB
// (bench_results/mixed.md, "Where the error goes"): the copper's bumps are
// what is left.
TEST(Reconstruct, MixedMaterialsRightCountAndMetal) {
  const Outcome r = RunCase("mixed_tiny", SynthPreset("mixed_tiny"));
  EXPECT_EQ(r.clusters, 3);
  EXPECT_EQ(CheckMetal(r, kMixedTinyF0Tolerance), 1);
  EXPECT_GE(r.psnr_mean, kMixedTinyMinPsnr);
  int coated = 0;
  for (size_t k = 0; k < r.basis.size() && k < r.truth.size(); ++k) {
    if (!HasParam(r.basis[k], "ior") || r.truth[k].spec.Label() != r.basis[k].spec.Label()) continue;
    ++coated;
    std::printf("coated plastic: ior %.4f (true %.4f)\n", GetParam(r.basis[k], "ior"), GetParam(r.truth[k], "ior"));
    EXPECT_NEAR(GetParam(r.basis[k], "ior"), GetParam(r.truth[k], "ior"), kMixedTinyIorTolerance);
  }
  EXPECT_EQ(coated, 1);
}

// The mixed preset at its standard size puts the copper on top, so the
// split search's control split (halves by the texels' light / view / half
// elevations) halves the materials too (77 % of the texels as the copper /
// paint candidate does). Unrefined, that control gained within 1.3 % of
// the candidate and the search kept 2 materials of 3 (22.2 dB); a control
// confounded with its candidate is now refined before they are compared
// (split_search.cc): 3 of 3, 48.55 dB (min 46.07) measured. Floor 3.5 dB below.
TEST(Reconstruct, MaterialsConfoundedWithElevationAreKept) {
  const Outcome r = RunCase("mixed", SynthPreset("mixed"));
  EXPECT_EQ(r.clusters, 3);
  EXPECT_EQ(CheckMetal(r, kMixedTinyF0Tolerance), 1);
  EXPECT_GE(r.psnr_mean, 45.0);
}

TEST(Reconstruct, ForcedModelAndCountAreHonoured) {
  ReconstructOptions ro;
  ro.force_model = "lafortune-2";
  ro.force_clusters = 2;
  const Outcome r = RunCase("forced", SynthPreset("tiny"), ro);
  ASSERT_EQ(r.clusters, 2);
  for (const auto& l : r.labels) EXPECT_EQ(l, "lafortune-2");
}

}  // namespace
}  // namespace svbrdf
