// report.html: one self-contained page from a reconstruction's summary and pictures.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/error.h"
#include "io/files.h"
#include "io/image.h"
#include "pipeline/normal_stage.h"
#include "pipeline/report_html.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;

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

// A material round is kept when its held-out error is not higher (its
// materials were fitted in the frames of the normals that go with them) and
// another runs only after a clear drop. The mixed preset's round 1: 0.3 %
// below the incumbent, kept (it was dropped for missing the 1 %).
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

// The bootstrap of the normals <-> materials alternation starts when the
// first refinement lowers some material's held-out error by the given share
// (relative, on squared errors), even if the whole is rejected; not when
// every material gets worse or gains less (captures without bumps).
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
