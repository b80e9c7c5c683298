#include "normals/refine.h"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "cluster/holdout.h"
#include "cluster/nnls.h"
#include "core/error.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "core/rng.h"
#include "normals/joint_cost.h"
#include "normals/normal_cost.h"
#include "normals/tilt_solver.h"

namespace svbrdf {

using normals::NormalSampleCost;
using normals::PredictBasis;
using normals::TexelSample;
using normals::TiltPrior;
using normals::WeightedBasis;

void NormalOptions::Check() const {
  auto fail = [](const char* name, auto value, const char* rule) {
    throw Error(Msg("normal refinement: ", name, " = ", value, ": must be ", rule));
  };
  if (mode != "on" && mode != "off" && mode != "force") fail("--normals", mode, "on, off or force");
  if (min_samples < 3) fail("min_samples", min_samples, ">= 3");
  if (!(neighbour_weight >= 0 && neighbour_weight <= 1)) fail("neighbour_weight", neighbour_weight, "in [0, 1]");
  if (!(prior_tilt > 0 && std::isfinite(prior_tilt))) fail("prior_tilt", prior_tilt, "> 0");
  if (!(smooth_tilt >= 0 && std::isfinite(smooth_tilt))) fail("smooth_tilt", smooth_tilt, ">= 0 (0 = pool the neighbours' samples)");
  if (!std::isfinite(noise)) fail("noise", noise, "finite (< 0 = estimated)");
  if (!(robust_sigmas >= 0)) fail("robust_sigmas", robust_sigmas, ">= 0");
  if (!(robust_growth >= 1)) fail("robust_growth", robust_growth, ">= 1");
  if (!(max_tilt_deg > 0 && max_tilt_deg <= 85)) fail("max_tilt_deg", max_tilt_deg, "in (0, 85]");
  if (iterations < 1) fail("iterations", iterations, ">= 1");
  if (material_rounds < 0) fail("--material-rounds", material_rounds, ">= 0");
  if (max_iterations < 1) fail("max_iterations", max_iterations, ">= 1");
  if (decision_texels < 100) fail("decision_texels", decision_texels, ">= 100");
  if (screen_texels != 0 && (screen_texels < 100 || screen_texels > decision_texels))
    fail("screen_texels", screen_texels, "0 (off) or in [100, decision_texels]");
  if (!(min_improvement >= 0 && min_improvement < 1)) fail("min_improvement", min_improvement, "in [0, 1)");
  if (!(holdout_fraction > 0 && holdout_fraction < 0.9)) fail("holdout_fraction", holdout_fraction, "in (0, 0.9)");
}

std::string NormalRefinement::Report() const {
  std::ostringstream os;
  os << "normals " << (kept ? "kept" : "not kept") << ": held-out RMSE " << heldout_rmse_mesh << " with mesh normals, "
     << heldout_rmse_refined << " refined (" << decision_texels << " texels); " << texels_refined
     << " texels refined, tilt mean " << mean_tilt_deg << " deg, median " << median_tilt_deg << " deg, noise sigma "
     << noise_sigma;
  for (size_t k = 0; k < heldout_rmse_mesh_by_material.size(); ++k)
    os << "; m" << k << (material_kept[k] ? " kept" : " not kept") << " (" << heldout_rmse_mesh_by_material[k] << " -> "
       << heldout_rmse_refined_by_material[k] << ")";
  return os.str();
}

namespace {

// Weight of the clustering's weights in the re-solve, in samples. The
// clustering's weights were fitted on every photo, held-out ones included,
// with the mesh normals: in the decision's fits on training photos they would
// leak the held-out photos into the mesh-normal arm, so there they only
// regularise (a hundredth of a sample).
constexpr double kPriorSamples = 1.0;
constexpr double kDecisionPriorSamples = 0.01;

// Per-texel state of the alternation: tilt (a, b) and mixing weights.
struct State {
  std::vector<double> ab;     // 2 per texel
  std::vector<float> w;       // K*3 per texel
};

// A texel's samples for its normal fit: its own and, in its frame, its
// 8 neighbours' (each with the texel it came from and its weight).
struct Pooled {
  std::vector<TexelSample> samples;
  std::vector<int> source;      // 0 = the texel, j > 0 = its (j-1)-th neighbour
  std::vector<double> weight;
  // Own samples only (smooth_tilt): the neighbours' current tilts in the
  // texel's frame, each a Gaussian prior of std smooth_tilt on the difference.
  std::vector<Vec2> neighbour_tilts;
};

class Refiner {
 public:
  Refiner(const SampleSet& s, const Atlas& atlas, const SvbrdfEstimate& est, const NormalOptions& o)
      : s_(s), atlas_(atlas), est_(est), o_(o), K_(int(est.basis.size())), nt_(s.num_texels) {
    if (est.num_texels != nt_ || est.weights.size() != size_t(nt_) * K_ * 3 || int(atlas.texels.size()) < nt_)
      throw Error(Msg("normal refinement: the estimate has ", est.num_texels, " texels, the samples ", nt_,
                      ", the atlas ", atlas.texels.size()));
    for (const BasisMaterial& b : est.basis) normals::CheckParamCount(b.spec);
    int num_images = 0;
    for (int32_t im : s.image) num_images = std::max(num_images, im + 1);
    held_image_ = HeldOutImages(num_images, o.holdout_fraction, o.seed);
    max_ab_ = std::tan(o.max_tilt_deg * kPi / 180.0);
    noise_ = MakeShotNoiseWeights(s, o.shot_noise);
    frames_.resize(nt_);
    neighbours_.resize(nt_);
    support_.resize(nt_);
    for (int t = 0; t < nt_; ++t) {
      const Texel& tx = atlas.texels[t];
      frames_[t] = Frame::FromNormalTangent(tx.normal, tx.tangent);
      neighbours_[t] = TexelNeighbours8(atlas, t, nt_);
    }
    for (int t = 0; t < nt_; ++t) {
      // Materials of the texel and its 8 neighbours: a tilted normal must not
      // let a material in that the clustering kept out of the neighbourhood.
      std::vector<char> used(K_, 0);
      auto mark = [&](int u) {
        for (int k = 0; k < K_; ++k)
          for (int c = 0; c < 3; ++c) used[k] |= est.weights[(size_t(u) * K_ + k) * 3 + c] > 0;
      };
      mark(t);
      for (int u : neighbours_[t]) mark(u);
      for (int k = 0; k < K_; ++k)
        if (used[k]) support_[t].push_back(k);
    }
  }

  // Samples of texel t: training ones (`which` = 0), held-out ones (1) or all (2).
  std::vector<TexelSample> Samples(int t, int which) const {
    std::vector<TexelSample> out;
    for (int64_t i = s_.texel_begin[t]; i < s_.texel_begin[t + 1]; ++i) {
      if (!Wanted(i, which)) continue;
      TexelSample ts;
      for (int c = 0; c < 3; ++c) ts.wi[c] = s_.wi[c][i], ts.wo[c] = s_.wo[c][i], ts.y[c] = s_.y[c][i];
      ts.geom = s_.geom[i];
      ts.SetFootprint(s_, i);
      out.push_back(ts);
    }
    return out;
  }

  // Texel t's samples and its neighbours' in t's mesh frame. A texel alone
  // has a handful of samples, too few for two tilt and several weight
  // unknowns (a photo's three channels share one shading term); bumps
  // wider than a texel tilt the neighbours alike, so their samples, at
  // `neighbour_weight`, make the fit determined at the price of a slight
  // smoothing of the normal field (a 3 x 3 kernel).
  // `tilt_of(u, &ab)` gives texel u's current tilt in its own frame, or
  // false when u is not being fitted (outside the decision's subset, or of a
  // material whose normals are not kept): a neighbour's samples are
  // predicted under the neighbour's normal relative to the texel's (so that,
  // as passes repeat, the pooling follows the normal field instead of
  // flattening it). A neighbour without a tilt of its own is taken to be
  // tilted like the texel (only their mesh normals differ), as all are in
  // the first pass: holding it at its mesh normal while the texel tilts
  // would make its samples ask for the texel's tilt once more on top of
  // the texel's (on the mixed preset, a decision subset started from
  // refined tilts lost much of its held-out accuracy that way).
  template <class TiltOf>
  Pooled PooledSamples(int t, int which, const TiltOf& tilt_of, bool own_only = false) const {
    Pooled p;
    p.samples = Samples(t, which);
    p.source.assign(p.samples.size(), 0);
    p.weight.resize(p.samples.size());
    for (size_t i = 0; i < p.samples.size(); ++i) p.weight[i] = NoiseWeight(p.samples[i].y);
    const Frame& ft = frames_[t];
    if (own_only) {
      // The prior is on the bump, the tilt from the mesh normal, not on the
      // normal itself: the mesh's own curvature between two texels (22
      // degrees on a 16-texel sphere) is geometry, not a tilt to smooth
      // away. The neighbour's tilt vector a t_u + b s_u, in t's tangent axes.
      for (int u : neighbours_[t]) {
        Vec2 ab_u, in_t;
        if (!tilt_of(u, &ab_u)) continue;  // not fitted: no constraint
        if (NeighbourTiltInFrame(ab_u, frames_[u], ft, &in_t)) p.neighbour_tilts.push_back(in_t);
      }
      return p;
    }
    Vec2 ab_t = Vec2::Zero();
    tilt_of(t, &ab_t);
    for (size_t j = 0; j < neighbours_[t].size(); ++j) {
      const int u = neighbours_[t][j];
      const Frame& fu = frames_[u];
      // The neighbour's normal as a tilt in t's frame, relative to t's tilt.
      Vec2 ab_u = Vec2::Zero(), ab_ref = Vec2::Zero();
      if (tilt_of(u, &ab_u)) ab_ref = ab_t;
      const Vec3 n_u = ft.ToLocal(fu.ToWorld(Vec3(ab_u.x(), ab_u.y(), 1.0)));
      const Vec2 offset =
          n_u.z() > 0.1 ? Vec2(n_u.x() / n_u.z() - ab_ref.x(), n_u.y() / n_u.z() - ab_ref.y()) : Vec2::Zero();
      for (int64_t i = s_.texel_begin[u]; i < s_.texel_begin[u + 1]; ++i) {
        if (!Wanted(i, which)) continue;
        const Vec3 wi_u(s_.wi[0][i], s_.wi[1][i], s_.wi[2][i]), wo_u(s_.wo[0][i], s_.wo[1][i], s_.wo[2][i]);
        const Vec3 wi = ft.ToLocal(fu.ToWorld(wi_u)), wo = ft.ToLocal(fu.ToWorld(wo_u));
        if (wi.z() <= 0.05 || wo.z() <= 0.05 || wi_u.z() <= 0) continue;
        TexelSample ts;
        for (int c = 0; c < 3; ++c) ts.wi[c] = wi[c], ts.wo[c] = wo[c], ts.y[c] = s_.y[c][i];
        ts.geom = s_.geom[i] / wi_u.z() * wi.z();  // the light's s, times cos_i of t's mesh normal
        ts.offset[0] = offset.x(), ts.offset[1] = offset.y();
        p.samples.push_back(ts);
        p.source.push_back(int(j) + 1);
        p.weight.push_back(o_.neighbour_weight * NoiseWeight(ts.y));
      }
    }
    return p;
  }

  int64_t OwnCount(int t, int which) const {
    int64_t n = 0;
    for (int64_t i = s_.texel_begin[t]; i < s_.texel_begin[t + 1]; ++i) n += Wanted(i, which);
    return n;
  }

  // Sample count of texel t and its weighted pooled count.
  void Counts(int t, int which, int64_t* own, double* pooled) const {
    *own = 0;
    for (int64_t i = s_.texel_begin[t]; i < s_.texel_begin[t + 1]; ++i) *own += Wanted(i, which);
    *pooled = double(*own);
    for (int u : neighbours_[t])
      for (int64_t i = s_.texel_begin[u]; i < s_.texel_begin[u + 1]; ++i) *pooled += o_.neighbour_weight * Wanted(i, which);
  }

  // Texel t's support materials with non-zero weights `w`.
  std::vector<WeightedBasis> Basis(int t, const float* w) const {
    std::vector<WeightedBasis> out = SupportBasis(t, w);
    out.erase(std::remove_if(out.begin(), out.end(),
                             [](const WeightedBasis& b) { return !(b.w[0] > 0 || b.w[1] > 0 || b.w[2] > 0); }),
              out.end());
    return out;
  }

  // Levenberg-Marquardt for the tilt (a, b) of one texel, weights fixed;
  // basis[j] holds the weighted materials of source j of the pooled samples.
  void SolveNormal(const Pooled& fit, const std::vector<std::vector<WeightedBasis>>& basis, double sigma,
                   double robust_mult, double* ab) const {
    if (basis[0].empty() || fit.samples.empty()) return;
    std::vector<const std::vector<WeightedBasis>*> per_sample(fit.samples.size());
    for (size_t i = 0; i < fit.samples.size(); ++i) per_sample[i] = &basis[fit.source[i]];
    const double cauchy = o_.robust_sigmas > 0 ? std::max(1e-12, robust_mult * o_.robust_sigmas * sigma) : 0.0;
    normals::NormalBatchCost cost{&fit.samples, &per_sample, &fit.weight, cauchy, 0.0};
    CombinedTiltPrior(o_, fit.neighbour_tilts, sigma, &cost.prior_scale, cost.prior_mean);
    normals::SolveTilt(cost, int(3 * fit.samples.size() + 2), TiltOptions(), ab);
  }

  normals::TiltSolverOptions TiltOptions() const {
    normals::TiltSolverOptions so;
    so.max_iterations = o_.max_iterations;
    // A tilt to 1e-6 is far below what a photo resolves; tighter only adds iterations.
    so.function_tolerance = 1e-6;
    so.parameter_tolerance = 1e-6;
    so.bound = max_ab_;
    return so;
  }

  // As SolveNormal, with every source's weights solved at each trial tilt
  // (joint_cost.h): the weights of source j (the texel, then its
  // neighbours) over its support, from its pooled samples, with a weak
  // prior (`prior` samples' worth) towards its current weights
  // (`weights_of(u)`: the previous pass's, re-solved under its previous
  // tilt). Towards the current rather than the clustering's weights: where
  // a texel has few samples the prior holds, and the clustering's weights,
  // fitted under the mesh normals with a model that may not fit (a
  // bump-mapped default capture's mixed cluster), are the worse guess there
  // (towards them the e2e normals test's normals are rejected; the mixed
  // preset is about the same either way). Returns false (nothing done) when
  // a support exceeds kMaxSupport.
  template <class WeightsOf>
  bool SolveNormalJoint(int t, const Pooled& fit, double prior, double sigma, double robust_mult, double* ab,
                        const WeightsOf& weights_of) const {
    if (fit.samples.empty()) return true;
    std::vector<normals::WeightSource> sources(neighbours_[t].size() + 1);
    for (size_t j = 0; j < sources.size(); ++j) {
      const int u = j == 0 ? t : neighbours_[t][j - 1];
      if (support_[u].size() > size_t(normals::kMaxSupport)) return false;
      sources[j].basis = SupportBasis(u, weights_of(u));
      sources[j].prior = prior;
      sources[j].per_channel = est_.per_channel_weights;
      sources[j].unit_sum = est_.weight_unit_sum;
    }
    for (size_t i = 0; i < fit.samples.size(); ++i) sources[fit.source[i]].members.push_back(int(i));
    if (sources[0].basis.empty()) return true;
    const double cauchy = o_.robust_sigmas > 0 ? std::max(1e-12, robust_mult * o_.robust_sigmas * sigma) : 0.0;
    normals::NormalJointCost cost{&fit.samples, &sources, &fit.weight, cauchy, 0.0};
    CombinedTiltPrior(o_, fit.neighbour_tilts, sigma, &cost.prior_scale, cost.prior_mean);
    normals::SolveTilt(cost, int(3 * fit.samples.size() + 2), TiltOptions(), ab);
    return true;
  }

  // Texel u's support materials, each with weights w0 (the prior target).
  std::vector<WeightedBasis> SupportBasis(int u, const float* w0) const {
    std::vector<WeightedBasis> out;
    for (int k : support_[u]) {
      WeightedBasis b;
      b.spec = &est_.basis[k].spec;
      b.params = est_.basis[k].params;
      for (int c = 0; c < 3; ++c) b.w[c] = w0[k * 3 + c];
      out.push_back(std::move(b));
    }
    return out;
  }

  // Mixing weights by NNLS with the normal (a, b) on the texel's own
  // samples, over its support, with a weak prior towards w0 (the clustering's).
  void SolveWeights(int t, const std::vector<TexelSample>& fit, const double* ab, const float* w0, double prior,
                    float* w) const {
    const std::vector<int>& sup = support_[t];
    const int m = int(sup.size());
    if (m == 0 || fit.empty()) {
      std::copy(w0, w0 + K_ * 3, w);
      return;
    }
    std::fill(w, w + K_ * 3, 0.0f);
    Eigen::MatrixXd AtA[3], Atb[3];
    for (int c = 0; c < 3; ++c) AtA[c] = Eigen::MatrixXd::Zero(m, m), Atb[c] = Eigen::MatrixXd::Zero(m, 1);
    Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> P(m, 3);
    std::vector<WeightedBasis> single(m);
    for (int j = 0; j < m; ++j) single[j].spec = &est_.basis[sup[j]].spec, single[j].params = est_.basis[sup[j]].params;
    for (const TexelSample& ts : fit) {
      for (int j = 0; j < m; ++j) PredictBasis(single[j], ts, ab, P.row(j).data());
      for (int c = 0; c < 3; ++c) {
        AtA[c] += P.col(c) * P.col(c).transpose();
        Atb[c] += P.col(c) * ts.y[c];
      }
    }
    const double n = double(fit.size());
    auto solve = [&](Eigen::MatrixXd A, Eigen::VectorXd b, const Eigen::VectorXd& target) {
      const double lambda = prior * A.trace() / (m * n) + 1e-12;
      // The clustering's unit-sum prior (SvbrdfEstimate::weight_unit_sum), same scale.
      const double mu = est_.weight_unit_sum * A.trace() / (m * n);
      A.diagonal().array() += lambda;
      b += lambda * target;
      A.array() += mu;
      b.array() += mu;
      return NnlsNormal(A, b);
    };
    if (est_.per_channel_weights) {
      for (int c = 0; c < 3; ++c) {
        Eigen::VectorXd target(m);
        for (int j = 0; j < m; ++j) target[j] = w0[sup[j] * 3 + c];
        const Eigen::VectorXd x = solve(AtA[c], Atb[c].col(0), target);
        for (int j = 0; j < m; ++j) w[sup[j] * 3 + c] = float(x[j]);
      }
    } else {
      Eigen::VectorXd target(m);
      for (int j = 0; j < m; ++j) target[j] = (w0[sup[j] * 3] + w0[sup[j] * 3 + 1] + w0[sup[j] * 3 + 2]) / 3.0;
      const Eigen::VectorXd x = solve(AtA[0] + AtA[1] + AtA[2], (Atb[0] + Atb[1] + Atb[2]).col(0), target);
      for (int j = 0; j < m; ++j)
        for (int c = 0; c < 3; ++c) w[sup[j] * 3 + c] = float(x[j]);
    }
  }

  // Residuals (per channel) of the texel's own samples under (a, b) and weights w.
  void Residuals(int t, const std::vector<TexelSample>& samples, const double* ab, const float* w,
                 std::vector<float>* abs_residuals, double* sse) const {
    const std::vector<WeightedBasis> basis = Basis(t, w);
    for (const TexelSample& ts : samples) {
      double r[3];
      NormalSampleCost{&ts, &basis}(ab, r);
      const double white = std::sqrt(NoiseWeight(ts.y));
      for (int c = 0; c < 3; ++c) {
        if (abs_residuals) abs_residuals->push_back(float(white * std::abs(r[c])));
        if (sse) *sse += r[c] * r[c];
      }
    }
  }

  // Robust noise estimate: 1.4826 x the median |residual| over the own
  // samples (kind `which`) of `texels`.
  double Sigma(const std::vector<int>& texels, int which, const State& st) const {
    if (o_.noise >= 0) return std::max(o_.noise, 1e-12);
    std::vector<std::vector<float>> per(texels.size());
    ParallelFor(long(texels.size()), o_.threads, [&](long j) {
      const int t = texels[j];
      Residuals(t, Samples(t, which), &st.ab[2 * size_t(j)], &st.w[size_t(j) * K_ * 3], &per[j], nullptr);
    }, 64);
    std::vector<float> all;
    for (auto& v : per) all.insert(all.end(), v.begin(), v.end());
    if (all.empty()) return 1e-12;
    std::nth_element(all.begin(), all.begin() + all.size() / 2, all.end());
    return std::max(1e-12, 1.4826 * all[all.size() / 2]);
  }

  // Alternates normals and weights on `texels` (state index j = position in
  // `texels`), fitting samples of kind `which` (0 training, 2 all). With
  // `refine` false only the weights are solved (mesh normals). Each pass
  // solves all normals from the previous weights, then all weights (Jacobi:
  // the result does not depend on the thread count). Returns sigma, or a
  // negative value when the deadline (NormalOptions) came before a pass.
  double Run(const std::vector<int>& texels, int which, bool refine, const std::vector<Vec2>* start, State* st,
             Progress* progress) const {
    const long n = long(texels.size());
    std::vector<int> slot(nt_, -1);
    for (long j = 0; j < n; ++j) slot[texels[j]] = int(j);
    // Weights of texel u in the current state (the clustering's when u is not refined).
    auto weights_of = [&](int u) -> const float* {
      return slot[u] >= 0 ? &st->w[size_t(slot[u]) * K_ * 3] : Est(u);
    };
    auto solve_weights = [&] {
      ParallelFor(n, o_.threads, [&](long j) {
        const int t = texels[j];
        SolveWeights(t, Samples(t, which), &st->ab[2 * j], Est(t), which == 2 ? kPriorSamples : kDecisionPriorSamples,
                     &st->w[size_t(j) * K_ * 3]);
      }, 64);
    };
    // Start: mesh normals (or `start`), weights re-solved from the
    // clustering's (the same solver for both arms of the decision).
    for (long j = 0; j < n; ++j) {
      st->ab[2 * j] = refine && start ? (*start)[texels[j]].x() : 0.0;
      st->ab[2 * j + 1] = refine && start ? (*start)[texels[j]].y() : 0.0;
    }
    solve_weights();
    double sigma = Sigma(texels, which, *st);
    if (!refine) return sigma;
    for (int it = 0; it < o_.iterations; ++it) {
      if (std::chrono::steady_clock::now() > o_.deadline) return -1.0;
      const double robust_mult = std::pow(o_.robust_growth, o_.iterations - 1 - it);
      const std::vector<double> ab_before = st->ab;  // read by neighbours while st->ab is written
      auto tilt_of = [&](int u, Vec2* ab) {
        if (slot[u] < 0) return false;
        *ab = Vec2(ab_before[2 * slot[u]], ab_before[2 * slot[u] + 1]);
        return true;
      };
      ParallelFor(n, o_.threads, [&](long j) {
        const int t = texels[j];
        // Pass 0 pools the neighbours' samples; later passes (smooth_tilt)
        // fit the own samples with the neighbours' tilts as a prior.
        const Pooled fit = PooledSamples(t, which, tilt_of, o_.smooth_tilt > 0 && it > 0 && OwnCount(t, which) >= o_.min_own_samples);
        // The weights inside the tilt fit are nuisance parameters, held by the
        // final fit's prior (one sample's worth) in both arms: at the
        // decision's hundredth of a sample, a source seen in a few training
        // photos fits its per-channel weights to them almost whatever the
        // tilt (mixed_tiny: its matte's held-out error with refined normals
        // far above the mesh normals' at a hundredth, about equal at one).
        if (!o_.joint_weights || !SolveNormalJoint(t, fit, kPriorSamples, sigma, robust_mult, &st->ab[2 * j], weights_of)) {
          std::vector<std::vector<WeightedBasis>> basis{Basis(t, weights_of(t))};
          for (int u : neighbours_[t]) basis.push_back(Basis(u, weights_of(u)));
          SolveNormal(fit, basis, sigma, robust_mult, &st->ab[2 * j]);
        }
        if (progress) progress->Tick();
      }, 16);
      solve_weights();
      // Re-estimated after every pass, own-sample passes too: the pooled
      // pass's residuals hold its blur, and a sigma frozen there makes both
      // priors too strong (default_bump, true basis and weights;
      // bench_results/bump_default.md).
      sigma = Sigma(texels, which, *st);
    }
    return sigma;
  }

  // Held-out squared error and (when `count` is not null) channel count per
  // texel (index j of `texels`).
  void HeldoutSse(const std::vector<int>& texels, const State& st, std::vector<double>* sse,
                  std::vector<int64_t>* count) const {
    sse->assign(texels.size(), 0.0);
    if (count) count->assign(texels.size(), 0);
    ParallelFor(long(texels.size()), o_.threads, [&](long j) {
      const std::vector<TexelSample> held = Samples(texels[j], 1);
      Residuals(texels[j], held, &st.ab[2 * j], &st.w[size_t(j) * K_ * 3], nullptr, &(*sse)[j]);
      if (count) (*count)[j] = 3 * int64_t(held.size());
    }, 64);
  }

  const float* Est(int t) const { return &est_.weights[size_t(t) * K_ * 3]; }
  // Basis material of texel t: its label, else its largest weight.
  int Material(int t) const {
    if (size_t(t) < est_.label.size() && est_.label[t] >= 0 && est_.label[t] < K_) return est_.label[t];
    int best = 0;
    double most = -1;
    for (int k = 0; k < K_; ++k) {
      const float* w = Est(t) + k * 3;
      if (w[0] + w[1] + w[2] > most) most = w[0] + w[1] + w[2], best = k;
    }
    return best;
  }
  int K() const { return K_; }
  bool Wanted(int64_t i, int which) const {
    const bool held = held_image_[s_.image[i]];
    return which == 2 || (which == 1) == held;
  }

 private:
  const SampleSet& s_;
  const Atlas& atlas_;
  const SvbrdfEstimate& est_;
  const NormalOptions& o_;
  const int K_, nt_;
  std::vector<char> held_image_;
  std::vector<Frame> frames_;
  std::vector<std::vector<int>> neighbours_;
  std::vector<std::vector<int>> support_;
  double max_ab_ = 1.0;
  ShotNoiseWeights noise_;

 public:
  // Inverse relative variance of a sample of colour y (1 without shot_noise).
  double NoiseWeight(const double* y) const { return noise_(y); }
};

State MakeState(size_t n, int K) { return State{std::vector<double>(2 * n, 0.0), std::vector<float>(n * K * 3, 0.0f)}; }

}  // namespace

NormalRefinement RefineNormals(const SampleSet& samples, const Atlas& atlas, const SvbrdfEstimate& est,
                               const NormalOptions& o, const std::vector<Vec2>* start) {
  o.Check();
  NormalRefinement out;
  const int nt = samples.num_texels;
  out.normal.resize(nt);
  out.refined.assign(nt, 0);
  out.tilt.assign(nt, Vec2::Zero());
  if (start && int(start->size()) != nt) throw Error("normal refinement: start tilts do not match the texels");
  out.weights = est.weights;
  for (int t = 0; t < nt; ++t) out.normal[t] = atlas.texels[t].normal;
  if (!o.Enabled() || est.basis.empty()) return out;
  const Refiner r(samples, atlas, est, o);
  const int K = r.K();

  // Texels with enough samples: all of them for the final fit, those with
  // enough training and some held-out samples for the decision.
  std::vector<int> texels, candidates;
  for (int t = 0; t < nt; ++t) {
    int64_t own_all, own_train, own_held;
    double pooled_all, pooled_train, pooled_held;
    r.Counts(t, 2, &own_all, &pooled_all);
    r.Counts(t, 0, &own_train, &pooled_train);
    r.Counts(t, 1, &own_held, &pooled_held);
    if (own_all >= 1 && pooled_all >= o.min_samples) texels.push_back(t);
    // The decision needs texels that can be fitted on training photos alone.
    if (own_train >= 1 && pooled_train >= o.min_samples && own_held > 0) candidates.push_back(t);
  }
  if (texels.empty()) return out;
  // A seeded subset for the decision (hash order, then texel order), and
  // the screening decision's: the first of the same hash order.
  std::vector<int> screen;
  {
    std::vector<std::pair<uint64_t, int>> keyed;
    for (int t : candidates) keyed.emplace_back(StreamSeed(o.seed, uint64_t(t), 0x6e6d), t);
    std::sort(keyed.begin(), keyed.end());
    if (long(keyed.size()) > o.decision_texels) keyed.resize(o.decision_texels);
    candidates.clear();
    for (const auto& kv : keyed) candidates.push_back(kv.second);
    if (o.screen_texels > 0 && !start && long(candidates.size()) > o.screen_texels)
      screen.assign(candidates.begin(), candidates.begin() + o.screen_texels);
    std::sort(candidates.begin(), candidates.end());
    std::sort(screen.begin(), screen.end());
  }
  const bool decide = o.mode == "on" && !candidates.empty();
  out.material_kept.assign(K, 1);
  Progress progress("refine normals",
                    long(o.iterations) * (long(texels.size()) + (decide ? long(candidates.size() + screen.size()) : 0)),
                    o.progress);

  // The decision's two arms on `subset`, into out's decision fields (out.kept
  // its verdict). False when the deadline stopped it.
  auto decide_on = [&](const std::vector<int>& subset) {
    out.decision_texels = long(subset.size());
    State mesh = MakeState(subset.size(), K), tilted = MakeState(subset.size(), K);
    r.Run(subset, 0, false, nullptr, &mesh, nullptr);
    if (r.Run(subset, 0, true, start, &tilted, &progress) < 0) return false;
    // Per basis material (the texel's largest weight): refined normals are
    // kept for the texels of the materials whose held-out error they lower.
    // A material whose normals the data cannot locate (a glossy lobe seen by
    // too few samples, a wrong model) must not cost the others theirs.
    std::vector<double> sse_m, sse_t;
    std::vector<int64_t> n_m;  // the same held-out samples in both arms
    r.HeldoutSse(subset, mesh, &sse_m, &n_m);
    r.HeldoutSse(subset, tilted, &sse_t, nullptr);
    std::vector<double> mat_mesh(K, 0.0), mat_tilted(K, 0.0);
    std::vector<int64_t> mat_count(K, 0);
    for (size_t j = 0; j < subset.size(); ++j) {
      const int k = r.Material(subset[j]);
      mat_mesh[k] += sse_m[j], mat_tilted[k] += sse_t[j], mat_count[k] += n_m[j];
    }
    out.material_kept.assign(K, 0);
    out.heldout_rmse_mesh_by_material.clear();
    out.heldout_rmse_refined_by_material.clear();
    for (int k = 0; k < K; ++k) {
      out.material_kept[k] = mat_count[k] > 0 && mat_tilted[k] < (1.0 - o.min_improvement) * mat_mesh[k];
      out.heldout_rmse_mesh_by_material.push_back(std::sqrt(mat_mesh[k] / std::max<int64_t>(1, mat_count[k])));
      out.heldout_rmse_refined_by_material.push_back(std::sqrt(mat_tilted[k] / std::max<int64_t>(1, mat_count[k])));
    }
    double sse_mesh = 0, sse_chosen = 0;
    int64_t n_mesh = 0;
    for (size_t j = 0; j < subset.size(); ++j) {
      sse_mesh += sse_m[j], n_mesh += n_m[j];
      sse_chosen += out.material_kept[r.Material(subset[j])] ? sse_t[j] : sse_m[j];
    }
    out.heldout_rmse_mesh = std::sqrt(sse_mesh / std::max<int64_t>(1, n_mesh));
    // The error of the chosen normals (refined where kept, mesh elsewhere).
    out.heldout_rmse_refined = std::sqrt(sse_chosen / std::max<int64_t>(1, n_mesh));
    // And the chosen normals must lower the held-out error of all texels by
    // min_improvement too: a material kept by a hair (noise in its few
    // decision texels) is not worth a normal map.
    out.kept = std::find(out.material_kept.begin(), out.material_kept.end(), 1) != out.material_kept.end() &&
               sse_chosen < (1.0 - o.min_improvement) * sse_mesh;
    return true;
  };

  out.kept = true;
  auto decision_start = std::chrono::steady_clock::now();
  if (decide) {
    // Anytime: a decision stopped by the deadline keeps the mesh normals.
    bool stopped = !screen.empty() && !decide_on(screen);
    // A screen that keeps no normals decides; one that keeps some leaves the
    // decision to the full one.
    const bool full = !stopped && (screen.empty() || out.kept);
    decision_start = std::chrono::steady_clock::now();
    if (full) stopped = !decide_on(candidates);
    if (stopped) {
      out.kept = false;
      out.cut_by_deadline = true;
      progress.Finish();
      return out;
    }
    if (!out.kept) std::fill(out.material_kept.begin(), out.material_kept.end(), 0);
    // Only the texels of kept materials are fitted on all photos.
    std::vector<int> kept_texels;
    for (int t : texels)
      if (out.material_kept[r.Material(t)]) kept_texels.push_back(t);
    texels.swap(kept_texels);
    // The final fit refines every texel once, the decision the candidates
    // twice (mesh and tilted arms): its cost scales from the decision's.
    const auto now = std::chrono::steady_clock::now();
    const double estimate = std::chrono::duration<double>(now - decision_start).count() * double(texels.size()) /
                            (2.0 * double(candidates.size()));
    if (out.kept && o.deadline != std::chrono::steady_clock::time_point::max() &&
        now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(estimate)) >
            o.deadline) {
      out.kept = false;
      out.cut_by_deadline = true;
    }
  }
  if (!out.kept) {
    progress.Finish();
    return out;
  }

  State st = MakeState(texels.size(), K);
  out.noise_sigma = r.Run(texels, 2, true, start, &st, &progress);
  progress.Finish();
  if (out.noise_sigma < 0) {  // stopped by the deadline: nothing kept
    out.kept = false;
    std::fill(out.material_kept.begin(), out.material_kept.end(), 0);
    out.cut_by_deadline = true;
    out.noise_sigma = 0;
    return out;
  }
  std::vector<double> tilt;
  for (size_t j = 0; j < texels.size(); ++j) {
    const int t = texels[j];
    const Texel& tx = atlas.texels[t];
    const Vec3 local = Vec3(st.ab[2 * j], st.ab[2 * j + 1], 1.0).normalized();
    out.normal[t] = Frame::FromNormalTangent(tx.normal, tx.tangent).ToWorld(local).normalized();
    out.refined[t] = 1;
    out.tilt[t] = Vec2(st.ab[2 * j], st.ab[2 * j + 1]);
    std::copy(st.w.begin() + j * K * 3, st.w.begin() + (j + 1) * K * 3, out.weights.begin() + size_t(t) * K * 3);
    tilt.push_back(std::acos(std::clamp(local.z(), -1.0, 1.0)) * 180.0 / kPi);
  }
  out.texels_refined = long(texels.size());
  double sum = 0;
  for (double a : tilt) sum += a;
  out.mean_tilt_deg = sum / tilt.size();
  std::nth_element(tilt.begin(), tilt.begin() + tilt.size() / 2, tilt.end());
  out.median_tilt_deg = tilt[tilt.size() / 2];
  return out;
}

}  // namespace svbrdf

namespace svbrdf {

SampleSet ReorientSamples(const SampleSet& s, const std::vector<Vec2>& tilt) {
  if (int(tilt.size()) != s.num_texels) throw Error("ReorientSamples: one tilt per texel needed");
  SampleSet out;
  out.num_texels = s.num_texels;
  out.Reserve(s.size());
  out.texel_begin.push_back(0);
  for (int t = 0; t < s.num_texels; ++t) {
    const double ab[2] = {tilt[t].x(), tilt[t].y()};
    for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) {
      TexelSample ts;
      for (int c = 0; c < 3; ++c) ts.wi[c] = s.wi[c][i], ts.wo[c] = s.wo[c][i];
      Vec3 wi, wo;
      double ratio;
      if (!normals::TiltedDirections(ab, ts, &wi, &wo, &ratio)) continue;
      const float fwi[3] = {float(wi.x()), float(wi.y()), float(wi.z())};
      const float fwo[3] = {float(wo.x()), float(wo.y()), float(wo.z())};
      const float y[3] = {s.y[0][i], s.y[1][i], s.y[2][i]};
      out.Push(t, s.image[i], fwi, fwo, float(s.geom[i] * ratio), y);
      // The footprint's normals keep their tilts relative to the refined normal.
      if (s.HasFootprint())
        out.footprint.insert(out.footprint.end(), s.footprint.begin() + 3 * SampleSet::kFootprintSubsamples * i,
                             s.footprint.begin() + 3 * SampleSet::kFootprintSubsamples * (i + 1));
    }
    out.texel_begin.push_back(out.size());
  }
  return out;
}

std::vector<int> TexelNeighbours8(const Atlas& atlas, int t, int num_texels) {
  std::vector<int> u;
  const Texel& tx = atlas.texels[t];
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int x = tx.x + dx, y = tx.y + dy;
      if ((dx || dy) && x >= 0 && y >= 0 && x < atlas.width && y < atlas.height && atlas.At(x, y) >= 0 &&
          atlas.At(x, y) < num_texels)
        u.push_back(atlas.At(x, y));
    }
  return u;
}

bool NeighbourTiltInFrame(const Vec2& ab, const Frame& from, const Frame& to, Vec2* out) {
  if (from.n.dot(to.n) < 0.5) return false;
  const Vec3 d = ab.x() * from.t + ab.y() * from.b;
  *out = Vec2(d.dot(to.t), d.dot(to.b));
  return true;
}

void CombinedTiltPrior(const NormalOptions& o, const std::vector<Vec2>& neighbour_tilts, double sigma, double* scale,
                       double mean[2]) {
  const double p = 1.0 / (o.prior_tilt * o.prior_tilt);
  double s = 0;
  Vec2 sum = Vec2::Zero();
  if (o.smooth_tilt > 0)
    for (const Vec2& m : neighbour_tilts) s += 1.0 / (o.smooth_tilt * o.smooth_tilt), sum += m / (o.smooth_tilt * o.smooth_tilt);
  *scale = sigma * std::sqrt(p + s);
  mean[0] = sum.x() / (p + s), mean[1] = sum.y() / (p + s);
}

ShotNoiseWeights MakeShotNoiseWeights(const SampleSet& s, bool on) {
  ShotNoiseWeights w;
  if (!on || s.size() == 0) return w;
  std::vector<float> ybar;
  const int64_t stride = std::max<int64_t>(1, s.size() / 20000);
  for (int64_t i = 0; i < s.size(); i += stride) ybar.push_back((s.y[0][i] + s.y[1][i] + s.y[2][i]) / 3.0f);
  std::nth_element(ybar.begin(), ybar.begin() + ybar.size() / 2, ybar.end());
  w.y_median = std::max(1e-6, double(ybar[ybar.size() / 2]));
  return w;
}

}  // namespace svbrdf
