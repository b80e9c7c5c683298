// Normal refinement (lib/normals): known tilted normals recovered from samples
// generated in code (Lambertian and glossy basis materials), the Jet
// derivatives of the cost against finite differences, and the normal map.
#include <gtest/gtest.h>

#include <ceres/autodiff_cost_function.h>
#include <ceres/loss_function.h>

#include <algorithm>
#include <array>
#include <random>

#include "core/rng.h"
#include "cluster/nnls.h"
#include "fit/fit.h"
#include "normals/basis_polish.h"
#include "normals/joint_cost.h"
#include "normals/normal_cost.h"
#include "normals/normal_map.h"
#include "normals/refine.h"

namespace svbrdf {
namespace {

using normals::NormalSampleCost;
using normals::TexelSample;
using normals::WeightedBasis;

double AngleDeg(const Vec3& a, const Vec3& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / kPi;
}

// A flat patch of n x n texels (mesh normal +z, tangent +x), each with its own
// true normal tilted by up to `max_tilt_deg` (a smooth bump field, or random
// per texel when `smooth` is false), made of `basis` mixed with
// weight `weight` (a texel may be darker than its material), seen in
// `views` photos under random lights and views with relative noise `noise`.
struct Patch {
  Atlas atlas;
  SampleSet samples;
  SvbrdfEstimate estimate;
  std::vector<Vec3> truth;
};

Patch MakePatch(const BasisMaterial& basis, int n, double max_tilt_deg, int views, double noise, uint64_t seed,
                bool smooth = true, int flat_from_x = 1 << 30) {
  Patch p;
  p.atlas.width = p.atlas.height = n;
  p.atlas.index.assign(n * n, -1);
  Rng rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      Texel tx;
      tx.x = x, tx.y = y;
      tx.position = Vec3(x * 0.01, y * 0.01, 0);
      tx.normal = Vec3(0, 0, 1);
      tx.tangent = Vec3(1, 0, 0);
      p.atlas.index[y * n + x] = int(p.atlas.texels.size());
      p.atlas.texels.push_back(tx);
      if (x >= flat_from_x) {  // this part of the patch is flat: the mesh normal is right
        p.truth.push_back(tx.normal);
        continue;
      }
      if (smooth) {  // a bump field: tan(tilt) per axis varies over ~12 texels
        const double m = std::tan(max_tilt_deg * kPi / 180.0) / std::sqrt(2.0);
        p.truth.push_back(Vec3(m * std::sin(2 * kPi * x / 12.0 + 0.3 * seed), m * std::cos(2 * kPi * y / 12.0), 1).normalized());
        continue;
      }
      const double tilt = max_tilt_deg * kPi / 180.0 * std::sqrt(u(rng)), phi = 2 * kPi * u(rng);
      p.truth.push_back(Vec3(std::sin(tilt) * std::cos(phi), std::sin(tilt) * std::sin(phi), std::cos(tilt)));
    }
  const int nt = n * n;
  // Photos: one light and one camera direction each, shared by all texels.
  std::vector<Vec3> light(views), eye(views);
  for (int v = 0; v < views; ++v) {
    auto hemi = [&](double zmin) {
      const double z = zmin + (1 - zmin) * u(rng), phi = 2 * kPi * u(rng), r = std::sqrt(1 - z * z);
      return Vec3(r * std::cos(phi), r * std::sin(phi), z);
    };
    light[v] = hemi(0.45);
    // Every third photo looks near the mirror direction: glossy materials show highlights.
    eye[v] = v % 3 == 0 ? Vec3(Vec3(-light[v].x(), -light[v].y(), light[v].z()) + 0.15 * hemi(0)).normalized()
                        : hemi(0.45);
  }
  SampleSet& s = p.samples;
  s.num_texels = nt;
  s.texel_begin.push_back(0);
  std::vector<double> weight(nt);
  for (int t = 0; t < nt; ++t) {
    weight[t] = 0.7 + 0.5 * u(rng);
    const Frame truth = Frame::FromNormalTangent(p.truth[t], Vec3(1, 0, 0));
    for (int v = 0; v < views; ++v) {
      const Vec3 wi_t = truth.ToLocal(light[v]), wo_t = truth.ToLocal(eye[v]);
      if (wi_t.z() < 0.1 || wo_t.z() < 0.1) continue;  // gather rejects grazing/unlit samples too
      const Rgb f = EvalModelD(basis.spec, basis.params.data(), wi_t, wo_t) * weight[t];
      const float wi[3] = {float(light[v].x()), float(light[v].y()), float(light[v].z())};
      const float wo[3] = {float(eye[v].x()), float(eye[v].y()), float(eye[v].z())};
      const double geom = light[v].z();  // cos_i of the mesh normal, unit irradiance
      float y[3];
      for (int c = 0; c < 3; ++c) {
        const double clean = f[c] * wi_t.z();  // the photo sees the true normal's cosine
        y[c] = float(clean * (1.0 + noise * g(rng)));
      }
      s.Push(t, v, wi, wo, float(geom), y);
    }
    s.texel_begin.push_back(s.size());
  }
  // The clustering's output: the true basis material, weights fitted with the
  // mesh normal are not known here, so start from 1 (the refinement re-solves them).
  SvbrdfEstimate& e = p.estimate;
  e.basis = {basis};
  e.num_texels = nt;
  e.weights.assign(size_t(nt) * 3, 1.0f);
  return p;
}

struct Recovered {
  double mean_deg = 0, max_deg = 0;
  NormalRefinement r;
};

Recovered Refine(const Patch& p, const std::string& mode, double neighbour_weight = 0.5) {
  NormalOptions o;
  o.mode = mode;
  o.neighbour_weight = neighbour_weight;
  o.progress = false;
  o.threads = 2;
  Recovered out;
  out.r = RefineNormals(p.samples, p.atlas, p.estimate, o);
  for (size_t t = 0; t < p.truth.size(); ++t) {
    const double a = AngleDeg(out.r.normal[t], p.truth[t]);
    out.mean_deg += a / p.truth.size();
    out.max_deg = std::max(out.max_deg, a);
  }
  std::printf("angle to the true normals: mean %.3f, max %.3f deg; %s\n", out.mean_deg, out.max_deg,
              out.r.Report().c_str());
  return out;
}

// A basis material with the given parameters by name (the rest at their initial values).
BasisMaterial Basis(const std::string& label, const std::vector<std::pair<std::string, double>>& values) {
  BasisMaterial b;
  b.spec = ModelSpec::FromLabel(label);
  b.params = b.spec.InitialParams();
  const std::vector<ParamInfo> info = b.spec.Params();
  for (const auto& [name, v] : values) {
    const auto it = std::find_if(info.begin(), info.end(), [&](const ParamInfo& p) { return p.name == name; });
    EXPECT_NE(it, info.end()) << label << " has no " << name;
    if (it != info.end()) b.params[it - info.begin()] = v;
  }
  return b;
}
const std::vector<std::pair<std::string, double>> kGreen = {{"rd_r", 0.25}, {"rd_g", 0.5}, {"rd_b", 0.15}};
BasisMaterial Lambert() { return Basis("lambert", kGreen); }
BasisMaterial RedPlastic(const std::string& label = "cook_torrance-beckmann") {
  return Basis(label, {{"rd_r", 0.55}, {"rd_g", 0.12}, {"rd_b", 0.08}, {"rs_r", 0.35}, {"rs_g", 0.35},
                       {"rs_b", 0.35}, {"roughness", 0.18}, {"ior", 1.5}});
}
BasisMaterial BluePaint() {
  return Basis("lafortune-1", {{"rd_r", 0.08}, {"rd_g", 0.18}, {"rd_b", 0.45}, {"lobe0.rho_r", 1.5},
                               {"lobe0.rho_g", 1.5}, {"lobe0.rho_b", 1.5}, {"lobe0.cx", -1.0}, {"lobe0.cz", 1.0},
                               {"lobe0.n", 30.0}});
}

TEST(NormalRefinement, RecoversTiltedNormalsOfALambertianPatch) {
  // Random normals per texel, each texel on its own (no pooling), noise-free:
  // the data decide, the prior vanishes with the estimated noise.
  const Patch p = MakePatch(Lambert(), 8, 25.0, 24, 0.0, 1, false);
  const Recovered r = Refine(p, "force", 0.0);
  EXPECT_TRUE(r.r.kept);
  EXPECT_EQ(r.r.texels_refined, 64);
  EXPECT_LT(r.max_deg, 1.0) << "mean " << r.mean_deg;
  // A smooth bump field, 1 % noise: a pooled first pass, then own samples
  // with the neighbours' tilts as a prior (measured: mean 0.16, max 0.44 deg).
  const Patch b = MakePatch(Lambert(), 12, 20.0, 16, 0.01, 7);
  const Recovered rb = Refine(b, "on");
  EXPECT_TRUE(rb.r.kept);
  EXPECT_LT(rb.mean_deg, 0.5);
  EXPECT_LT(rb.max_deg, 1.5);
}

TEST(NormalRefinement, RecoversTiltedNormalsOfAGlossyPatchWithNoise) {
  // Cook-Torrance (red plastic) with 1 % noise, random normals, each texel on its own.
  const Patch p = MakePatch(RedPlastic(), 8, 20.0, 30, 0.01, 2, false);
  const Recovered r = Refine(p, "on", 0.0);
  EXPECT_TRUE(r.r.kept) << r.r.Report();
  EXPECT_LT(r.r.heldout_rmse_refined, 0.7 * r.r.heldout_rmse_mesh);
  EXPECT_LT(r.mean_deg, 1.5) << r.r.Report();
  EXPECT_LT(r.max_deg, 5.0) << r.r.Report();
  // A smooth bump field: pooling the neighbours' samples in every pass
  // smoothed the field over 3 x 3 texels, which a sharp highlight notices
  // (bias ~2 deg here); with the smoothness prior after the first pass
  // (smooth_tilt) measured mean 0.13, max 0.69 deg.
  const Patch b = MakePatch(RedPlastic(), 12, 20.0, 24, 0.01, 8);
  const Recovered rb = Refine(b, "on");
  EXPECT_TRUE(rb.r.kept) << rb.r.Report();
  EXPECT_LT(rb.r.heldout_rmse_refined, 0.3 * rb.r.heldout_rmse_mesh);
  EXPECT_LT(rb.mean_deg, 0.5) << rb.r.Report();
  EXPECT_LT(rb.max_deg, 2.0) << rb.r.Report();
}

// A steep lobe (the blue paint, Lafortune n = 30) on a bump field that turns
// ~2 degrees per texel: pooling the neighbours' samples in every pass fits
// each texel's normal to a 3 x 3 neighbourhood's highlights, a blur the
// lobe cannot hide; own samples with a prior towards the neighbours' tilts
// (smooth_tilt, after one pooled pass) keep the field sharp and still give
// every texel its neighbours' support where its own samples are weak.
TEST(NormalRefinement, SmoothnessPriorDoesNotBlurASteepLobesBumps) {
  const Patch p = MakePatch(BluePaint(), 16, 12.0, 30, 0.01, 12);
  NormalOptions o;
  o.mode = "force";
  o.progress = false;
  o.threads = 2;
  auto error = [&](double smooth_tilt) {
    o.smooth_tilt = smooth_tilt;
    const NormalRefinement r = RefineNormals(p.samples, p.atlas, p.estimate, o);
    double mean = 0;
    for (size_t t = 0; t < p.truth.size(); ++t) mean += AngleDeg(r.normal[t], p.truth[t]) / p.truth.size();
    std::printf("smooth_tilt %.2f: mean angle to the true normals %.3f deg\n", smooth_tilt, mean);
    return mean;
  };
  const double pooled = error(0.0), smooth = error(NormalOptions().smooth_tilt);
  // Measured: pooled 0.305 deg, smoothness prior 0.020 deg.
  EXPECT_LT(smooth, 0.3 * pooled);
  EXPECT_LT(smooth, 0.1);
}

TEST(NormalRefinement, KeepsMeshNormalsWhenTheyAreRightOrDataAreTooFew) {
  // True normals = mesh normals: the held-out test rejects the refinement.
  const Patch flat = MakePatch(BluePaint(), 8, 0.0, 24, 0.01, 3);
  const Recovered r = Refine(flat, "on");
  EXPECT_FALSE(r.r.kept) << r.r.Report();
  EXPECT_LT(r.max_deg, 1e-9);
  // One photo: at most 1 + 8 x 0.5 pooled samples, fewer than min_samples (8).
  const Patch few = MakePatch(Lambert(), 4, 20.0, 1, 0.0, 4);
  const Recovered f = Refine(few, "force");
  EXPECT_EQ(f.r.texels_refined, 0);
  for (const Vec3& n : f.r.normal) EXPECT_EQ(n, Vec3(0, 0, 1));
}

// The screening decision (NormalOptions::screen_texels) on the first of the
// decision texels: where the mesh normals are right it ends the refinement
// with the same verdict as the full decision, on the screen's texels only;
// where normals pay, the full decision runs after it and the result is the
// one without the screen.
TEST(NormalRefinement, ScreeningDecisionEndsWhereTheMeshNormalsAreRight) {
  NormalOptions o;
  o.progress = false;
  o.threads = 2;
  auto run = [&](const Patch& p, long screen) {
    o.screen_texels = screen;
    return RefineNormals(p.samples, p.atlas, p.estimate, o);
  };
  const Patch flat = MakePatch(BluePaint(), 16, 0.0, 24, 0.01, 3);
  const NormalRefinement screened = run(flat, 100), full = run(flat, 0);
  EXPECT_FALSE(screened.kept) << screened.Report();
  EXPECT_FALSE(full.kept) << full.Report();
  EXPECT_EQ(screened.decision_texels, 100);
  EXPECT_GT(full.decision_texels, 200) << full.Report();
  EXPECT_EQ(screened.normal, full.normal);
  const Patch bumped = MakePatch(Lambert(), 16, 20.0, 16, 0.01, 7);
  const NormalRefinement b_screened = run(bumped, 100), b_full = run(bumped, 0);
  EXPECT_TRUE(b_screened.kept) << b_screened.Report();
  EXPECT_EQ(b_screened.decision_texels, b_full.decision_texels);
  EXPECT_GT(b_screened.decision_texels, 200);
  EXPECT_EQ(b_screened.normal, b_full.normal);
  EXPECT_EQ(b_screened.weights, b_full.weights);
  // From start tilts (a material round) the full decision runs alone.
  const std::vector<Vec2> start(flat.atlas.texels.size(), Vec2::Zero());
  o.screen_texels = 100;
  EXPECT_GT(RefineNormals(flat.samples, flat.atlas, flat.estimate, o, &start).decision_texels, 200);
  // Out of range: more screening texels than decision texels.
  o.screen_texels = o.decision_texels + 1;
  EXPECT_THROW(o.Check(), Error);
}

TEST(NormalRefinement, IsDeterministicAcrossThreadCounts) {
  const Patch p = MakePatch(RedPlastic("cook_torrance-ggx"), 6, 15.0, 24, 0.01, 5);
  NormalOptions o;
  o.progress = false;
  o.threads = 1;
  const NormalRefinement a = RefineNormals(p.samples, p.atlas, p.estimate, o);
  o.threads = 2;
  const NormalRefinement b = RefineNormals(p.samples, p.atlas, p.estimate, o);
  EXPECT_EQ(a.normal, b.normal);
  EXPECT_EQ(a.weights, b.weights);
}

// The decision is taken per basis material: a bumped material keeps its
// refined normals although another one's (here flat: the mesh normals are
// right) are rejected. Two Lambertian basis materials, one per half.
TEST(NormalRefinement, KeepsRefinedNormalsPerMaterial) {
  const int n = 12;
  Patch p = MakePatch(Lambert(), n, 20.0, 16, 0.01, 9, true, n / 2);
  SvbrdfEstimate& e = p.estimate;
  e.basis = {Lambert(), Lambert()};
  e.weights.assign(size_t(n * n) * 2 * 3, 0.0f);
  e.label.assign(n * n, 0);
  for (int t = 0; t < n * n; ++t) {
    const int k = p.atlas.texels[t].x >= n / 2;
    e.label[t] = k;
    for (int c = 0; c < 3; ++c) e.weights[(size_t(t) * 2 + k) * 3 + c] = 1.0f;
  }
  const Recovered r = Refine(p, "on");
  ASSERT_EQ(r.r.material_kept.size(), 2u);
  EXPECT_TRUE(r.r.kept) << r.r.Report();
  EXPECT_EQ(r.r.material_kept[0], 1) << r.r.Report();
  EXPECT_EQ(r.r.material_kept[1], 0) << r.r.Report();
  double left = 0;
  int count = 0;
  for (int t = 0; t < n * n; ++t) {
    if (p.atlas.texels[t].x >= n / 2) {
      EXPECT_FALSE(r.r.refined[t]);
      EXPECT_EQ(r.r.normal[t], p.atlas.texels[t].normal);
    } else {
      left += AngleDeg(r.r.normal[t], p.truth[t]), ++count;
    }
  }
  EXPECT_LT(left / count, 1.5);
}

// Jet derivatives of the sample cost against central finite differences, for
// models with and without a sharp lobe, at several tilts.
TEST(NormalSampleCost, JetGradientMatchesFiniteDifferences) {
  for (const BasisMaterial& m : {Lambert(), RedPlastic(), BluePaint(), Basis("oren_nayar", kGreen)}) {
    const std::string label = m.spec.Label();
    std::vector<WeightedBasis> basis(1);
    basis[0].spec = &m.spec;
    basis[0].params = m.params;
    basis[0].w[0] = 0.9, basis[0].w[1] = 1.1, basis[0].w[2] = 1.0;
    const Vec3 wi = Vec3(0.3, -0.2, 0.9).normalized(), wo = Vec3(-0.25, 0.3, 0.85).normalized();
    TexelSample s{{wi.x(), wi.y(), wi.z()}, {wo.x(), wo.y(), wo.z()}, 0.8, {0.1, 0.2, 0.3}};
    const NormalSampleCost functor{&s, &basis};
    ceres::AutoDiffCostFunction<NormalSampleCost, 3, 2> cost(new NormalSampleCost(functor));
    for (const auto& ab0 : std::vector<std::array<double, 2>>{{0, 0}, {0.1, -0.05}, {-0.2, 0.15}}) {
      double ab[2] = {ab0[0], ab0[1]}, r[3], J[6];
      const double* params[1] = {ab};
      double* jac[1] = {J};
      ASSERT_TRUE(cost.Evaluate(params, r, jac));
      for (int j = 0; j < 2; ++j) {
        const double h = 1e-6;
        double p[2] = {ab[0], ab[1]}, m2[2] = {ab[0], ab[1]}, rp[3], rm[3];
        p[j] += h, m2[j] -= h;
        functor(p, rp);
        functor(m2, rm);
        for (int c = 0; c < 3; ++c) {
          const double fd = (rp[c] - rm[c]) / (2 * h);
          EXPECT_NEAR(J[c * 2 + j], fd, 1e-5 * (1 + std::abs(fd))) << label << " param " << j << " channel " << c;
        }
      }
    }
    // At the mesh normal the cost predicts exactly the sample's model value.
    double ab[2] = {0, 0}, r[3];
    functor(ab, r);
    const Rgb f = EvalModelD(m.spec, m.params.data(), wi, wo);
    EXPECT_NEAR(r[0], 0.9 * f[0] * 0.8 - 0.1, 1e-12) << label;
  }
}

// The batched cost (one block per texel) must have the objective of
// per-sample blocks under ceres::CauchyLoss plus the tilt prior.
TEST(NormalBatchCost, EqualsPerSampleCauchyLossAndPrior) {
  const BasisMaterial m = RedPlastic();
  std::vector<WeightedBasis> basis(1);
  basis[0].spec = &m.spec;
  basis[0].params = m.params;
  basis[0].w[0] = basis[0].w[1] = basis[0].w[2] = 1.0;
  const std::vector<WeightedBasis> none;
  std::vector<TexelSample> samples;
  std::vector<const std::vector<WeightedBasis>*> per_sample;
  std::vector<double> weight;
  for (int i = 0; i < 6; ++i) {
    const Vec3 wi = Vec3(0.1 * i - 0.3, 0.2, 0.9).normalized(), wo = Vec3(-0.2, 0.05 * i, 0.8).normalized();
    samples.push_back({{wi.x(), wi.y(), wi.z()}, {wo.x(), wo.y(), wo.z()}, 0.7, {0.3 * i, 0.1, 0.05}});
    per_sample.push_back(i == 4 ? &none : &basis);  // a sample without materials contributes nothing
    weight.push_back(i % 2 ? 0.5 : 1.0);
  }
  const double c = 0.05, prior = 0.3, ab[2] = {0.08, -0.04};
  // The prior centred off the mesh normal (a neighbours' prior, refine.cc).
  normals::NormalBatchCost batch{&samples, &per_sample, &weight, c, prior};
  batch.prior_mean[0] = 0.03, batch.prior_mean[1] = 0.01;
  std::vector<double> r(3 * samples.size() + 2);
  ASSERT_TRUE(batch(ab, r.data()));
  double batched = 0;
  for (double v : r) batched += v * v;
  const double prior_sq = prior * prior * ((ab[0] - 0.03) * (ab[0] - 0.03) + (ab[1] - 0.01) * (ab[1] - 0.01));
  double expected = prior_sq;
  const ceres::CauchyLoss loss(c);
  for (size_t i = 0; i < samples.size(); ++i) {
    if (per_sample[i]->empty()) continue;
    double ri[3], rho[3];
    NormalSampleCost{&samples[i], per_sample[i], std::sqrt(weight[i])}(ab, ri);
    loss.Evaluate(ri[0] * ri[0] + ri[1] * ri[1] + ri[2] * ri[2], rho);
    expected += rho[0];
  }
  EXPECT_GT(expected, 1.01 * prior_sq);  // the samples count
  EXPECT_NEAR(batched, expected, 1e-12 * expected);
}

// Weights of a rough conductor patch as a fit under the mesh normals gives
// them: per texel and channel the least-squares scale of the material's
// prediction at tilt 0 (a bump-shifted highlight reads as a wrong brightness).
void MeshNormalWeights(Patch* p) {
  const BasisMaterial& b = p->estimate.basis[0];
  WeightedBasis wb;
  wb.spec = &b.spec;
  wb.params = b.params;
  const double ab[2] = {0, 0};
  for (int t = 0; t < p->samples.num_texels; ++t) {
    double pp[3] = {0, 0, 0}, py[3] = {0, 0, 0};
    for (int64_t i = p->samples.texel_begin[t]; i < p->samples.texel_begin[t + 1]; ++i) {
      TexelSample ts;
      for (int c = 0; c < 3; ++c)
        ts.wi[c] = p->samples.wi[c][i], ts.wo[c] = p->samples.wo[c][i], ts.y[c] = p->samples.y[c][i];
      ts.geom = p->samples.geom[i];
      double rgb[3];
      normals::PredictBasis(wb, ts, ab, rgb);
      for (int c = 0; c < 3; ++c) pp[c] += rgb[c] * rgb[c], py[c] += rgb[c] * ts.y[c];
    }
    for (int c = 0; c < 3; ++c) p->estimate.weights[size_t(t) * 3 + c] = float(pp[c] > 0 ? py[c] / pp[c] : 1.0);
  }
  p->estimate.per_channel_weights = true;
}

// A bumped rough conductor (GGX, alpha 0.2, copper-like F0) whose weights
// come from a fit under the mesh normals: with those weights held fixed in
// the tilt fit, the refined tilt fell short of the true one (0.78 of it on
// the mixed preset's copper, true basis given); solving the weights with
// the tilt (NormalOptions::joint_weights) recovers it.
TEST(NormalRefinement, RecoversABumpedConductorFromWeightsFittedUnderTheMeshNormal) {
  const BasisMaterial copper = Basis("conductor-ggx-schlick", {{"f0_r", 0.95}, {"f0_g", 0.64}, {"f0_b", 0.54}, {"roughness", 0.2}});
  Patch p = MakePatch(copper, 12, 12.0, 40, 0.01, 11);
  MeshNormalWeights(&p);
  auto gain = [&](const NormalRefinement& r) {  // refined tilt projected on the true tilt
    double num = 0, den = 0;
    for (size_t t = 0; t < p.truth.size(); ++t) {
      const Vec2 truth(p.truth[t].x() / p.truth[t].z(), p.truth[t].y() / p.truth[t].z());
      num += r.tilt[t].dot(truth), den += truth.squaredNorm();
    }
    return num / den;
  };
  NormalOptions o;
  o.mode = "force";
  o.progress = false;
  o.threads = 2;
  o.joint_weights = false;
  const NormalRefinement fixed = RefineNormals(p.samples, p.atlas, p.estimate, o);
  o.joint_weights = true;
  const NormalRefinement joint = RefineNormals(p.samples, p.atlas, p.estimate, o);
  double fixed_deg = 0, joint_deg = 0;
  for (size_t t = 0; t < p.truth.size(); ++t) {
    fixed_deg += AngleDeg(fixed.normal[t], p.truth[t]) / p.truth.size();
    joint_deg += AngleDeg(joint.normal[t], p.truth[t]) / p.truth.size();
  }
  std::printf("conductor patch: tilt gain %.3f (weights held) vs %.3f (joint); mean angle %.3f vs %.3f deg\n",
              gain(fixed), gain(joint), fixed_deg, joint_deg);
  EXPECT_GT(gain(joint), 0.95);
  EXPECT_LT(joint_deg, 0.6 * fixed_deg);
  EXPECT_LT(joint_deg, 1.0);
}

// A bumped coated plastic whose basis was fitted under the mesh normals
// (its ior low): the normals refined against that basis absorb part of its
// error, so the basis refitted in their frames (what one material round
// does) moves only part of the way back; fitted jointly with the interior
// texels' tilts (PolishBasisWithTilts) it lands near the truth (mixed
// preset, seed 1: ior 1.432 -> 1.495, true 1.5; the rounds alone 1.440).
TEST(BasisPolish, RecoversACoatedPlasticsIorThatTheRefinedNormalsAbsorbed) {
  const BasisMaterial truth = Basis("coated-ggx", {{"rd_r", 0.55}, {"rd_g", 0.08}, {"rd_b", 0.06}, {"roughness", 0.1},
                                                    {"ior", 1.5}});
  const int ior_index = 4;
  ASSERT_EQ(truth.spec.Params()[ior_index].name, "ior");
  Patch p = MakePatch(truth, 20, 6.0, 40, 0.01, 5);
  p.estimate.basis[0].params[ior_index] = 1.40;  // biased as a fit under the mesh normals
  p.estimate.label.assign(p.samples.num_texels, 0);
  NormalOptions o;
  o.mode = "force";
  o.progress = false;
  o.threads = 2;
  o.holdout_fraction = 0.2;
  const NormalRefinement nr = RefineNormals(p.samples, p.atlas, p.estimate, o);
  SvbrdfEstimate est = p.estimate;
  est.weights = nr.weights;
  // One round's basis fit: the samples in the refined frames, every texel at weight 1.
  const SampleSet reoriented = ReorientSamples(p.samples, nr.tilt);
  FitOptions fo;
  fo.threads = 2;
  const FitResult refit = FitModel(truth.spec, reoriented, {}, fo, est.basis[0].params);
  const std::vector<BasisPolishReport> rep =
      PolishBasisWithTilts(p.samples, p.atlas, o, nr.tilt, nr.material_kept, nr.noise_sigma, 20000, &est);
  ASSERT_EQ(rep.size(), 1u);
  const double polished = est.basis[0].params[ior_index];
  std::printf("ior: start 1.40, refit in the refined frames %.4f, polished %.4f (true 1.5); %s\n",
              refit.params[ior_index], polished, Report(rep[0], est).c_str());
  EXPECT_GT(rep[0].texels, 300);
  EXPECT_LT(rep[0].cost_after, rep[0].cost_before);
  EXPECT_LT(std::abs(polished - 1.5), 0.03);
  EXPECT_LT(std::abs(polished - 1.5), 0.5 * std::abs(refit.params[ior_index] - 1.5));
}

// The joint cost's weights are the non-negative least-squares optimum (with
// the weight step's prior) at the trial tilt: its residuals equal the batched
// cost's under those weights; and its Jets (through the weights' solve)
// match central finite differences.
TEST(NormalJointCost, SolvesTheWeightsAtTheTiltAndDifferentiatesThroughThem) {
  const BasisMaterial lambert = Lambert(), plastic = RedPlastic("cook_torrance-ggx");
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  std::vector<TexelSample> samples;
  for (int i = 0; i < 12; ++i) {
    const Vec3 wi = Vec3(u(rng), u(rng), 0.9).normalized(), wo = Vec3(u(rng), u(rng), 0.85).normalized();
    samples.push_back({{wi.x(), wi.y(), wi.z()}, {wo.x(), wo.y(), wo.z()}, 0.6 + u(rng), {0.2 + u(rng) * 0.3, 0.1, 0.05}});
  }
  for (const bool per_channel : {true, false}) {
    std::vector<normals::WeightSource> sources(2);  // two sources: samples 0-7 and 8-11
    for (int j = 0; j < 2; ++j) {
      sources[j].per_channel = per_channel;
      sources[j].prior = 0.5;
      for (const BasisMaterial* m : {&lambert, &plastic}) {
        WeightedBasis b;
        b.spec = &m->spec;
        b.params = m->params;
        b.w[0] = 0.3, b.w[1] = 0.4, b.w[2] = 0.5;  // prior targets
        sources[j].basis.push_back(b);
      }
    }
    for (int i = 0; i < 12; ++i) sources[i < 8 ? 0 : 1].members.push_back(i);
    const std::vector<double> weight(12, 0.7);
    const double cauchy = 0.2, prior_scale = 0.1;
    const normals::NormalJointCost joint{&samples, &sources, &weight, cauchy, prior_scale};
    const double ab[2] = {0.07, -0.12};
    std::vector<double> r(3 * 12 + 2);
    ASSERT_TRUE(joint(ab, r.data()));
    // Reference: per source, the weights by NNLS on its predictions at ab.
    std::vector<std::vector<WeightedBasis>> solved(2);
    for (int j = 0; j < 2; ++j) {
      const int m = 2, n = int(sources[j].members.size());
      std::vector<std::array<double, 6>> P;
      for (int i : sources[j].members) {
        std::array<double, 6> row;
        for (int k = 0; k < m; ++k) normals::PredictBasis(sources[j].basis[k], samples[i], ab, &row[3 * k]);
        P.push_back(row);
      }
      solved[j] = sources[j].basis;
      for (int q = 0; q < (per_channel ? 3 : 1); ++q) {
        Eigen::MatrixXd A = Eigen::MatrixXd::Zero(m, m);
        Eigen::VectorXd b = Eigen::VectorXd::Zero(m), target(m);
        for (int s = 0; s < n; ++s)
          for (int c = per_channel ? q : 0; c < (per_channel ? q + 1 : 3); ++c)
            for (int k = 0; k < m; ++k) {
              b[k] += P[s][3 * k + c] * samples[sources[j].members[s]].y[c];
              for (int l = 0; l < m; ++l) A(k, l) += P[s][3 * k + c] * P[s][3 * l + c];
            }
        for (int k = 0; k < m; ++k) target[k] = per_channel ? 0.3 + 0.1 * q : 0.4;
        const double lambda = 0.5 * A.trace() / (m * n) + 1e-12;
        A.diagonal().array() += lambda;
        b += lambda * target;
        const Eigen::VectorXd w = NnlsNormal(A, b);
        for (int k = 0; k < m; ++k)
          for (int c = 0; c < 3; ++c)
            if (!per_channel || c == q) solved[j][k].w[c] = w[k];
      }
    }
    std::vector<const std::vector<WeightedBasis>*> per_sample;
    for (int i = 0; i < 12; ++i) per_sample.push_back(&solved[i < 8 ? 0 : 1]);
    const normals::NormalBatchCost batch{&samples, &per_sample, &weight, cauchy, prior_scale};
    std::vector<double> rb(r.size());
    ASSERT_TRUE(batch(ab, rb.data()));
    for (size_t i = 0; i < r.size(); ++i) EXPECT_NEAR(r[i], rb[i], 1e-10) << "residual " << i;
    // Jets through the weights' solve against central differences.
    using Jet2 = ceres::Jet<double, 2>;
    const Jet2 abj[2] = {Jet2(ab[0], 0), Jet2(ab[1], 1)};
    std::vector<Jet2> rj(r.size());
    ASSERT_TRUE(joint(abj, rj.data()));
    for (int d = 0; d < 2; ++d) {
      const double h = 1e-6;
      double p[2] = {ab[0], ab[1]}, m2[2] = {ab[0], ab[1]};
      p[d] += h, m2[d] -= h;
      std::vector<double> rp(r.size()), rm(r.size());
      joint(p, rp.data());
      joint(m2, rm.data());
      for (size_t i = 0; i < r.size(); ++i) {
        const double fd = (rp[i] - rm[i]) / (2 * h);
        EXPECT_NEAR(rj[i].v[d], fd, 1e-5 * (1 + std::abs(fd))) << "residual " << i << " d" << d;
      }
    }
  }
}

TEST(NormalMap, RoundTripsThroughTheMaterialLookup) {
  const Patch p = MakePatch(Lambert(), 4, 20.0, 3, 0.0, 6);
  Material m;
  m.width = m.height = 4;
  m.normal_map = NormalMapImage(p.atlas, p.truth, NormalMapSpace::kWorld);
  const NormalErrors e = CompareNormals(p.atlas, p.truth, m);
  EXPECT_LT(e.mean_deg, 1e-4);
  Material none;  // without a map the truth is the mesh normal
  const NormalErrors z = CompareNormals(p.atlas, std::vector<Vec3>(16, Vec3(0, 0, 1)), none);
  EXPECT_EQ(z.mean_deg, 0.0);
}

// On a flat mesh the tangent frame is the same everywhere, so a map written
// in world space and the same normals written in tangent space give the same
// normals at texel centres (MaterialNormal) and, interpolated, anywhere
// (the shader's lookup); the plane is tilted and its UVs turned 30 deg so
// that T, B are no axes of the world. A round trip through the map gives
// the normals back.
TEST(NormalMap, WorldAndTangentSpaceAgreeOnAFlatMesh) {
  const Vec3 n = Vec3(0.3, -0.4, 0.866).normalized();
  const Frame f = Frame::FromNormal(n);
  Mesh mesh;
  for (const Vec2& q : {Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(0, 1)}) {
    mesh.positions.push_back(0.5 * (q.x() * f.t + q.y() * f.b));
    const double c = std::cos(kPi / 6), s = std::sin(kPi / 6);  // UVs turned 30 deg, inside [0, 1]
    mesh.texcoords.push_back(Vec2(0.2 + 0.55 * (c * q.x() - s * q.y()) + 0.3, 0.1 + 0.55 * (s * q.x() + c * q.y())));
  }
  mesh.faces = {Vec3i(0, 1, 2), Vec3i(0, 2, 3)};
  mesh.face_uvs = mesh.faces;
  mesh.ComputeNormals();
  const int res = 16;
  const Atlas atlas = BuildAtlas(mesh, res, res);
  ASSERT_GT(atlas.texels.size(), 60u);
  Rng rng(3);
  std::normal_distribution<double> g(0.0, 0.3);
  std::vector<Vec3> normals;
  for (size_t t = 0; t < atlas.texels.size(); ++t) normals.push_back((n + g(rng) * f.t + g(rng) * f.b).normalized());
  Material world, tangent;
  world.width = world.height = tangent.width = tangent.height = res;
  world.normal_map = NormalMapImage(atlas, normals, NormalMapSpace::kWorld);
  tangent.normal_map = NormalMapImage(atlas, normals, NormalMapSpace::kTangent);
  tangent.normal_map_space = NormalMapSpace::kTangent;
  EXPECT_GT((Vec3(tangent.normal_map.at(atlas.texels[0].x, atlas.texels[0].y, 0), 0, 0) -
             Vec3(world.normal_map.at(atlas.texels[0].x, atlas.texels[0].y, 0), 0, 0)).norm(), 1e-3);  // not the same numbers
  for (size_t t = 0; t < atlas.texels.size(); ++t) {
    const Vec3 a = MaterialNormal(world, atlas.texels[t], atlas), b = MaterialNormal(tangent, atlas.texels[t], atlas);
    EXPECT_LT((a - normals[t]).norm(), 1e-6) << t;
    EXPECT_LT((b - normals[t]).norm(), 1e-6) << t;
  }
  const Vec3 dpdu = mesh.FaceDpDu(0);
  std::uniform_real_distribution<double> u(2.0, res - 2.0);
  for (int i = 0; i < 200; ++i) {
    const double x = u(rng), y = u(rng);
    Vec3 vw, vt;
    for (int c = 0; c < 3; ++c) vw[c] = world.normal_map.Bilinear(x, y, c), vt[c] = tangent.normal_map.Bilinear(x, y, c);
    const Vec3 a = NormalFromMapValue(vw, NormalMapSpace::kWorld, n, dpdu);
    const Vec3 b = NormalFromMapValue(vt, NormalMapSpace::kTangent, n, dpdu);
    EXPECT_LT((a - b).norm(), 1e-6) << x << ", " << y;
  }
  // Zero texels (outside the atlas) mean the mesh normal in both spaces.
  EXPECT_EQ(NormalFromMapValue(Vec3::Zero(), NormalMapSpace::kTangent, n, dpdu), n);
  EXPECT_EQ(NormalFromMapValue(Vec3::Zero(), NormalMapSpace::kWorld, n, dpdu), n);
}

}  // namespace
}  // namespace svbrdf
