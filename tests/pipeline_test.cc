// report.html: one self-contained page from a reconstruction's summary and pictures.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "core/error.h"
#include "io/files.h"
#include "io/image.h"
#include "core/rng.h"
#include "fit/fit.h"
#include "pipeline/merge_stage.h"
#include "pipeline/mirror_stage.h"
#include "pipeline/normal_stage.h"
#include "pipeline/reconstruction.h"
#include "pipeline/report_html.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;

// An option out of range is named before any work: not after the capture
// was read and gathered (here the capture does not even exist).
TEST(Reconstruction, OptionsAreCheckedBeforeTheCaptureIsRead) {
  ReconstructionJob job;
  job.scene_path = "/nonexistent/scene.json";
  job.out_dir = (fs::temp_directory_path() / "svbrdf_options_checked_first").string();
  job.estimate.core_fit_rings = 9;
  try {
    RunReconstruction(job);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("core fit rings must be in [0, 8], got 9"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(job.out_dir));
}

TEST(ReportHtml, HasMapsTwinTimingsModelsAndWarnings) {
  const std::string dir = ::testing::TempDir() + "/report_html_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (const char* f : {"cluster_map.png", "weights_m0.png", "confidence.png", "residual.png", "heldout_photo.png",
                        "heldout_relit.png", "heldout_error.png"})
    WriteImage(dir + "/" + f, Image(4, 4, 3, 0.25f), PixelFormat::kUInt8, ColorSpace::kLinear);
  const nlohmann::json summary = {
      {"scene", "cap/scene.json"}, {"texels", 100}, {"texture_size", 16}, {"clusters", 1}, {"weights", "per_channel"},
      {"heldout_rmse", 0.01},
      {"samples", {{"kept", 5}, {"candidates", 100}, {"saturated", 20}}},
      {"basis", {{{"name", "m0"}, {"label", "lambert"}, {"params", {{"rd_r", 0.5}, {"rd_g", 0.25}, {"rd_b", 0.125}}}}}},
      {"twin", {{"view", "images/0000.exr"}, {"psnr_srgb", 25.0}, {"rel_rmse_linear", 0.1}, {"kind", "held-out view"}}},
      {"timings_s", {{"gather samples", 1.5}, {"fit + cluster", 7.25}}},
      {"total_s", 8.75},
      {"warnings", {"a warning from a stage"}}};
  const std::vector<std::string> w = ReportWarnings(summary);
  EXPECT_EQ(w.size(), 5u);  // the stage's own + few kept + saturated + low PSNR + one cluster
  WriteReportHtml(summary, dir);
  const std::string html = ReadFileBytes(dir + "/report.html");
  for (const char* s : {"cluster map", "weights of m0", "confidence", "residual", "photo", "relit", "gather samples",
                        "7.25", "lambert", "rd_r = 0.5", "a warning from a stage", "only 5.0 % of the candidate"})
    EXPECT_NE(html.find(s), std::string::npos) << s;
  size_t images = 0;
  for (size_t p = html.find("data:image/png;base64,"); p != std::string::npos; p = html.find("data:image/png;base64,", p + 1)) ++images;
  EXPECT_EQ(images, 7u);
  fs::remove_all(dir);
}

BasisMaterial Material(const std::string& label, const std::vector<double>& params) {
  BasisMaterial m;
  m.spec = ModelSpec::FromLabel(label);
  m.params = params.empty() ? m.spec.InitialParams() : params;
  return m;
}

// Merging material `from` into `into`: labels moved, higher indices shifted
// down, the larger cluster's material kept as the refit's start.
// A stage entered twice ("fit + cluster" around the interreflection's
// second pass) reports the sum of both entries, not the last one.
TEST(ReportHtml, StageTimesSumAStageEnteredTwice) {
  StageTimer timer;
  timer.Start("fit");
  timer.Start("gather");
  timer.Start("fit");
  volatile double sink = 0;
  for (int i = 0; i < 2000000; ++i) sink = sink + std::sqrt(double(i));  // CPU time in the second entry
  timer.Stop();
  ASSERT_EQ(timer.stages().size(), 3u);
  nlohmann::json summary;
  AddStageTimes(timer, &summary);
  const auto& st = timer.stages();
  EXPECT_DOUBLE_EQ(summary["timings_s"]["fit"].get<double>(), st[0].seconds + st[2].seconds);
  EXPECT_DOUBLE_EQ(summary["cpu_s"]["fit"].get<double>(), st[0].cpu_seconds + st[2].cpu_seconds);
  EXPECT_GT(summary["timings_s"]["fit"].get<double>(), st[0].seconds);
  EXPECT_DOUBLE_EQ(summary["timings_s"]["gather"].get<double>(), st[1].seconds);
  EXPECT_EQ(summary["timings_s"].size(), 2u);
}

TEST(MergeStage, MergedEstimateRelabelsAndKeepsTheLargerClustersMaterial) {
  SvbrdfEstimate est;
  est.basis = {Material("lambert", {0.1, 0.1, 0.1}), Material("lambert", {0.2, 0.2, 0.2}),
               Material("lambert", {0.3, 0.3, 0.3})};
  est.label = {0, 1, 2, 2, 1};
  est.weights.assign(5 * 3 * 3, 0.5f);
  SvbrdfEstimate m = WithMaterialsMerged(est, 0, 2);
  EXPECT_EQ(m.label, (std::vector<int>{0, 1, 0, 0, 1}));
  ASSERT_EQ(m.basis.size(), 2u);
  EXPECT_DOUBLE_EQ(m.basis[0].params[0], 0.3);  // material 2 had more texels
  EXPECT_DOUBLE_EQ(m.basis[1].params[0], 0.2);
  EXPECT_TRUE(m.weights.empty());
  m = WithMaterialsMerged(est, 2, 0);
  EXPECT_EQ(m.label, (std::vector<int>{1, 0, 1, 1, 0}));
  ASSERT_EQ(m.basis.size(), 2u);
  EXPECT_DOUBLE_EQ(m.basis[1].params[0], 0.3);
  EXPECT_THROW(WithMaterialsMerged(est, 1, 1), Error);
  EXPECT_THROW(WithMaterialsMerged(est, 0, 3), Error);
}

// The merge screen's second label map: texels with an 8-neighbour of another
// label (blend zones, borders) are left out (-1), region interiors kept.
TEST(MergeStage, InteriorLabelsDropTexelsNextToAnotherLabel) {
  Atlas atlas;
  atlas.width = 4, atlas.height = 3;
  atlas.index.assign(12, -1);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) {
      Texel tx;
      tx.x = x, tx.y = y;
      atlas.index[y * 4 + x] = int(atlas.texels.size());
      atlas.texels.push_back(tx);
    }
  // Columns 0-2 label 0, column 3 label 1.
  std::vector<int> label(12, 0);
  for (int y = 0; y < 3; ++y) label[y * 4 + 3] = 1;
  const std::vector<int> in = InteriorLabels(atlas, label);
  for (int y = 0; y < 3; ++y) {
    EXPECT_EQ(in[y * 4 + 0], 0);
    EXPECT_EQ(in[y * 4 + 1], 0);
    EXPECT_EQ(in[y * 4 + 2], -1);  // next to column 3
    EXPECT_EQ(in[y * 4 + 3], -1);
  }
  label[3] = 0;  // texel (3, 0) now label 0: column 3's others stay next to it
  const std::vector<int> in2 = InteriorLabels(atlas, label);
  EXPECT_EQ(in2[7], -1);
  EXPECT_EQ(in2[0], 0);
}

// Samples of `per` texels per label, 12 photos each (random directions,
// 1 % noise), rendered with the label's material.
SampleSet SamplesOf(const std::vector<BasisMaterial>& truth, const std::vector<int>& label, uint64_t seed) {
  SampleSet s;
  s.num_texels = int(label.size());
  s.texel_begin.push_back(0);
  Rng rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.01);
  auto dir = [&](float* d) {
    const double z = 0.2 + 0.8 * u(rng), phi = 6.283185307 * u(rng), r = std::sqrt(1 - z * z);
    d[0] = float(r * std::cos(phi)), d[1] = float(r * std::sin(phi)), d[2] = float(z);
  };
  for (size_t t = 0; t < label.size(); ++t) {
    for (int j = 0; j < 12; ++j) {
      float wi[3], wo[3], y[3] = {0, 0, 0};
      dir(wi), dir(wo);
      s.Push(int32_t(t), j, wi, wo, wi[2], y);
      const BasisMaterial& m = truth[label[t]];
      const Rgb p = PredictSample(m.spec, m.params.data(), s, s.size() - 1);
      for (int c = 0; c < 3; ++c) s.y[c].back() = float(p[c] * (1.0 + noise(rng)));
    }
    s.texel_begin.push_back(s.size());
  }
  return s;
}

// One material split into two clusters (given slightly different starting
// materials) tests as one; two materials test as two.
TEST(MergeStage, OneMaterialInTwoClustersMergesTwoMaterialsDoNot) {
  const BasisMaterial red = Material("lambert", {0.6, 0.2, 0.1}), blue = Material("lambert", {0.1, 0.2, 0.6});
  std::vector<int> label(60);
  for (int t = 0; t < 60; ++t) label[t] = t < 30 ? 0 : 1;
  std::vector<char> held(12, 0);
  held[3] = held[8] = 1;
  FitOptions fo;
  fo.threads = 1;
  const std::vector<BasisMaterial> start = {Material("lambert", {0.5, 0.3, 0.2}), Material("lambert", {0.7, 0.1, 0.1})};
  const SampleSet one = SamplesOf({red, red}, label, 4);
  const MergeTest same = TestMerge(one, label, start, 0, 1, held, fo);
  ASSERT_TRUE(same.tested);
  EXPECT_TRUE(MergePays(same.merged_rmse, same.apart_rmse, 0.02)) << same.merged_rmse << " vs " << same.apart_rmse;
  const SampleSet two = SamplesOf({red, blue}, label, 4);
  const MergeTest apart = TestMerge(two, label, start, 0, 1, held, fo);
  ASSERT_TRUE(apart.tested);
  EXPECT_GT(apart.merged_rmse, 3 * apart.apart_rmse);
  EXPECT_FALSE(MergePays(apart.merged_rmse, apart.apart_rmse, 0.02));
  // No held-out photo sees the pair: untested, not merged.
  EXPECT_FALSE(TestMerge(one, label, start, 0, 1, std::vector<char>(12, 0), fo).tested);
}

// The stage fits each material apart once per screen and hands the fits to
// every pair it is in: the same test as fitting them within the pair.
TEST(MergeStage, MaterialFittedApartOnceTestsAsWithinThePair) {
  const BasisMaterial red = Material("lambert", {0.6, 0.2, 0.1}), blue = Material("lambert", {0.1, 0.2, 0.6});
  std::vector<int> label(90);
  for (int t = 0; t < 90; ++t) label[t] = t / 30;
  std::vector<char> held(12, 0);
  held[2] = held[7] = 1;
  FitOptions fo;
  fo.threads = 1;
  const std::vector<BasisMaterial> start = {Material("lambert", {0.5, 0.3, 0.2}), Material("lambert", {0.2, 0.2, 0.5}),
                                            Material("lambert", {0.4, 0.3, 0.3})};
  const SampleSet samples = SamplesOf({red, blue, red}, label, 4);
  std::vector<BasisMaterial> apart;
  for (int k = 0; k < 3; ++k) {
    const std::optional<BasisMaterial> fit = FitMaterialApart(samples, label, start, k, held, fo);
    ASSERT_TRUE(fit.has_value()) << k;
    apart.push_back(*fit);
  }
  for (const auto& [i, j] : std::vector<std::pair<int, int>>{{0, 1}, {0, 2}, {1, 2}}) {
    const MergeTest within = TestMerge(samples, label, start, i, j, held, fo);
    const MergeTest given = TestMerge(samples, label, start, i, j, held, fo, apart[i], apart[j]);
    ASSERT_TRUE(within.tested && given.tested);
    EXPECT_EQ(within.apart_rmse, given.apart_rmse) << i << j;
    EXPECT_EQ(within.merged_rmse, given.merged_rmse) << i << j;
    EXPECT_EQ(within.merged_model, given.merged_model);
  }
  // Red with red merges, red with blue does not.
  EXPECT_TRUE(MergePays(TestMerge(samples, label, start, 0, 2, held, fo, apart[0], apart[2]).merged_rmse,
                        TestMerge(samples, label, start, 0, 2, held, fo, apart[0], apart[2]).apart_rmse, 0.02));
  const MergeTest red_blue = TestMerge(samples, label, start, 0, 1, held, fo, apart[0], apart[1]);
  EXPECT_FALSE(MergePays(red_blue.merged_rmse, red_blue.apart_rmse, 0.02));
  // A label without texels has nothing to fit.
  EXPECT_FALSE(FitMaterialApart(samples, std::vector<int>(90, 0), start, 1, held, fo).has_value());
}

// A merge is kept when the materials apart are not better by the split
// search's own bar (min_improvement): the mixed preset's copper halves at
// seed 3, measured (0.0219 apart, 0.0211 merged); a real third material
// (0.0211 apart, 0.0657 merged) stays.
TEST(MergeStage, MergeKeptUnlessApartIsClearlyBetter) {
  EXPECT_TRUE(MergePays(0.0211476, 0.0219143, 0.02));
  EXPECT_FALSE(MergePays(0.0657312, 0.0211476, 0.02));
  EXPECT_TRUE(MergePays(1.0, 0.985, 0.02));
  EXPECT_FALSE(MergePays(1.0, 0.97, 0.02));
}

// A material round is kept when its held-out error is not higher (its
// materials were fitted in the frames of the normals that go with them) and
// another runs only after a clear drop. The mixed preset's round 1: 0.3 %
// below the incumbent, kept (it was dropped for missing the 1 %).
// The mirror stage's F0: the least-squares solve of y = base + w (F0 + (1 -
// F0) s5) L recovers F0 from noise-free samples, stays in [0, 1], and is 0
// where the mirror direction sees nothing.
TEST(MirrorStage, F0IsTheLeastSquaresFitOfTheReflectedRadiance) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> y, base, w, s5, l;
  for (int i = 0; i < 200; ++i) {
    base.push_back(0.1 * u(rng)), w.push_back(0.5 + 0.5 * u(rng)), s5.push_back(std::pow(u(rng), 5)), l.push_back(u(rng));
    y.push_back(base.back() + w.back() * (0.37 + (1 - 0.37) * s5.back()) * l.back());
  }
  EXPECT_NEAR(MirrorF0(y, base, w, s5, l), 0.37, 1e-12);
  std::vector<double> bright = y;
  for (size_t i = 0; i < y.size(); ++i) bright[i] = base[i] + 3 * w[i] * l[i];
  EXPECT_EQ(MirrorF0(bright, base, w, s5, l), 1.0);
  EXPECT_EQ(MirrorF0(y, base, w, s5, std::vector<double>(l.size(), 0.0)), 0.0);
}

TEST(NormalStage, MaterialRoundKeptWhenNotWorseRepeatedWhenClearlyBetter) {
  const double min_improvement = 0.01;
  MaterialRoundDecision d = DecideMaterialRound(true, 0.0239555, 0.0240331, min_improvement);
  EXPECT_TRUE(d.keep);
  EXPECT_FALSE(d.again);
  d = DecideMaterialRound(true, 0.0239262, 0.0243809, min_improvement);  // 1.9 % below
  EXPECT_TRUE(d.keep);
  EXPECT_TRUE(d.again);
  d = DecideMaterialRound(true, 0.0245402, 0.0239262, min_improvement);  // higher
  EXPECT_FALSE(d.keep);
  EXPECT_FALSE(d.again);
  d = DecideMaterialRound(false, 0.01, 0.0239262, min_improvement);  // its normals rejected
  EXPECT_FALSE(d.keep);
  EXPECT_FALSE(d.again);
}

// A merge inside the normal stage (before the material rounds): the
// refinement's per-material entries follow the merged estimate's indices
// (the merged material keeps refined normals when either part did; the
// polish and the rounds read them by index) and its weights become the
// merged estimate's.
TEST(NormalStage, RefinementFollowsAMergeOfTwoMaterials) {
  NormalRefinement nr;
  nr.material_kept = {1, 0, 1, 0};
  nr.heldout_rmse_mesh_by_material = {0.1, 0.2, 0.3, 0.4};
  nr.heldout_rmse_refined_by_material = {0.01, 0.02, 0.03, 0.04};
  nr.weights.assign(4 * 3, 1.0f);
  SvbrdfEstimate merged;
  merged.weights.assign(3 * 3, 0.5f);
  FollowMerge(1, 3, merged, &nr);  // 3 into 1: neither kept
  EXPECT_EQ(nr.material_kept, (std::vector<char>{1, 0, 1}));
  EXPECT_EQ(nr.heldout_rmse_mesh_by_material, (std::vector<double>{0.1, 0.2, 0.3}));
  EXPECT_EQ(nr.weights, merged.weights);
  FollowMerge(1, 2, merged, &nr);  // 2 (kept) into 1 (not): the merged one is kept
  EXPECT_EQ(nr.material_kept, (std::vector<char>{1, 1}));
  EXPECT_EQ(nr.heldout_rmse_refined_by_material, (std::vector<double>{0.01, 0.02}));
}

// A refinement kept for a material that the mirror stage then replaced is
// void (reconstruction.cc); one kept only for another material is not.
TEST(NormalStage, RefinementKeptForAMirrorIsVoid) {
  SvbrdfEstimate est;
  est.basis.resize(2);
  est.basis[0].spec = ModelSpec::FromLabel("lambert");
  est.basis[1].spec = ModelSpec::FromLabel("mirror");
  NormalRefinement nr;
  nr.kept = true;
  nr.material_kept = {1, 1};
  EXPECT_TRUE(RefinedMaterialIsAMirror(est, nr));
  nr.material_kept = {1, 0};
  EXPECT_FALSE(RefinedMaterialIsAMirror(est, nr));
  nr.material_kept = {0, 1};
  nr.kept = false;  // not kept at all: nothing to void
  EXPECT_FALSE(RefinedMaterialIsAMirror(est, nr));
  nr.kept = true;
  est.basis[1].spec = ModelSpec::FromLabel("conductor-ggx");
  EXPECT_FALSE(RefinedMaterialIsAMirror(est, nr));
}

// The bootstrap of the normals <-> materials alternation starts when the
// first refinement lowers some material's held-out error by the given share
// (relative, on squared errors), even if the whole is rejected; not when
// every material gets worse or gains less (captures without bumps).
// The final photo check chooses among three renders (normal_stage.h): the
// bunny scan's numbers keep the refined materials without their map, the
// bump-mapped default capture's keep the map, and neither 1 % below the
// clustering's error keeps the clustering's estimate.
TEST(NormalStage, PhotoCheckChoosesTheLowestOfThreeRenders) {
  PhotoCheck pc;
  pc.photos = 4;
  pc.error_without_map = 132.4, pc.error_with_map = 114.2, pc.error_refined_no_map = 92.8;  // bunny scan
  EXPECT_EQ(ChooseOnPhotos(pc, 0.01), PhotoChoice::kRefinedWithoutMap);
  pc.error_without_map = 1456.3, pc.error_with_map = 578.8, pc.error_refined_no_map = 2394.2;  // default_bump
  EXPECT_EQ(ChooseOnPhotos(pc, 0.01), PhotoChoice::kRefinedWithMap);
  pc.error_without_map = 100, pc.error_with_map = 99.5, pc.error_refined_no_map = 99.8;
  EXPECT_EQ(ChooseOnPhotos(pc, 0.01), PhotoChoice::kMeshNormals);
  pc.error_with_map = pc.error_refined_no_map = 90;  // a tie keeps the map
  EXPECT_EQ(ChooseOnPhotos(pc, 0.01), PhotoChoice::kRefinedWithMap);
  pc.photos = 0;
  EXPECT_EQ(ChooseOnPhotos(pc, 0.01), PhotoChoice::kRefinedWithMap);
}

// The stage's photo check lets the material rounds run when the refined
// materials and weights pay without their map: a clean (256 spp) Mitsuba
// bunny's numbers, where the map alone did not (130.19 -> 129.89).
TEST(NormalStage, PhotoCheckPassesWhenOnlyTheRefinedMaterialsPay) {
  PhotoCheck pc;
  pc.photos = 4;
  pc.error_without_map = 130.19, pc.error_with_map = 129.888, pc.error_refined_no_map = 93.2185;
  EXPECT_TRUE(PhotoCheckPasses(pc, 0.01));
  pc.error_refined_no_map = 129.5;  // neither 1 % below
  EXPECT_FALSE(PhotoCheckPasses(pc, 0.01));
  pc.error_with_map = 100;
  EXPECT_TRUE(PhotoCheckPasses(pc, 0.01));
  pc.photos = 0;
  pc.error_with_map = pc.error_refined_no_map = 1000;
  EXPECT_TRUE(PhotoCheckPasses(pc, 0.01));
}

TEST(NormalStage, BootstrapStartsWhenSomeMaterialImproves) {
  NormalRefinement nr;
  nr.heldout_rmse_mesh_by_material = {0.174, 0.0151, 0.0091};
  nr.heldout_rmse_refined_by_material = {0.204, 0.0103, 0.0061};  // bump-mapped default, measured
  EXPECT_TRUE(SomeMaterialImproved(nr, 0.01));
  nr.heldout_rmse_refined_by_material = {0.204, 0.0160, 0.0092};  // every material worse
  EXPECT_FALSE(SomeMaterialImproved(nr, 0.01));
  nr.heldout_rmse_refined_by_material = {0.204, 0.0151 * 0.996, 0.0091};  // 0.8 % on squared error: too little
  EXPECT_FALSE(SomeMaterialImproved(nr, 0.01));
  EXPECT_FALSE(SomeMaterialImproved(NormalRefinement(), 0.01));  // nothing decided (mode force, or no texels)
  // The default gain: bumps (53 %) start it, a hair (the scan test's 8 %) does not.
  const double gain = NormalAlternationOptions().min_material_gain;
  nr.heldout_rmse_mesh_by_material = {0.174, 0.0151, 0.0091};
  nr.heldout_rmse_refined_by_material = {0.204, 0.0103, 0.0092};
  EXPECT_TRUE(SomeMaterialImproved(nr, gain));
  nr.heldout_rmse_mesh_by_material = {0.0133471, 0.00108176};
  nr.heldout_rmse_refined_by_material = {0.0128165, 0.00120307};
  EXPECT_TRUE(SomeMaterialImproved(nr, 0.01));
  EXPECT_FALSE(SomeMaterialImproved(nr, gain));
  NormalAlternationOptions ao;
  ao.bootstrap_rounds = -1;
  EXPECT_THROW(ao.Check(), Error);
  ao.bootstrap_rounds = 2;
  ao.min_material_gain = 1.0;
  EXPECT_THROW(ao.Check(), Error);
}

}  // namespace
}  // namespace svbrdf
