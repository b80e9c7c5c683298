// The Jet arithmetic of the model evaluation dominates; as lib/fit/batch_cost.cc,
// force Eigen's fixed-size loops inline (results unchanged, much faster there).
#define EIGEN_STRONG_INLINE inline __attribute__((always_inline))
#include "normals/basis_polish.h"

#include <ceres/ceres.h>
#include <ceres/dynamic_autodiff_cost_function.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>
#include <thread>

#include "brdf/model_eval.h"
#include "cluster/holdout.h"
#include "core/error.h"
#include "core/rng.h"
#include "normals/normal_cost.h"

#pragma GCC diagnostic ignored "-Warray-bounds"  // as batch_cost.cc: model dispatch branches never taken

namespace svbrdf {

namespace {

using normals::TexelSample;

// Share of a texel's weight another material may hold for the texel to count as interior.
constexpr double kOtherWeightShare = 1e-3;
// Levenberg-Marquardt iterations of the joint solve.
constexpr int kMaxIterations = 30;

// One interior texel's residuals: 3 per training sample, 2 of the prior;
// parameter blocks theta_k (the model's parameters) and (a, b).
struct TexelCost {
  const ModelSpec* spec;
  std::vector<TexelSample> samples;
  std::vector<double> sqrt_v;  // sqrt of the shot-noise weight per sample
  double w[3];                 // the texel's weight of the material per channel (held)
  double cauchy = 0;
  double prior_scale = 0, prior_mean[2] = {0, 0};

  template <class T>
  bool operator()(T const* const* p, T* r) const {
    const T* theta = p[0];
    const T* ab = p[1];
    for (size_t i = 0; i < samples.size(); ++i) {
      const TexelSample& s = samples[i];
      T* ri = r + 3 * i;
      T rgb[3] = {T(0), T(0), T(0)};
      normals::ForEachSampleFrame(ab, s, [&](const Vec3T<T>& wi, const Vec3T<T>& wo, const T& shading) {
        T f[3];
        EvalModel(*spec, theta, wi, wo, f);
        for (int c = 0; c < 3; ++c) rgb[c] += f[c] * w[c] * shading;
      });
      for (int c = 0; c < 3; ++c) ri[c] = sqrt_v[i] * (rgb[c] - s.y[c]);
      normals::ApplyCauchy(cauchy, ri);
    }
    const size_t n = samples.size();
    r[3 * n] = prior_scale * (ab[0] - prior_mean[0]);
    r[3 * n + 1] = prior_scale * (ab[1] - prior_mean[1]);
    return true;
  }
};

}  // namespace

std::vector<BasisPolishReport> PolishBasisWithTilts(const SampleSet& s, const Atlas& atlas, const NormalOptions& no,
                                                    const std::vector<Vec2>& tilt,
                                                    const std::vector<char>& material_kept, double sigma,
                                                    int64_t max_samples, SvbrdfEstimate* est) {
  std::vector<BasisPolishReport> out;
  const int nt = s.num_texels, K = int(est->basis.size());
  if (int(tilt.size()) != nt || int(est->label.size()) != nt || !(sigma > 0)) return out;
  int num_images = 0;
  for (int32_t im : s.image) num_images = std::max(num_images, im + 1);
  const std::vector<char> held = HeldOutImages(num_images, no.holdout_fraction, no.seed);
  // Shot-noise weights as RefineNormals'.
  const ShotNoiseWeights noise = MakeShotNoiseWeights(s, no.shot_noise);
  std::vector<Frame> frames(nt);
  for (int t = 0; t < nt; ++t) frames[t] = Frame::FromNormalTangent(atlas.texels[t].normal, atlas.texels[t].tangent);
  const double max_ab = std::tan(no.max_tilt_deg * kPi / 180.0);
  const double cauchy = no.robust_sigmas > 0 ? std::max(1e-12, no.robust_sigmas * sigma) : 0.0;

  for (int k = 0; k < K; ++k) {
    if (k >= int(material_kept.size()) || !material_kept[k]) continue;
    const ModelSpec& spec = est->basis[k].spec;
    const int np = spec.NumParams();
    if (np > normals::kMaxModelParams) continue;
    // Interior texels of k in seeded-hash order, until max_samples.
    std::vector<std::pair<uint64_t, int>> keyed;
    for (int t = 0; t < nt; ++t) {
      if (est->label[t] != k) continue;
      const std::vector<int> nb = TexelNeighbours8(atlas, t, nt);
      if (nb.size() < 8 || std::any_of(nb.begin(), nb.end(), [&](int u) { return est->label[u] != k; })) continue;
      double wk = 0, other = 0;
      for (int j = 0; j < K; ++j)
        for (int c = 0; c < 3; ++c) (j == k ? wk : other) += est->weights[(size_t(t) * K + j) * 3 + c];
      if (!(wk > 0) || other > kOtherWeightShare * wk) continue;
      keyed.emplace_back(StreamSeed(no.seed, uint64_t(t), 0x706f6c), t);
    }
    std::sort(keyed.begin(), keyed.end());
    BasisPolishReport rep;
    rep.material = k;
    rep.params_before = est->basis[k].params;
    std::vector<double> theta = est->basis[k].params;
    std::vector<double> ab(2 * keyed.size(), 0.0);
    ceres::Problem::Options po;
    ceres::Problem problem(po);
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (size_t j = 0; j < keyed.size() && rep.samples < max_samples; ++j) {
      const int t = keyed[j].second;
      auto* cost = new TexelCost;
      cost->spec = &spec;
      for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) {
        if (held[s.image[i]]) continue;
        TexelSample ts;
        for (int c = 0; c < 3; ++c) ts.wi[c] = s.wi[c][i], ts.wo[c] = s.wo[c][i], ts.y[c] = s.y[c][i];
        ts.geom = s.geom[i];
        ts.SetFootprint(s, i);
        cost->samples.push_back(ts);
        cost->sqrt_v.push_back(std::sqrt(noise(ts.y)));
      }
      if (int64_t(cost->samples.size()) < no.min_own_samples) {
        delete cost;
        continue;
      }
      for (int c = 0; c < 3; ++c) cost->w[c] = est->weights[(size_t(t) * K + k) * 3 + c];
      cost->cauchy = cauchy;
      // Priors as RefineNormals' own-sample passes: towards the mesh normal
      // and towards each neighbour's current tilt (in t's tangent axes).
      std::vector<Vec2> neighbour_tilts;
      for (int u : TexelNeighbours8(atlas, t, nt)) {
        Vec2 in_t;
        if (NeighbourTiltInFrame(tilt[u], frames[u], frames[t], &in_t)) neighbour_tilts.push_back(in_t);
      }
      CombinedTiltPrior(no, neighbour_tilts, sigma, &cost->prior_scale, cost->prior_mean);
      const int nres = int(3 * cost->samples.size() + 2);
      rep.samples += int64_t(cost->samples.size());
      auto* fn = new ceres::DynamicAutoDiffCostFunction<TexelCost, 8>(cost);
      fn->AddParameterBlock(np);
      fn->AddParameterBlock(2);
      fn->SetNumResiduals(nres);
      double* abj = &ab[2 * j];
      abj[0] = tilt[t].x(), abj[1] = tilt[t].y();
      problem.AddResidualBlock(fn, nullptr, theta.data(), abj);
      for (int i = 0; i < 2; ++i) {
        problem.SetParameterLowerBound(abj, i, -max_ab);
        problem.SetParameterUpperBound(abj, i, max_ab);
      }
      ordering->AddElementToGroup(abj, 0);
      ++rep.texels;
    }
    if (rep.texels < 10) continue;
    const std::vector<ParamInfo> info = spec.Params();
    for (int i = 0; i < np; ++i) {
      theta[i] = std::clamp(theta[i], info[i].lower, info[i].upper);
      if (std::isfinite(info[i].lower)) problem.SetParameterLowerBound(theta.data(), i, info[i].lower);
      if (std::isfinite(info[i].upper)) problem.SetParameterUpperBound(theta.data(), i, info[i].upper);
    }
    ordering->AddElementToGroup(theta.data(), 1);
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_SCHUR;
    so.linear_solver_ordering = ordering;
    so.max_num_iterations = kMaxIterations;
    so.function_tolerance = 1e-7;
    so.num_threads = no.threads > 0 ? no.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    so.logging_type = ceres::SILENT;
    ceres::Solver::Summary sum;
    ceres::Solve(so, &problem, &sum);
    rep.iterations = int(sum.iterations.size());
    rep.cost_before = sum.initial_cost, rep.cost_after = sum.final_cost;
    const bool usable = sum.termination_type != ceres::FAILURE && std::isfinite(sum.final_cost) &&
                        std::all_of(theta.begin(), theta.end(), [](double v) { return std::isfinite(v); });
    if (usable && sum.final_cost <= sum.initial_cost) est->basis[k].params = theta;
    rep.params_after = est->basis[k].params;
    out.push_back(rep);
  }
  return out;
}

std::string Report(const BasisPolishReport& r, const SvbrdfEstimate& est) {
  std::ostringstream os;
  os << "basis m" << r.material << " (" << est.basis[r.material].spec.Label() << ") polished with the tilts of "
     << r.texels << " interior texels (" << r.samples << " samples, " << r.iterations << " iterations, cost "
     << r.cost_before << " -> " << r.cost_after << "):";
  const std::vector<ParamInfo> info = est.basis[r.material].spec.Params();
  for (size_t i = 0; i < info.size() && i < r.params_after.size(); ++i)
    os << " " << info[i].name << " " << r.params_before[i] << " -> " << r.params_after[i];
  return os.str();
}

}  // namespace svbrdf
