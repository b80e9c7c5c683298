// Fits on synthetic samples generated in code from known parameters:
// recovery (noise-free and noisy), robustness, determinism, bounds, failure
// reporting, and the batched autodiff Jacobian against finite differences.
#include "fit/fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include "brdf/fresnel.h"
#include "core/error.h"
#include "fit/batch_cost.h"
#include "fit/starts.h"
#include "fit/synthetic.h"

namespace svbrdf {
namespace {

// Synthetic sample sets with the test's defaults overridden.
SynthOptions Synth(int count, double noise = 0, uint64_t seed = 7) { return {count, noise, seed, 0}; }

double PredictionRmse(const ModelSpec& spec, const std::vector<double>& p, const std::vector<double>& truth,
                      const SampleSet& set) {
  double sum = 0;
  for (int64_t s = 0; s < set.size(); ++s)
    sum += (PredictSample(spec, p.data(), set, s) - PredictSample(spec, truth.data(), set, s)).square().sum();
  return std::sqrt(sum / (3.0 * set.size()));
}

struct Case {
  const char* label;
  std::vector<double> truth;
  std::vector<int> identifiable;  // parameter indices that the data pins down
};

// Parameter vectors in Params() order (see lib/brdf/model_layout.h).
std::vector<Case> RecoveryCases() {
  return {
      {"lambert", {0.6, 0.4, 0.2}, {0, 1, 2}},
      // rd, rs, exponent
      {"blinn_phong", {0.3, 0.2, 0.1, 0.4, 0.35, 0.3, 40}, {0, 1, 2, 3, 4, 5, 6}},
      // rd, lobe rho, cx, cz, n: (cx, cz, rho) trade off through rho |C|^n, so
      // only rd and n are checked directly; the rest through the prediction.
      {"lafortune-1", {0.3, 0.2, 0.1, 0.8, 0.7, 0.6, -0.9, 0.95, 25}, {0, 1, 2, 8}},
      // Two lobes can swap, so only rd is checked directly.
      {"lafortune-2", {0.3, 0.2, 0.1, 0.5, 0.5, 0.4, -1, 1, 8, 2.0, 1.8, 1.5, -1, 1, 120}, {0, 1, 2}},
      // rd, rs, roughness, ior
      {"cook_torrance-beckmann", {0.4, 0.3, 0.2, 0.5, 0.4, 0.3, 0.2, 1.6}, {0, 1, 2, 3, 4, 5, 6, 7}},
      {"cook_torrance-ggx", {0.4, 0.3, 0.2, 0.5, 0.4, 0.3, 0.25, 1.5}, {0, 1, 2, 3, 4, 5, 6, 7}},
      // f0, roughness: copper-coloured, rough and polished
      {"conductor-ggx-schlick", {0.94, 0.62, 0.54, 0.2}, {0, 1, 2, 3}},
      {"conductor-beckmann-schlick", {0.91, 0.91, 0.92, 0.06}, {0, 1, 2, 3}},
      // eta, kappa (gold, Johnson & Christy), roughness: eta and kappa trade
      // off against each other along curves of equal F0, so only the
      // roughness is checked directly (F0 in ExactConductorRecoversF0).
      {"conductor-ggx", {0.14, 0.43, 1.38, 3.697, 2.455, 1.914, 0.15}, {6}},
      // rd, roughness, ior
      {"coated-ggx", {0.5, 0.3, 0.15, 0.15, 1.5}, {0, 1, 2, 3, 4}},
      // rd, ior
      {"plastic", {0.7, 0.05, 0.6, 1.45}, {0, 1, 2, 3}},
  };
}

class Recovery : public ::testing::TestWithParam<Case> {};

TEST_P(Recovery, NoiseFree) {
  const Case& c = GetParam();
  const ModelSpec spec = ModelSpec::FromLabel(c.label);
  ASSERT_EQ(spec.NumParams(), static_cast<int>(c.truth.size()));
  const SampleSet set = SynthesizeSamples(spec, c.truth, {});
  FitOptions options;
  options.threads = 1;
  const FitResult r = FitModel(spec, set, {}, options);
  EXPECT_TRUE(r.converged) << r.message;
  EXPECT_LT(PredictionRmse(spec, r.params, c.truth, set), 1e-4);
  for (int i : c.identifiable)
    EXPECT_NEAR(r.params[i], c.truth[i], 1e-3 * std::abs(c.truth[i])) << c.label << " parameter " << i;
}

TEST_P(Recovery, OnePercentNoise) {
  const Case& c = GetParam();
  const ModelSpec spec = ModelSpec::FromLabel(c.label);
  SynthOptions synth;
  synth.noise = 0.01;
  const SampleSet set = SynthesizeSamples(spec, c.truth, synth);
  FitOptions options;
  options.threads = 1;
  const FitResult r = FitModel(spec, set, {}, options);
  EXPECT_TRUE(r.converged) << r.message;
  for (int i : c.identifiable)
    EXPECT_NEAR(r.params[i], c.truth[i], 0.03 * std::abs(c.truth[i])) << c.label << " parameter " << i;
}

INSTANTIATE_TEST_SUITE_P(Models, Recovery, ::testing::ValuesIn(RecoveryCases()),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           std::string name = info.param.label;
                           for (char& ch : name)
                             if (ch == '-') ch = '_';
                           return name;
                         });

// The exact conductor starts from the f0 of its Schlick twin; with 1 % noise
// its normal-incidence reflectance must come out within 1 % per channel.
TEST(Fit, ExactConductorRecoversF0) {
  const ModelSpec spec = ModelSpec::FromLabel("conductor-ggx");
  const std::vector<double> truth = {0.22, 1.02, 1.24, 3.747, 2.577, 2.397, 0.2};  // copper
  const SampleSet set = SynthesizeSamples(spec, truth, Synth(20000, 0.01));
  FitOptions options;
  options.threads = 1;
  const FitResult r = FitModel(spec, set, {}, options);
  for (int c = 0; c < 3; ++c) {
    const double f0 = brdf::ConductorF0(r.params[c], r.params[3 + c]);
    const double f0_true = brdf::ConductorF0(truth[c], truth[3 + c]);
    EXPECT_NEAR(f0, f0_true, 0.01 * f0_true) << "channel " << c;
  }
  EXPECT_NEAR(r.params[6], 0.2, 0.01);
}

// The second start family of the exact conductor (MetalLikeStart): the same
// normal-incidence reflectance per channel, with the large kappa of a real
// metal; nothing for other models.
TEST(Fit, MetalLikeStartKeepsF0WithAMetalsKappa) {
  const ModelSpec spec = ModelSpec::FromLabel("conductor-ggx");
  // eta = 1 - f0 starts (ConductorStartFromF0's family): small kappa.
  const std::vector<double> start = {0.074, 0.28, 0.45, 1.69, 1.1, 1.2, 0.12};
  const std::vector<double> metal = MetalLikeStart(spec, start);
  ASSERT_EQ(metal.size(), start.size());
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(brdf::ConductorF0(metal[c], metal[3 + c]), brdf::ConductorF0(start[c], start[3 + c]), 1e-9)
        << "channel " << c;
    EXPECT_GE(metal[3 + c], 1.8) << "channel " << c;  // the metals of metals.h: kappa 1.8..7.6
  }
  EXPECT_EQ(metal[6], start[6]);  // roughness untouched
  EXPECT_TRUE(MetalLikeStart(ModelSpec::FromLabel("conductor-ggx-schlick"), {0.9, 0.7, 0.5, 0.12}).empty());
  EXPECT_TRUE(MetalLikeStart(ModelSpec::FromLabel("lambert"), {0.5, 0.5, 0.5}).empty());
}

// Copper (Johnson & Christy) seen at all angles: the exact conductor's fit
// recovers the whole Fresnel curve, not only F0, and the roughness with it.
TEST(Fit, ExactConductorRecoversCoppersFresnelCurve) {
  const ModelSpec spec = ModelSpec::FromLabel("conductor-ggx");
  const std::vector<double> truth = {0.271, 0.677, 1.316, 3.609, 2.625, 2.292, 0.12};  // Mitsuba's Cu, RGB
  const SampleSet set = SynthesizeSamples(spec, truth, Synth(20000, 0.01));
  FitOptions options;
  options.threads = 1;
  const FitResult r = FitModel(spec, set, {}, options);
  for (int c = 0; c < 3; ++c)
    for (double deg : {0.0, 40.0, 60.0, 75.0}) {
      const double cosine = std::cos(deg * M_PI / 180);
      EXPECT_NEAR(brdf::FresnelConductor(cosine, r.params[c], r.params[3 + c]),
                  brdf::FresnelConductor(cosine, truth[c], truth[3 + c]), 0.01)
          << "channel " << c << " at " << deg << " deg";
    }
  EXPECT_NEAR(r.params[6], 0.12, 0.005);
}

// Samples whose photo averages four normals (SampleSet::footprint: a
// bilinear lookup of pixels on a surface that turns within them): the fit
// with the footprint recovers the glossy coat's roughness, the fit at the
// centre normal reads the spread as a rougher, dimmer lobe.
TEST(Fit, FootprintSubsamplesRecoverAGlossyCoatThatTheCentreNormalBlurs) {
  const ModelSpec spec = ModelSpec::FromLabel("coated-ggx");
  const std::vector<double> truth = {0.5, 0.3, 0.15, 0.1, 1.5};
  SampleSet set = SynthesizeSamples(spec, truth, Synth(6000));
  constexpr int kSub = SampleSet::kFootprintSubsamples;
  set.footprint.resize(size_t(set.size()) * 3 * kSub);
  uint64_t state = 12345;
  auto uniform = [&state]() {  // deterministic, [0, 1)
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return double(state >> 11) / double(1ULL << 53);
  };
  for (int64_t s = 0; s < set.size(); ++s) {
    float* fp = &set.footprint[size_t(s) * 3 * kSub];
    const double fx = uniform(), fy = uniform();  // the lookup's fractional offsets
    for (int j = 0; j < kSub; ++j) {
      fp[3 * j] = float(0.1 * (2 * uniform() - 1));  // tilts up to 5.7 deg
      fp[3 * j + 1] = float(0.1 * (2 * uniform() - 1));
      fp[3 * j + 2] = float(((j & 1) ? fx : 1 - fx) * ((j & 2) ? fy : 1 - fy));
    }
    const Rgb y = PredictSample(spec, truth.data(), set, s);
    for (int c = 0; c < 3; ++c) set.y[c][s] = float(y[c]);
  }
  FitOptions options;
  options.threads = 1;
  const FitResult with = FitModel(spec, set, {}, options);
  EXPECT_NEAR(with.params[3], 0.1, 0.002);
  EXPECT_NEAR(with.params[4], 1.5, 0.02);
  set.footprint.clear();
  const FitResult centre = FitModel(spec, set, {}, options);
  EXPECT_GT(centre.params[3], 0.105) << "the spread of normals should read as a rougher coat";
}

// The batched prediction (one model unpacked per batch) is PredictSample's
// sample by sample, bitwise, for every family, with and without the
// footprint's sub-samples, over a range and over a list of ids.
TEST(Fit, BatchedPredictionsAreThePerSampleOnesBitwise) {
  for (const char* label : {"lambert", "lafortune-2", "cook_torrance-beckmann", "conductor-ggx", "coated-ggx", "plastic", "gltf"}) {
    const ModelSpec spec = ModelSpec::FromLabel(label);
    const std::vector<double> params = spec.InitialParams();
    SampleSet set = SynthesizeSamples(spec, params, Synth(700));
    for (bool footprint : {false, true}) {
      constexpr int kSub = SampleSet::kFootprintSubsamples;
      if (footprint) {
        set.footprint.resize(size_t(set.size()) * 3 * kSub);
        for (int64_t s = 0; s < set.size(); ++s)
          for (int j = 0; j < kSub; ++j) {
            float* fp = &set.footprint[(size_t(s) * kSub + j) * 3];
            fp[0] = float(0.05 * std::sin(0.7 * s + j)), fp[1] = float(0.05 * std::cos(1.3 * s - j));
            fp[2] = (s + j) % 5 == 0 ? 0.0f : 0.25f;  // some sub-samples unused
          }
      }
      std::vector<Rgb> range(set.size() - 3);
      PredictSamples(spec, params.data(), set, nullptr, 3, int64_t(range.size()), range.data());
      const std::vector<int64_t> ids = {5, 0, 699, 300, 300, 17};
      std::vector<Rgb> listed(ids.size());
      PredictSamples(spec, params.data(), set, ids.data(), 0, int64_t(ids.size()), listed.data());
      for (size_t i = 0; i < range.size(); ++i)
        ASSERT_TRUE((range[i] == PredictSample(spec, params.data(), set, int64_t(i) + 3)).all())
            << label << (footprint ? " with footprint" : "") << ", sample " << i + 3;
      for (size_t i = 0; i < ids.size(); ++i)
        ASSERT_TRUE((listed[i] == PredictSample(spec, params.data(), set, ids[i])).all()) << label << ", id " << ids[i];
    }
  }
}

double MaxRelativeError(const std::vector<double>& a, const std::vector<double>& truth) {
  double worst = 0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - truth[i]) / std::abs(truth[i]));
  return worst;
}

// A fit cancelled by another thread ends at its next iteration with a
// finite result instead of running on (the split search's speculative
// control fits).
TEST(Fit, CancelledFitsEndAtTheirNextIteration) {
  const ModelSpec spec = ModelSpec::FromLabel("cook_torrance-beckmann");
  std::vector<double> truth = spec.InitialParams();
  const SampleSet set = SynthesizeSamples(spec, truth, Synth(3000));
  std::vector<int64_t> ids(set.size());
  for (int64_t i = 0; i < set.size(); ++i) ids[i] = i;
  FitOptions fo;
  fo.threads = 1;
  fo.multi_start = false;
  std::vector<double> start = truth;
  for (double& p : start) p *= 0.5;  // far from the truth: many iterations
  const FitResult full = FitModel(spec, set, ids, fo, start);
  std::atomic<bool> cancel{true};
  fo.cancel = &cancel;
  const FitResult cut = FitModel(spec, set, ids, fo, start);
  EXPECT_GT(full.iterations, 3);
  EXPECT_LE(cut.iterations, 1);
  for (double p : cut.params) EXPECT_TRUE(std::isfinite(p));
  cancel = false;  // not set: the same fit as without
  EXPECT_EQ(FitModel(spec, set, ids, fo, start).params, full.params);
}

TEST(Fit, RobustLossBeatsLeastSquaresWithOutliers) {
  const ModelSpec spec = ModelSpec::FromLabel("blinn_phong");
  const std::vector<double> truth{0.3, 0.2, 0.1, 0.4, 0.35, 0.3, 40};
  SynthOptions synth;
  synth.outlier_fraction = 0.1;
  const SampleSet set = SynthesizeSamples(spec, truth, synth);
  FitOptions plain;
  plain.threads = 1;
  FitOptions robust = plain;
  robust.robust_scale = 0.01;
  const double plain_error = MaxRelativeError(FitModel(spec, set, {}, plain).params, truth);
  const double robust_error = MaxRelativeError(FitModel(spec, set, {}, robust).params, truth);
  EXPECT_LT(robust_error, 0.02);
  EXPECT_LT(robust_error, 0.25 * plain_error);
}

// A model that cannot explain everything: a single lobe fitted to samples of
// a broad lobe plus a mirror-like spike (a clear coat over a glossy base).
// Linear residuals let the few spike samples decide the fit; compressed ones
// fit the broad reflection that most samples (most of every photo) show.
TEST(Fit, CompressionFitsTheBulkUnderModelMismatch) {
  const ModelSpec truth_spec = ModelSpec::FromLabel("lafortune-2");
  const std::vector<double> truth{0.1, 0.1, 0.1, 0.5, 0.5, 0.5, -1, 1, 8, 3, 3, 3, -1, 1, 300};
  const SampleSet set = SynthesizeSamples(truth_spec, truth, Synth(20000));
  const ModelSpec spec = ModelSpec::FromLabel("lafortune-1");
  // Median relative prediction error over the samples.
  auto median_rel = [&](const std::vector<double>& p) {
    std::vector<double> rel;
    for (int64_t s = 0; s < set.size(); ++s) {
      const Rgb q = PredictSample(spec, p.data(), set, s), t = PredictSample(truth_spec, truth.data(), set, s);
      if (t.sum() > 1e-6) rel.push_back(std::abs(q.sum() - t.sum()) / t.sum());
    }
    std::nth_element(rel.begin(), rel.begin() + rel.size() / 2, rel.end());
    return rel[rel.size() / 2];
  };
  FitOptions linear;
  linear.threads = 1;
  FitOptions compressed = linear;
  compressed.compression = 1.0;
  const FitResult fl = FitModel(spec, set, {}, linear), fc = FitModel(spec, set, {}, compressed);
  const double e_linear = median_rel(fl.params), e_compressed = median_rel(fc.params);
  // The lobe follows the spike (exponent 300) in the linear fit, the broad
  // reflection (exponent 8) in the compressed one.
  EXPECT_GT(fl.params[8], 100);
  EXPECT_LT(fc.params[8], 50);
  EXPECT_LT(e_compressed, 0.8 * e_linear) << "median relative error: linear " << e_linear;
  // Exact data is fitted exactly either way: the weights only matter where
  // the model cannot follow the samples.
  const ModelSpec lambert = ModelSpec::FromLabel("lambert");
  const SampleSet exact = SynthesizeSamples(lambert, {0.6, 0.4, 0.2}, Synth(2000));
  const FitResult r = FitModel(lambert, exact, {}, compressed);
  EXPECT_NEAR(r.params[0], 0.6, 1e-6);
  EXPECT_NEAR(r.params[2], 0.2, 1e-6);
}

TEST(Fit, ResidualWeight) {
  FitOptions o;
  EXPECT_EQ(ResidualWeight(o, 123.0), 1.0);  // off: linear residuals
  o.compression = 1.0;
  o.compression_reference = 0.1;
  EXPECT_NEAR(ResidualWeight(o, 0.0), 1.0, 1e-12);
  EXPECT_NEAR(ResidualWeight(o, 0.1), 1.0 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(ResidualWeight(o, 9.9), 0.1, 1e-12);  // a highlight 99x the median: 1/10 the residual
  EXPECT_NEAR(ResidualWeight(o, -1.0), 1.0, 1e-12);  // noise below zero counts as black
}

TEST(Fit, DeterministicForSeedAndThreads) {
  const ModelSpec spec = ModelSpec::FromLabel("lafortune-2");
  const SampleSet set = SynthesizeSamples(spec, RecoveryCases()[3].truth, Synth(30000, 0.01));
  FitOptions options;
  options.max_samples = 10000;  // exercises the seeded subset
  options.threads = 1;
  const FitResult a = FitModel(spec, set, {}, options);
  const FitResult b = FitModel(spec, set, {}, options);
  EXPECT_EQ(a.params, b.params);  // bitwise
  EXPECT_EQ(a.cost, b.cost);
  options.threads = 2;
  const FitResult c = FitModel(spec, set, {}, options);
  for (size_t i = 0; i < a.params.size(); ++i) EXPECT_NEAR(a.params[i], c.params[i], 1e-9 * (1 + std::abs(a.params[i])));
  options.seed = 2;  // another subset: close, not identical
  const FitResult d = FitModel(spec, set, {}, options);
  EXPECT_NE(a.params, d.params);
}

TEST(Fit, SubsetOfIds) {
  const ModelSpec spec = ModelSpec::FromLabel("lambert");
  SampleSet set = SynthesizeSamples(spec, {0.6, 0.4, 0.2}, Synth(2000));
  const SampleSet other = SynthesizeSamples(spec, {0.1, 0.9, 0.5}, Synth(2000, 0, 9));
  for (int64_t s = 0; s < other.size(); ++s) {
    const float wi[3] = {other.wi[0][s], other.wi[1][s], other.wi[2][s]};
    const float wo[3] = {other.wo[0][s], other.wo[1][s], other.wo[2][s]};
    const float y[3] = {other.y[0][s], other.y[1][s], other.y[2][s]};
    set.Push(1, 0, wi, wo, other.geom[s], y);
  }
  std::vector<int64_t> ids;
  for (int64_t s = 2000; s < 4000; ++s) ids.push_back(s);
  const FitResult r = FitModel(spec, set, ids, FitOptions{});
  EXPECT_NEAR(r.params[0], 0.1, 1e-4);
  EXPECT_NEAR(r.params[1], 0.9, 1e-4);
  EXPECT_NEAR(r.params[2], 0.5, 1e-4);
}

TEST(Fit, RespectsBounds) {
  // Albedo 1.3 is outside rd's range [0, 1]: the fit must stop at the bound,
  // and an out-of-range start is clamped.
  const ModelSpec spec = ModelSpec::FromLabel("blinn_phong");
  const SampleSet set = SynthesizeSamples(spec, {1.3, 0.2, -0.1, 0.4, 0.35, 0.3, 40}, Synth(5000));
  const FitResult r = FitModel(spec, set, {}, FitOptions{}, {5, 5, 5, 0.3, 0.3, 0.3, 1e6});
  const std::vector<ParamInfo> info = spec.Params();
  for (size_t i = 0; i < info.size(); ++i) {
    EXPECT_GE(r.params[i], info[i].lower) << info[i].name;
    EXPECT_LE(r.params[i], info[i].upper) << info[i].name;
  }
  EXPECT_EQ(r.params[0], info[0].upper);
  EXPECT_EQ(r.params[2], info[2].lower);
}

TEST(Fit, ReportsFailureInsteadOfSilence) {
  const ModelSpec spec = ModelSpec::FromLabel("lambert");
  SampleSet set = SynthesizeSamples(spec, {0.6, 0.4, 0.2}, Synth(500));
  set.y[1][17] = std::nanf("");
  // A non-finite sample never reaches Ceres: an Error naming the fit's context.
  FitOptions named;
  named.context = "cluster 3, split";
  try {
    FitModel(spec, set, {}, named);
    ADD_FAILURE() << "a NaN sample must be an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cluster 3, split"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("non-finite"), std::string::npos) << e.what();
  }
  set.y[1][17] = 0.5f;
  set.geom[3] = std::numeric_limits<float>::infinity();
  EXPECT_THROW(FitModel(spec, set, {}, named), Error);

  const FitResult empty = FitModel(spec, SampleSet{}, {}, FitOptions{});
  EXPECT_FALSE(empty.converged);
  EXPECT_EQ(empty.params, spec.InitialParams());

  FitOptions few;
  few.max_iterations = 1;
  const ModelSpec ct = ModelSpec::FromLabel("cook_torrance-ggx");
  const FitResult stopped = FitModel(ct, SynthesizeSamples(ct, RecoveryCases()[5].truth, Synth(2000)), {}, few);
  EXPECT_FALSE(stopped.converged);
}

TEST(Fit, WrongInitialSizeThrows) {
  const ModelSpec spec = ModelSpec::FromLabel("lambert");
  const SampleSet set = SynthesizeSamples(spec, {0.6, 0.4, 0.2}, Synth(100));
  EXPECT_THROW(FitModel(spec, set, {}, FitOptions{}, {0.5}), Error);
}

TEST(Fit, SumSquaredResidualMatchesCostAndIsThreadInvariant) {
  const ModelSpec spec = ModelSpec::FromLabel("cook_torrance-beckmann");
  const SampleSet set = SynthesizeSamples(spec, RecoveryCases()[4].truth, Synth(20000, 0.05));
  FitOptions options;
  options.max_samples = 1 << 30;
  const FitResult r = FitModel(spec, set, {}, options);
  int64_t count = 0;
  const double one = SumSquaredResidual(spec, r.params, set, {}, 1, &count);
  EXPECT_EQ(count, set.size());
  EXPECT_EQ(one, SumSquaredResidual(spec, r.params, set, {}, 3, nullptr));
  EXPECT_EQ(one, SumSquaredResidual(spec, r.params, set, {}));
  EXPECT_NEAR(r.cost, one / (3.0 * count), 1e-12 * one);
}

TEST(Fit, OptionsCheckNamesTheBadOption) {
  auto expect_rejects = [](const std::string& name, auto set_bad) {
    FitOptions o;
    set_bad(o);
    try {
      o.Check();
      ADD_FAILURE() << "accepted bad " << name;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  FitOptions o;
  EXPECT_NO_THROW(o.Check());
  expect_rejects("max_iterations", [](FitOptions& b) { b.max_iterations = 0; });
  expect_rejects("function_tolerance", [](FitOptions& b) { b.function_tolerance = -1; });
  expect_rejects("function_tolerance", [](FitOptions& b) { b.function_tolerance = NAN; });
  expect_rejects("robust_scale", [](FitOptions& b) { b.robust_scale = -0.1; });
  expect_rejects("robust_scale", [](FitOptions& b) { b.robust_scale = INFINITY; });
  expect_rejects("compression", [](FitOptions& b) { b.compression = -1; });
  expect_rejects("compression_reference", [](FitOptions& b) { b.compression_reference = NAN; });
  expect_rejects("max_samples", [](FitOptions& b) { b.max_samples = 0; });
  expect_rejects("threads", [](FitOptions& b) { b.threads = -2; });
  FitOptions bad;
  bad.threads = -1;
  const ModelSpec spec = ModelSpec::FromLabel("lambert");
  EXPECT_THROW(FitModel(spec, SampleSet{}, {}, bad), Error);
}

// Every model's parameter count has the fast compile-time-sized cost, and the
// batched autodiff Jacobian (plain and robust) agrees with central differences.
TEST(BatchCost, JacobianMatchesFiniteDifferences) {
  for (const ModelSpec& spec : AllModelSpecs()) {
    SCOPED_TRACE(spec.Label());
    EXPECT_TRUE(HasFixedSizeCost(spec.NumParams())) << spec.NumParams();
    // Away from the initial values (which can sit on symmetric special points,
    // or on a node of the coat's transmittance table, rough_coat.h, where the
    // interpolant has a kink and the derivative is one-sided), inside the bounds.
    std::vector<double> p = spec.InitialParams();
    const std::vector<ParamInfo> info = spec.Params();
    const double off_node = spec.family == Family::kCoated ? 0.013 : 0.0;
    for (size_t i = 0; i < p.size(); ++i)
      p[i] = std::clamp(p[i] * (1.0 + off_node + 0.07 * ((i % 3) - 1.0)), info[i].lower, info[i].upper);
    const SampleSet set = SynthesizeSamples(spec, p, Synth(100, 0.1));
    std::vector<int64_t> ids(set.size());
    for (int64_t s = 0; s < set.size(); ++s) ids[s] = s;
    const PackedSamples packed = PackedSamples::FromIds(set, ids);
    for (const double robust_scale : {0.0, 0.01}) {
      SCOPED_TRACE(robust_scale);
      std::unique_ptr<ceres::CostFunction> cost(MakeBatchCost(spec, packed, 10, 64, robust_scale));
      ASSERT_EQ(cost->num_residuals(), 3 * 64);
      const int m = cost->num_residuals(), n = spec.NumParams();
      std::vector<double> residuals(m), jacobian(m * n);  // row-major, as Ceres
      const double* block[] = {p.data()};
      double* jacobians[] = {jacobian.data()};
      ASSERT_TRUE(cost->Evaluate(block, residuals.data(), jacobians));
      const double scale = *std::max_element(jacobian.begin(), jacobian.end(),
                                              [](double a, double b) { return std::abs(a) < std::abs(b); });
      // Central difference of residual column j with step h.
      auto central = [&](int j, double h) {
        std::vector<double> q = p, plus(m), minus(m), d(m);
        const double* q_block[] = {q.data()};
        q[j] = p[j] + h;
        cost->Evaluate(q_block, plus.data(), nullptr);
        q[j] = p[j] - h;
        cost->Evaluate(q_block, minus.data(), nullptr);
        for (int i = 0; i < m; ++i) d[i] = (plus[i] - minus[i]) / (2 * h);
        return d;
      };
      for (int j = 0; j < n; ++j) {
        // Richardson extrapolation of two steps (error O(h^4)): sharp lobes
        // (exponents in the hundreds) and the Cauchy loss defeat plain differences.
        const double h = 1e-6 * std::max(1.0, std::abs(p[j]));
        const std::vector<double> coarse = central(j, h), fine = central(j, h / 2);
        for (int i = 0; i < m; ++i)
          EXPECT_NEAR(jacobian[i * n + j], (4 * fine[i] - coarse[i]) / 3,
                      1e-5 * (std::abs(jacobian[i * n + j]) + 1e-2 * std::abs(scale)))
              << info[j].name << " residual " << i;
      }
    }
  }
}

}  // namespace
}  // namespace svbrdf
