// Per-texel mixing weights of the basis materials (non-negative least
// squares per texel with a prior towards its cluster's material), the
// held-out error they give, and the final weights on all samples.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <numeric>

#include "cluster/clustering.h"
#include "cluster/nnls.h"
#include "cluster/stats.h"
#include "core/error.h"
#include "core/parallel.h"

namespace svbrdf {

std::string WeightModel::Label() const {
  return Msg(per_channel ? "per channel" : "scalar", ", radius ", radius,
             unit_sum_samples > 0 ? Msg(", unit sum ", unit_sum_samples) : std::string());
}

std::vector<uint8_t> Clustering::ClusterDistances() const {
  const int K = this->K();
  std::vector<uint8_t> dist(size_t(nt_) * K, kFar);
  std::deque<int> queue;
  for (int k = 0; k < K; ++k) {
    for (int t = 0; t < nt_; ++t)
      if (train_count_[t] > 0 && std::clamp(assign_[t], 0, K - 1) == k) dist[size_t(t) * K + k] = 0, queue.push_back(t);
    // Breadth-first over the 8-neighbour graph: steps = Chebyshev distance in the atlas.
    while (!queue.empty()) {
      const int t = queue.front();
      queue.pop_front();
      const uint8_t d = dist[size_t(t) * K + k];
      if (d + 1 >= kFar) continue;
      for (int u : neighbours_[t])
        if (dist[size_t(u) * K + k] > d + 1) dist[size_t(u) * K + k] = uint8_t(d + 1), queue.push_back(u);
    }
  }
  return dist;
}

double Clustering::MixtureError(const WeightModel& m, bool fit_on_all, bool eval_on_all, int64_t* count,
                                std::vector<float>* weights, std::vector<float>* residual,
                                std::vector<double>* per_texel, const std::vector<float>* smooth_from) const {
  const int K = this->K();
  if (K > kNnlsMaxUnknowns) throw Error(Msg("mixing weights: ", K, " basis materials (at most ", kNnlsMaxUnknowns, ")"));
  const std::vector<uint8_t> dist = ClusterDistances();
  std::vector<double> sse(nt_, 0.0);
  std::vector<int64_t> cnt(nt_, 0);
  const bool shown = m.display && !m.display->empty();
  if (weights) weights->assign(size_t(nt_) * K * 3, 0.0f);
  if (residual) residual->assign(nt_, 0.0f);
  ParallelFor(nt_, o_.threads, [&](long t) {
    const int64_t b = s_.texel_begin[t], e = s_.texel_begin[t + 1];
    // Texels with too few training samples would overfit K weights; they
    // are scored only when everything is fitted on all samples (final weights).
    if (e == b || (!fit_on_all && !usable_[t])) return;
    const int k0 = std::clamp(assign_[t], 0, K - 1);
    // Only materials of the clusters within `m.radius` texels mix: inside
    // a region one material (at a free brightness), in a blend zone or at a
    // junction all the materials around it. Free mixing of all K on a few
    // samples extrapolates badly to unseen light/view pairs (seen: false
    // highlights). The others' normal equations are replaced below; only
    // their diagonals (the trace prior's scale) are accumulated.
    int mixing[kNnlsMaxUnknowns];
    int n_mixing = 0;
    for (int k = 0; k < K; ++k)
      if (k == k0 || dist[size_t(t) * K + k] <= m.radius) mixing[n_mixing++] = k;
    // Second pass: the prior is the mean of the neighbours' first-pass
    // weights (a smoothness prior). Neighbours without first-pass weights
    // (too few training samples when fitting on the training set) do not
    // count: their zeros would pull the texel towards black. Without any,
    // the prior stays the texel's own cluster material.
    int neighbours = 0;
    NnlsVector neighbour_mean[3];
    if (smooth_from) {
      for (int c = 0; c < 3; ++c) neighbour_mean[c] = NnlsVector::Zero(K);
      for (int u : neighbours_[t]) {
        if (train_count_[u] == 0 || (!fit_on_all && !usable_[u])) continue;
        ++neighbours;
        for (int k = 0; k < K; ++k)
          for (int c = 0; c < 3; ++c) neighbour_mean[c][k] += (*smooth_from)[(size_t(u) * K + k) * 3 + c];
      }
      if (neighbours > 0)
        for (int c = 0; c < 3; ++c) neighbour_mean[c] /= neighbours;
    }
    std::vector<double> omega(size_t(e - b), 1.0);
    NnlsVector w[3];
    // The mixture's prediction of sample i, channel c, under the weights w.
    auto mixed = [&](int64_t i, int c) {
      double q = 0;
      for (int k = 0; k < K; ++k) q += w[c](k) * pred_[k][3 * i + c];
      return q;
    };
    NnlsMatrix AtA[3];
    NnlsVector Atb[3];
    for (int pass = 0; pass <= m.robust_passes; ++pass) {
      for (int c = 0; c < 3; ++c) AtA[c].setZero(K, K), Atb[c].setZero(K);
      for (int64_t i = b; i < e; ++i) {
        if (!fit_on_all && holdout_[i]) continue;
        const double om = omega[i - b];
        for (int c = 0; c < 3; ++c) {
          for (int k = 0; k < K; ++k) AtA[c](k, k) += om * pred_[k][3 * i + c] * pred_[k][3 * i + c];
          for (int a = 0; a < n_mixing; ++a) {
            const int k = mixing[a];
            const double pk = om * pred_[k][3 * i + c];
            Atb[c](k) += pk * s_.y[c][i];
            for (int j = 0; j < a; ++j) AtA[c](k, mixing[j]) += pk * pred_[mixing[j]][3 * i + c];
          }
        }
      }
      // Prior: the texel is its cluster's material at the brightness that fits
      // it best. Without it, K free weights on a handful of samples overfit
      // (seen: held-out error rising with K).
      NnlsVector w0 = NnlsVector::Zero(K);
      double yp = 0, pp = 0;
      int64_t nfit = 0;
      for (int64_t i = b; i < e; ++i) {
        if (!fit_on_all && holdout_[i]) continue;
        ++nfit;
        const double om = omega[i - b];
        for (int c = 0; c < 3; ++c) yp += om * pred_[k0][3 * i + c] * s_.y[c][i], pp += om * Sq(pred_[k0][3 * i + c]);
      }
      w0[k0] = pp > 0 && !(m.unit_sum_samples > 0) ? BrightnessScale(yp, pp) : 1.0;
      NnlsVector w0c[3] = {w0, w0, w0};
      double prior_samples = m.prior_samples;
      if (neighbours > 0) {
        for (int c = 0; c < 3; ++c) w0c[c] = neighbour_mean[c];
        prior_samples = m.smooth_samples;
      }
      const double per_sample = 3.0 * std::max<int64_t>(1, nfit);
      NnlsVector lambda(K);
      double trace = 0;
      for (int c = 0; c < 3; ++c) trace += AtA[c].trace();
      for (int k = 0; k < K; ++k) {
        const double own = AtA[0](k, k) + AtA[1](k, k) + AtA[2](k, k);
        lambda[k] = prior_samples * (m.per_material_prior ? own : trace / K) / per_sample + 1e-12;
      }
      const NnlsVector mean_target = (w0c[0] + w0c[1] + w0c[2]) / 3.0;
      // The unit-sum prior mu (sum_k w_k - 1)^2 per channel (the materials
      // that may not mix drop out below with their rows and columns).
      const double mu = m.unit_sum_samples * trace / K / per_sample;
      for (int c = 0; c < 3; ++c) {
        AtA[c].diagonal() += lambda;
        Atb[c] += lambda.cwiseProduct(m.per_channel ? w0c[c] : mean_target);
        if (mu > 0) AtA[c].array() += mu, Atb[c].array() += mu;
      }
      for (int k = 0; k < K; ++k)
        if (std::find(mixing, mixing + n_mixing, k) == mixing + n_mixing)
          for (int c = 0; c < 3; ++c) {
            AtA[c].row(k).setZero();
            AtA[c].col(k).setZero();
            AtA[c](k, k) = 1.0;
            Atb[c](k) = 0.0;
          }
      double moved = 0;
      if (m.per_channel) {
        for (int c = 0; c < 3; ++c) {
          AtA[c].triangularView<Eigen::StrictlyUpper>() = AtA[c].transpose();
          NnlsVector wc = NnlsNormal(AtA[c], Atb[c]);
          if (pass > 0) moved = std::max(moved, (wc - w[c]).cwiseAbs().maxCoeff());
          w[c] = std::move(wc);
        }
      } else {
        NnlsMatrix A = AtA[0] + AtA[1] + AtA[2];
        const NnlsVector w_old = w[0];
        A.triangularView<Eigen::StrictlyUpper>() = A.transpose();
        const NnlsVector sum_b = Atb[0] + Atb[1] + Atb[2];
        w[0] = w[1] = w[2] = NnlsNormal(A, sum_b);
        if (pass > 0) moved = (w[0] - w_old).cwiseAbs().maxCoeff();
      }
      // Converged (weights settle to well below a display step).
      if (pass == m.robust_passes || (pass > 0 && moved < 1e-3)) break;
      // Robust pass (Cauchy IRLS): samples that no mix of the materials
      // explains (light the fit does not model, e.g. a mirror-like texel
      // reflecting a lit neighbour) lose weight against the texel's typical
      // residual.
      std::vector<double> r2;
      double yy = 0;
      for (int64_t i = b; i < e; ++i) {
        if (!fit_on_all && holdout_[i]) continue;
        double d2 = 0;
        for (int c = 0; c < 3; ++c) {
          d2 += Sq(mixed(i, c) - s_.y[c][i]);
          yy += Sq(s_.y[c][i]);
        }
        omega[i - b] = d2;
        r2.push_back(d2);
      }
      if (r2.empty()) break;
      std::nth_element(r2.begin(), r2.begin() + r2.size() / 2, r2.end());
      const double scale2 = Sq(m.robust_c * 1.4826) * r2[r2.size() / 2] + Sq(0.01) * yy / r2.size() + 1e-30;
      double least = 1.0;
      for (int64_t i = b; i < e; ++i)
        if (fit_on_all || !holdout_[i]) least = std::min(least, omega[i - b] = 1.0 / (1.0 + omega[i - b] / scale2));
      // Every sample within the scale's reach: the re-weighted solve would
      // barely move (and most texels are like this).
      if (least > m.robust_skip) break;
    }
    double err = 0;
    int64_t n = 0;
    for (int64_t i = b; i < e; ++i) {
      if (!eval_on_all && !holdout_[i]) continue;
      for (int c = 0; c < 3; ++c) {
        const double q = mixed(i, c);
        if (shown) err += Sq(Shown(q, *m.display, s_, i, c) - Shown(s_.y[c][i], *m.display, s_, i, c));
        else err += (q - s_.y[c][i]) * (q - s_.y[c][i]);
        ++n;
      }
    }
    sse[t] = err;
    cnt[t] = n;
    if (weights)
      for (int k = 0; k < K; ++k)
        for (int c = 0; c < 3; ++c) (*weights)[(size_t(t) * K + k) * 3 + c] = float(w[c](k));
    if (residual && n) (*residual)[t] = float(std::sqrt(err / n));
  }, 256);
  *count = std::accumulate(cnt.begin(), cnt.end(), int64_t(0));
  if (per_texel) *per_texel = sse;
  return std::accumulate(sse.begin(), sse.end(), 0.0);
}

double Clustering::HeldoutRmse(const WeightModel& m, std::vector<double>* per_texel) const {
  int64_t n = 0;
  std::vector<float> first;
  if (m.smooth) MixtureError(m, false, false, &n, &first, nullptr);
  const double sse = MixtureError(m, false, false, &n, nullptr, nullptr, per_texel, m.smooth ? &first : nullptr);
  return n ? std::sqrt(sse / n) : 0.0;
}

WeightModel Clustering::SearchWeightModel(bool per_channel) const {
  WeightModel m;
  m.per_channel = per_channel;
  m.radius = o_.mix_radius;
  return m;
}

double Clustering::HeldoutRmse(bool per_channel, std::vector<double>* per_texel) const {
  return HeldoutRmse(SearchWeightModel(per_channel), per_texel);
}

double Clustering::HeldoutSse(const std::vector<float>& weights, int64_t* count) const {
  const int K = this->K();
  std::vector<double> sse(nt_, 0.0);
  std::vector<int64_t> cnt(nt_, 0);
  ParallelFor(nt_, o_.threads, [&](long t) {
    if (!usable_[t]) return;
    const float* w = &weights[size_t(t) * K * 3];
    for (int64_t i = s_.texel_begin[t]; i < s_.texel_begin[t + 1]; ++i) {
      if (!holdout_[i]) continue;
      for (int c = 0; c < 3; ++c) {
        double q = 0;
        for (int k = 0; k < K; ++k) q += w[k * 3 + c] * pred_[k][3 * i + c];
        sse[t] += (q - s_.y[c][i]) * (q - s_.y[c][i]);
        ++cnt[t];
      }
    }
  }, 256);
  *count = std::accumulate(cnt.begin(), cnt.end(), int64_t(0));
  return std::accumulate(sse.begin(), sse.end(), 0.0);
}

void Clustering::FinalWeights(const WeightModel& m, std::vector<float>* weights, std::vector<float>* residual) const {
  int64_t n = 0;
  std::vector<float> first;
  if (m.smooth) MixtureError(m, true, true, &n, &first, nullptr);
  MixtureError(m, true, true, &n, weights, residual, nullptr, m.smooth ? &first : nullptr);
}

namespace {
// Prior strengths of the final weights, in samples of each material's own
// mean squared prediction: weak ridges that keep a texel's few samples from
// being overfitted by a blend of materials, without pulling blend-zone
// texels to their cluster's material (on the default preset stronger
// priors raise the held-out error, these weak ones cost nothing against
// none).
constexpr double kPriorSamples = 0.1;
constexpr double kSmoothSamples = 0.3;
}  // namespace

std::vector<WeightModel> CandidateWeightModels(const ReconstructOptions& o) {
  std::vector<WeightModel> out;
  for (double unit_sum : o.weight_unit_sum_samples)
  for (int radius : o.weight_radii) {
    WeightModel m;
    m.unit_sum_samples = unit_sum;
    m.radius = radius;
    m.smooth = true;
    m.prior_samples = kPriorSamples;
    m.smooth_samples = kSmoothSamples;
    m.per_material_prior = true;
    out.push_back(m);
  }
  return out;
}

std::vector<WeightModel> AnytimeOrder(std::vector<WeightModel> models) {
  if (models.empty()) return models;
  std::vector<int> radii;
  for (const WeightModel& m : models) radii.push_back(m.radius);
  std::sort(radii.begin(), radii.end());
  const double middle = std::log2(double(std::max(1, radii[radii.size() / 2])));
  auto distance = [&](const WeightModel& m) { return std::abs(std::log2(double(std::max(1, m.radius))) - middle); };
  std::stable_sort(models.begin(), models.end(), [&](const WeightModel& a, const WeightModel& b) {
    if (a.unit_sum_samples != b.unit_sum_samples) return a.unit_sum_samples > b.unit_sum_samples;
    if (distance(a) != distance(b)) return distance(a) < distance(b);
    return a.radius < b.radius;
  });
  return models;
}

WeightModel ChooseWeightModel(const Clustering& cl, SvbrdfEstimate* est, const StageLog& log) {
  // Scalar weights at every radius and unit-sum prior first; per-channel
  // weights (three times the unknowns) are then scored once, at the best
  // scalar candidate's radius and prior, and must beat it clearly. Scoring
  // per-channel weights at every setting doubled the cost of the choice and
  // no multi-material scene of the randomized captures' dev half took them.
  std::vector<WeightModel> candidates = AnytimeOrder(CandidateWeightModels(cl.options()));
  const size_t total = candidates.size() + 1;
  std::vector<double> rmse;
  std::vector<std::vector<double>> per_texel;
  size_t best = 0;
  std::string line;
  auto score = [&](const WeightModel& m) {
    per_texel.emplace_back();
    rmse.push_back(cl.HeldoutRmse(m, &per_texel.back()));
    line += Msg(line.empty() ? "" : "; ", m.Label(), " ", rmse.back());
  };
  // Anytime: past the deadline the first scalar candidate (AnytimeOrder)
  // and its per-channel twin (with one cluster only per-channel weights can
  // follow colour) are scored, and another scalar one only while the time
  // left exceeds the last one's cost.
  for (size_t j = 0; j < candidates.size(); ++j) {
    const auto t0 = std::chrono::steady_clock::now();
    score(candidates[j]);
    if (rmse[j] < rmse[best]) best = j;
    if (j + 1 < candidates.size() &&
        cl.options().SecondsLeft() <= std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()) {
      est->cut_by_deadline.push_back(Msg("mixing-weight choice (", j + 2, " of ", total, " scored)"));
      break;
    }
  }
  std::vector<int64_t> held;
  for (int k = 0; k < cl.K(); ++k) {
    const std::vector<int64_t> ids = cl.Ids(k, true);
    held.insert(held.end(), ids.begin(), ids.end());
  }
  const double margin = cl.options().parsimony * SignalRms(cl.samples(), held);
  auto clearly_worse = [&](size_t a, size_t b) {
    return rmse[a] - rmse[b] > margin && PairedZ(per_texel[a], per_texel[b]) >= cl.options().model_min_z;
  };
  candidates.resize(rmse.size());  // the scored ones (all, unless the deadline cut the choice)
  const size_t scalar = best;
  WeightModel channel = candidates[scalar];
  channel.per_channel = true;
  candidates.push_back(channel);
  score(channel);
  // Per channel only when clearly better than the best scalar candidate, by
  // the model choice's rule (lower by `parsimony` x the signal's RMS and by
  // `model_min_z` standard errors, paired over texels). Without the rule a
  // difference within the noise (the mixed preset's first material round)
  // takes them; with it no capture's held-out PSNR changes.
  if (clearly_worse(scalar, candidates.size() - 1)) best = candidates.size() - 1;
  const WeightModel& m = candidates[best];
  est->per_channel_weights = m.per_channel;
  est->weight_radius = m.radius;
  est->weight_unit_sum = m.unit_sum_samples;
  est->heldout_rmse = rmse[best];
  est->heldout_rmse_scalar = rmse[scalar];
  est->heldout_rmse_channel = rmse.back();
  log(Msg("weights: ", m.Label(), " (held-out RMSE ", line, ")"));
  return m;
}

std::vector<int> LargestWeightLabels(const std::vector<float>& weights, int K) {
  if (K <= 0) return {};
  const size_t stride = size_t(K) * 3;
  std::vector<int> labels(weights.size() / stride, -1);
  for (size_t t = 0; t < labels.size(); ++t) {
    const float* w = &weights[t * stride];
    float best_sum = 0;
    for (int k = 0; k < K; ++k) {
      const float sum = w[k * 3] + w[k * 3 + 1] + w[k * 3 + 2];
      if (sum > best_sum) labels[t] = k, best_sum = sum;
    }
  }
  return labels;
}

void SmoothInteriorWeights(const std::vector<std::vector<int>>& neighbours, int K, double alpha,
                           std::vector<float>* weights) {
  if (!(alpha > 0) || K <= 0) return;
  const size_t stride = size_t(K) * 3;
  const int nt = int(weights->size() / stride);
  const std::vector<int> labels = LargestWeightLabels(*weights, K);
  std::vector<char> interior(nt, 0);
  for (int t = 0; t < nt && t < int(neighbours.size()); ++t) {
    if (labels[t] < 0 || neighbours[t].empty()) continue;
    interior[t] = 1;
    for (int u : neighbours[t]) interior[t] = interior[t] && labels[u] == labels[t];
  }
  // Only interior neighbours count: a blend-zone texel next to the region
  // has the region's label but a partial weight, and would bleed into it.
  const std::vector<float> before = *weights;
  for (int t = 0; t < nt && t < int(neighbours.size()); ++t) {
    if (!interior[t]) continue;
    int n = 0;
    for (int u : neighbours[t]) n += interior[u];
    if (n == 0) continue;
    for (size_t j = 0; j < stride; ++j) {
      double sum = 0;
      for (int u : neighbours[t])
        if (interior[u]) sum += before[size_t(u) * stride + j];
      (*weights)[size_t(t) * stride + j] = float((before[size_t(t) * stride + j] + alpha * sum) / (1.0 + alpha * n));
    }
  }
}

namespace {
// Smoothing strengths tried (alpha of SmoothInteriorWeights; 1 = a texel
// counts as much as each neighbour). Hand-smoothed weights on the mixed
// capture, with and without its bumps, relight the held-out views better
// at a weak pull and worse at a strong one, which blurs real variation.
constexpr double kSmoothingCandidates[] = {0.0, 0.1, 0.25, 0.5, 1.0};
}  // namespace

double ChooseWeightSmoothing(const Clustering& cl, const WeightModel& m, SvbrdfEstimate* est, const StageLog& log) {
  int64_t n = 0;
  std::vector<float> first, train;
  if (m.smooth) cl.MixtureError(m, false, false, &n, &first, nullptr);
  cl.MixtureError(m, false, false, &n, &train, nullptr, nullptr, m.smooth ? &first : nullptr);
  double best = 0, best_sse = std::numeric_limits<double>::infinity();
  std::string line;
  for (double alpha : kSmoothingCandidates) {
    std::vector<float> w = train;
    SmoothInteriorWeights(cl.neighbours(), cl.K(), alpha, &w);
    int64_t count = 0;
    const double sse = cl.HeldoutSse(w, &count);
    line += Msg(line.empty() ? "" : "; ", alpha, " ", count ? std::sqrt(sse / count) : 0.0);
    if (sse < best_sse) best_sse = sse, best = alpha;
  }
  est->weight_smoothing = best;
  log(Msg("weight smoothing inside regions: ", best, " (held-out RMSE ", line, ")"));
  return best;
}

}  // namespace svbrdf
