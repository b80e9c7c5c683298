// Per-texel mixing weights of the basis materials (non-negative least
// squares per texel with a prior towards its cluster's material), the
// held-out error they give, and the final weights on all samples.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "cluster/clustering.h"
#include "cluster/nnls.h"
#include "core/parallel.h"

namespace svbrdf {

namespace {
constexpr double kPriorSamples = 1.0;   // weight of the cluster prior in per-texel weights
constexpr double kSmoothSamples = 3.0;  // weight of the neighbours' weights in the second pass
}  // namespace

double Clustering::MixtureError(bool per_channel, bool fit_on_all, bool eval_on_all, int64_t* count,
                                std::vector<float>* weights, std::vector<float>* residual,
                                std::vector<double>* per_texel, const std::vector<float>* smooth_from) const {
  const int K = this->K();
  std::vector<double> sse(nt_, 0.0);
  std::vector<int64_t> cnt(nt_, 0);
  if (weights) weights->assign(size_t(nt_) * K * 3, 0.0f);
  if (residual) residual->assign(nt_, 0.0f);
  ParallelFor(nt_, o_.threads, [&](long t) {
    const int64_t b = s_.texel_begin[t], e = s_.texel_begin[t + 1];
    // Texels with too few training samples would overfit K weights; they
    // are scored only when everything is fitted on all samples (final weights).
    if (e == b || (!fit_on_all && !usable_[t])) return;
    Eigen::MatrixXd AtA[3], Atb[3];
    for (int c = 0; c < 3; ++c) AtA[c] = Eigen::MatrixXd::Zero(K, K), Atb[c] = Eigen::MatrixXd::Zero(K, 1);
    for (int64_t i = b; i < e; ++i) {
      if (!fit_on_all && holdout_[i]) continue;
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < K; ++k) {
          const double pk = pred_[k][3 * i + c];
          Atb[c](k) += pk * s_.y[c][i];
          for (int l = 0; l <= k; ++l) AtA[c](k, l) += pk * pred_[l][3 * i + c];
        }
    }
    // Prior: the texel is its cluster's material at the brightness that fits
    // it best, worth kPriorSamples samples. Without it, K free weights on a
    // handful of samples overfit (seen: held-out error rising with K).
    Eigen::VectorXd w0 = Eigen::VectorXd::Zero(K);
    const int k0 = std::clamp(assign_[t], 0, K - 1);
    double yp = 0, pp = 0, trace = 0;
    int64_t nfit = 0;
    for (int64_t i = b; i < e; ++i) {
      if (!fit_on_all && holdout_[i]) continue;
      ++nfit;
      for (int c = 0; c < 3; ++c) yp += pred_[k0][3 * i + c] * s_.y[c][i], pp += Sq(pred_[k0][3 * i + c]);
    }
    w0[k0] = pp > 0 ? BrightnessScale(yp, pp) : 1.0;
    // Second pass: the prior is the mean of the neighbours' first-pass
    // weights (a smoothness prior), worth kSmoothSamples samples.
    Eigen::VectorXd w0c[3] = {w0, w0, w0};
    double prior_samples = kPriorSamples;
    if (smooth_from) {
      int m = 0;
      for (int c = 0; c < 3; ++c) w0c[c].setZero();
      for (int u : neighbours_[t]) {
        if (train_count_[u] == 0) continue;
        ++m;
        for (int k = 0; k < K; ++k)
          for (int c = 0; c < 3; ++c) w0c[c][k] += (*smooth_from)[(size_t(u) * K + k) * 3 + c];
      }
      if (m > 0) {
        for (int c = 0; c < 3; ++c) w0c[c] /= m;
        prior_samples = kSmoothSamples;
      } else {
        w0c[0] = w0c[1] = w0c[2] = w0;
      }
    }
    for (int c = 0; c < 3; ++c) trace += AtA[c].trace();
    const double lambda = prior_samples * trace / (3.0 * K * std::max<int64_t>(1, nfit)) + 1e-12;
    for (int c = 0; c < 3; ++c) {
      AtA[c].diagonal().array() += lambda;
      Atb[c].col(0) += lambda * (per_channel ? w0c[c] : Eigen::VectorXd((w0c[0] + w0c[1] + w0c[2]) / 3.0));
    }
    // Only materials of the clusters within `mix_radius` texels mix: inside
    // a region one material (at a free brightness), in a blend zone or at a
    // junction all the materials around it. Free mixing of all K on a few
    // samples extrapolates badly to unseen light/view pairs (seen: false
    // highlights).
    std::vector<char> allowed(K, 0);
    allowed[k0] = 1;
    for (int u : mix_neighbours_[t])
      if (train_count_[u] > 0) allowed[std::clamp(assign_[u], 0, K - 1)] = 1;
    for (int k = 0; k < K; ++k)
      if (!allowed[k])
        for (int c = 0; c < 3; ++c) {
          AtA[c].row(k).setZero();
          AtA[c].col(k).setZero();
          AtA[c](k, k) = 1.0;
          Atb[c](k) = 0.0;
        }
    Eigen::VectorXd w[3];
    if (per_channel) {
      for (int c = 0; c < 3; ++c) {
        AtA[c].triangularView<Eigen::StrictlyUpper>() = AtA[c].transpose();
        w[c] = NnlsNormal(AtA[c], Atb[c].col(0));
      }
    } else {
      Eigen::MatrixXd A = AtA[0] + AtA[1] + AtA[2];
      A.triangularView<Eigen::StrictlyUpper>() = A.transpose();
      w[0] = w[1] = w[2] = NnlsNormal(A, (Atb[0] + Atb[1] + Atb[2]).col(0));
    }
    double err = 0;
    int64_t n = 0;
    for (int64_t i = b; i < e; ++i) {
      if (!eval_on_all && !holdout_[i]) continue;
      for (int c = 0; c < 3; ++c) {
        double q = 0;
        for (int k = 0; k < K; ++k) q += w[c](k) * pred_[k][3 * i + c];
        err += (q - s_.y[c][i]) * (q - s_.y[c][i]);
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

double Clustering::HeldoutRmse(bool per_channel, std::vector<double>* per_texel, bool smooth) const {
  int64_t n = 0;
  std::vector<float> first;
  if (smooth) MixtureError(per_channel, false, false, &n, &first, nullptr);
  const double sse = MixtureError(per_channel, false, false, &n, nullptr, nullptr, per_texel, smooth ? &first : nullptr);
  return n ? std::sqrt(sse / n) : 0.0;
}

void Clustering::FinalWeights(bool per_channel, std::vector<float>* weights, std::vector<float>* residual) const {
  int64_t n = 0;
  std::vector<float> first;
  MixtureError(per_channel, true, true, &n, &first, nullptr);
  MixtureError(per_channel, true, true, &n, weights, residual, nullptr, &first);
}

}  // namespace svbrdf
