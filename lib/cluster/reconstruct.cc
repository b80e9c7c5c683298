#include "cluster/reconstruct.h"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "cluster/nnls.h"
#include "core/error.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "core/rng.h"

namespace svbrdf {

void ReconstructOptions::Check() const {
  fit.Check();
  if (max_clusters < 1 || max_clusters > 16) throw Error(Msg("reconstruct: --max-clusters must be in [1, 16], got ", max_clusters));
  if (force_clusters < 0 || force_clusters > 16) throw Error(Msg("reconstruct: --clusters must be in [0, 16], got ", force_clusters));
  if (!(holdout_fraction > 0 && holdout_fraction < 0.9)) throw Error("reconstruct: holdout fraction must be in (0, 0.9)");
  if (!(min_improvement >= 0)) throw Error("reconstruct: min improvement must be >= 0");
  if (!(parsimony >= 0)) throw Error("reconstruct: parsimony must be >= 0");
  if (refine_iterations < 0) throw Error("reconstruct: refine iterations must be >= 0");
  if (min_samples < 1) throw Error("reconstruct: min samples must be >= 1");
  if (candidate_models.empty() && force_model.empty()) throw Error("reconstruct: no candidate models");
  for (const auto& m : candidate_models) ModelSpec::FromLabel(m);  // throws for unknown labels
  if (!force_model.empty()) ModelSpec::FromLabel(force_model);
  ModelSpec::FromLabel(cluster_model);
}

namespace {

constexpr double kPriorSamples = 1.0;   // weight of the cluster prior in per-texel weights
constexpr double kSmoothSamples = 3.0;
constexpr int kMaxFailedSplits = 4;      // splits in a row without improvement before stopping  // weight of the neighbours' weights in the second pass
inline double Sq(double x) { return x * x; }
// Least-squares brightness of a texel relative to a basis material (sums of
// y*p and p*p), limited to [0.5, 2]: darker or brighter, not another material.
inline double BrightnessScale(double yp, double pp) { return std::clamp(yp / pp, 0.5, 2.0); }

// Everything the clustering works on: samples split into training and
// held-out sets, per-texel sample counts, the current basis materials, their
// predictions for every sample, and the texel-to-cluster assignment.
class Clustering {
 public:
  Clustering(const SampleSet& s, const Atlas& atlas, const ReconstructOptions& o)
      : s_(s), o_(o), nt_(s.num_texels) {
    // Whole photos are held out: held-out error then measures what relighting
    // needs (new views and lights); per-sample hold-out leaks through
    // neighbouring texels seen in the same photo.
    int num_images = 0;
    for (int32_t im : s.image) num_images = std::max(num_images, im + 1);
    std::vector<std::pair<double, int>> order;
    for (int im = 0; im < num_images; ++im) order.emplace_back(HashUniform(o.seed, uint64_t(im), 0x401d), im);
    std::sort(order.begin(), order.end());
    std::vector<char> held_image(num_images, 0);
    const int num_held = std::max(1, int(std::lround(o.holdout_fraction * num_images)));
    for (int j = 0; j < num_held && num_images > 1; ++j) held_image[order[j].second] = 1;
    holdout_.resize(s.size());
    train_count_.assign(nt_, 0);
    for (int t = 0; t < nt_; ++t)
      for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) {
        holdout_[i] = held_image[s.image[i]];
        train_count_[t] += !holdout_[i];
      }
    // 8-neighbours in the atlas, for spatially pooled assignment and mixing.
    neighbours_.resize(nt_);
    for (int t = 0; t < nt_ && t < int(atlas.texels.size()); ++t) {
      const Texel& tx = atlas.texels[t];
      const int d[8][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {1, -1}, {-1, 1}, {-1, -1}};
      for (const auto& dd : d) {
        const int x = tx.x + dd[0], y = tx.y + dd[1];
        if (x < 0 || y < 0 || x >= atlas.width || y >= atlas.height) continue;
        const int u = atlas.At(x, y);
        if (u >= 0 && u < nt_) neighbours_[t].push_back(u);
      }
    }
    usable_.resize(nt_);
    for (int t = 0; t < nt_; ++t) usable_[t] = train_count_[t] >= o.min_samples;
    if (std::count(usable_.begin(), usable_.end(), true) == 0)
      throw Error(Msg("reconstruct: no texel has ", o.min_samples, " or more training samples; more photos or a coarser --texture-size are needed"));
    assign_.assign(nt_, 0);
  }

  int K() const { return static_cast<int>(basis_.size()); }
  std::vector<BasisMaterial>& basis() { return basis_; }
  std::vector<int>& assign() { return assign_; }
  const std::vector<char>& usable() const { return usable_; }
  const std::vector<char>& holdout() const { return holdout_; }
  const char* stage = "clustering";  // names the stage in fit errors

  // Sample ids of usable texels in cluster k (all clusters when k < 0), train or held-out.
  std::vector<int64_t> Ids(int k, bool heldout) const {
    std::vector<int64_t> ids;
    for (int t = 0; t < nt_; ++t) {
      if (!usable_[t] || (k >= 0 && assign_[t] != k)) continue;
      for (int64_t i = s_.texel_begin[t]; i < s_.texel_begin[t + 1]; ++i)
        if (bool(holdout_[i]) == heldout) ids.push_back(i);
    }
    return ids;
  }

  void SetBasis(int k, const BasisMaterial& b) {
    if (k == K()) {
      basis_.push_back(b);
      pred_.emplace_back();
    } else {
      basis_[k] = b;
    }
    pred_[k] = Predict(b);
  }
  void RemoveBasis(int k) {
    basis_.erase(basis_.begin() + k);
    pred_.erase(pred_.begin() + k);
    for (int& a : assign_) a = a == k ? 0 : (a > k ? a - 1 : a);
  }

  // Cluster fits are robust by default: texels that the assignment got wrong
  // (their samples missed the highlight that tells them apart) must not pull
  // the basis material. A least-squares fit first (so that true highlights
  // are explained, not discarded as outliers), then a Cauchy refit from it
  // with a scale of 3 robust sigmas (1.4826 MAD) of its residuals.
  FitResult Fit(const ModelSpec& spec, int k, const std::vector<double>& init, int64_t max_samples = 0,
                int threads = -1) const {
    const std::vector<int64_t> ids = Ids(k, false);
    FitOptions fo = o_.fit;
    if (max_samples > 0) fo.max_samples = std::min(fo.max_samples, max_samples);
    if (threads >= 0) fo.threads = threads;
    fo.robust_scale = std::max(0.0, o_.robust_scale);
    fo.context = Msg("reconstruct: cluster ", k, " (", stage, ")");
    FitResult ls = FitModel(spec, s_, ids, fo, init);
    if (o_.robust_scale >= 0 || ids.empty()) return ls;
    std::vector<float> r;
    const size_t step = std::max<size_t>(1, ids.size() / 20000);
    for (size_t j = 0; j < ids.size(); j += step) {
      const Rgb p = PredictSample(spec, ls.params.data(), s_, ids[j]);
      for (int c = 0; c < 3; ++c) r.push_back(std::abs(s_.y[c][ids[j]] - float(p[c])));
    }
    std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
    fo.robust_scale = std::max(1e-6, 3.0 * 1.4826 * r[r.size() / 2]);
    fo.multi_start = false;
    FitResult robust = FitModel(spec, s_, ids, fo, ls.params);
    return robust.converged || !ls.converged ? robust : ls;
  }

  // Squared error of texel t's samples under basis k with the best brightness
  // scale a in [0.5, 2] shared by the channels (a texel may be darker or
  // brighter than its material, but not of another colour).
  double ScaledError(int t, int k, bool heldout) const {
    double yp = 0, pp = 0, yy = 0;
    const std::vector<float>& p = pred_[k];
    for (int64_t i = s_.texel_begin[t]; i < s_.texel_begin[t + 1]; ++i) {
      if (bool(holdout_[i]) != heldout) continue;
      for (int c = 0; c < 3; ++c) {
        const double y = s_.y[c][i], q = p[3 * i + c];
        yp += y * q, pp += q * q, yy += y * y;
      }
    }
    const double a = pp > 0 ? BrightnessScale(yp, pp) : 0.0;
    return std::max(0.0, yy - 2 * a * yp + a * a * pp);
  }

  // Whether cluster k gained or lost texels in the last Assign().
  bool MembershipChanged(int k) const { return k < int(changed_.size()) && changed_[k]; }

  // Assigns every usable texel to its best basis; returns how many changed.
  // Errors are pooled over the texel and half-weighted 8-neighbours: materials
  // are spatially coherent, and a texel's own few samples often miss the
  // highlight that tells its material apart.
  long Assign() {
    std::vector<int> next(assign_);
    const int K = this->K();
    std::vector<double> err(size_t(nt_) * K, 0.0);
    // Texels too sparse for fits are still assigned (their neighbours help),
    // so that their weights mix the right materials.
    ParallelFor(nt_, o_.threads, [&](long t) {
      if (train_count_[t] == 0) return;
      for (int k = 0; k < K; ++k) err[size_t(t) * K + k] = ScaledError(int(t), k, false);
    }, 512);
    ParallelFor(nt_, o_.threads, [&](long t) {
      if (train_count_[t] == 0) return;
      double best = 1e300;
      for (int k = 0; k < K; ++k) {
        double e = err[size_t(t) * K + k];
        for (int u : neighbours_[t])
          if (train_count_[u] > 0) e += 0.5 * err[size_t(u) * K + k];
        if (e < best) best = e, next[t] = k;
      }
    }, 512);
    long changed = 0;
    changed_.assign(K, 0);
    for (int t = 0; t < nt_; ++t)
      if (next[t] != assign_[t]) {
        ++changed;
        if (assign_[t] >= 0 && assign_[t] < K) changed_[assign_[t]] = 1;
        changed_[next[t]] = 1;
      }
    assign_ = next;
    return changed;
  }

  // Per-texel NNLS mixing weights from one subset of samples (train, or all),
  // error on another (held-out, or all). Returns the summed squared error and
  // its sample-channel count; `weights` (texel-major [t][k][c]) when non-null.
  double MixtureError(bool per_channel, bool fit_on_all, bool eval_on_all, int64_t* count,
                      std::vector<float>* weights, std::vector<float>* residual,
                      std::vector<double>* per_texel = nullptr,
                      const std::vector<float>* smooth_from = nullptr) const {
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
      // Only materials of the texel's own and its neighbours' clusters mix:
      // inside a region that is one material (at a free brightness), at a
      // border a blend of two. Free mixing of all K on a few samples
      // extrapolates badly to unseen light/view pairs (seen: false highlights).
      std::vector<char> allowed(K, 0);
      allowed[k0] = 1;
      for (int u : neighbours_[t])
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

  double HeldoutRmse(bool per_channel = false, std::vector<double>* per_texel = nullptr, bool smooth = false) const {
    int64_t n = 0;
    std::vector<float> first;
    if (smooth) MixtureError(per_channel, false, false, &n, &first, nullptr);
    const double sse = MixtureError(per_channel, false, false, &n, nullptr, nullptr, per_texel, smooth ? &first : nullptr);
    return n ? std::sqrt(sse / n) : 0.0;
  }
  // Final weights on all samples: a first pass, then the smoothness pass.
  void FinalWeights(bool per_channel, std::vector<float>* weights, std::vector<float>* residual) const {
    int64_t n = 0;
    std::vector<float> first;
    MixtureError(per_channel, true, true, &n, &first, nullptr);
    MixtureError(per_channel, true, true, &n, weights, residual, nullptr, &first);
  }
  double TrainRmse(int k = -1) const {
    int64_t n = 0;
    double sse = 0;
    for (int t = 0; t < nt_; ++t)
      if (usable_[t] && (k < 0 || assign_[t] == k)) {
        sse += ScaledError(t, assign_[t], false);
        n += 3 * train_count_[t];
      }
    return n ? std::sqrt(sse / n) : 0.0;
  }
  double ClusterSse(int k) const {
    double sse = 0;
    for (int t = 0; t < nt_; ++t)
      if (usable_[t] && assign_[t] == k) sse += ScaledError(t, k, false);
    return sse;
  }

  // Lensch's split of cluster k along the direction of largest parameter
  // variance (see reconstruct.h, step 2b). Per texel, the parameters that the
  // texel's own few samples do determine are estimated linearly: diffuse
  // albedo per channel and the amplitudes of two fixed normalised cosine
  // lobes (Lewis, exponents 8 and 64: a broad and a sharp highlight probe),
  // by NNLS. The probes do not depend on the cluster's current fit, which may
  // be poor while the cluster still mixes materials. The features are
  // whitened, split at the mean along their principal component, and the
  // split is refined by 2-means.
  // Returns +1/-1 for the texels of cluster k, 0 for the others.
  // `variant` selects the features: 0 = all five, 1 = diffuse colour only,
  // 2 = gloss amplitudes only (tried in turn when a split does not help).
  std::vector<int> SplitSides(int k, int variant) const {
    BasisMaterial probe[2];
    for (int q = 0; q < 2; ++q) {
      probe[q].spec = ModelSpec::FromLabel("cosine_lobe");
      probe[q].params = {0, 0, 0, 1, 1, 1, q == 0 ? 8.0 : 64.0};  // rd, rs, exponent
    }
    std::vector<int> texels;
    for (int t = 0; t < nt_; ++t)
      if (usable_[t] && assign_[t] == k) texels.push_back(t);
    const size_t T = texels.size();
    constexpr int kFeatures = 5;
    using VecF = Eigen::Matrix<double, kFeatures, 1>;
    using MatF = Eigen::Matrix<double, kFeatures, kFeatures>;
    Eigen::MatrixXd X(T, kFeatures);
    ParallelFor(long(T), o_.threads, [&](long j) {
      const int t = texels[j];
      MatF AtA = MatF::Zero();
      VecF Atb = VecF::Zero();
      for (int64_t i = s_.texel_begin[t]; i < s_.texel_begin[t + 1]; ++i) {
        if (holdout_[i]) continue;
        const Vec3 wi(s_.wi[0][i], s_.wi[1][i], s_.wi[2][i]), wo(s_.wo[0][i], s_.wo[1][i], s_.wo[2][i]);
        const double p0 = EvalModelD(probe[0].spec, probe[0].params.data(), wi, wo)[0] * s_.geom[i];
        const double p1 = EvalModelD(probe[1].spec, probe[1].params.data(), wi, wo)[0] * s_.geom[i];
        for (int c = 0; c < 3; ++c) {
          VecF row = VecF::Zero();
          row[c] = s_.geom[i] / kPi;
          row[3] = p0;
          row[4] = p1;
          AtA += row * row.transpose();
          Atb += row * double(s_.y[c][i]);
        }
      }
      AtA.diagonal().array() += 1e-9 * (1.0 + AtA.diagonal().maxCoeff());
      X.row(j) = NnlsNormal(AtA, Atb).transpose();
    }, 256);
    std::vector<int> side(nt_, 0);
    if (T < 4) return side;
    if (variant == 1) X = Eigen::MatrixXd(X.leftCols(3));
    if (variant == 2) X = Eigen::MatrixXd(X.rightCols(2));
    const int F = static_cast<int>(X.cols());
    // Whiten per feature, principal component, split at the mean.
    const Eigen::RowVectorXd mean = X.colwise().mean();
    Eigen::MatrixXd Z = X.rowwise() - mean;
    for (int q = 0; q < F; ++q) {
      const double sd = std::sqrt(Z.col(q).squaredNorm() / T);
      Z.col(q) /= sd > 1e-12 ? sd : 1.0;
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Z.transpose() * Z);
    const Eigen::VectorXd v = eig.eigenvectors().col(F - 1);
    std::vector<int> g(T);
    for (size_t j = 0; j < T; ++j) g[j] = Z.row(j).dot(v) >= 0 ? 1 : 0;
    // 2-means refinement in the whitened feature space.
    for (int it = 0; it < 20; ++it) {
      Eigen::RowVectorXd c[2] = {Eigen::RowVectorXd::Zero(F), Eigen::RowVectorXd::Zero(F)};
      double n[2] = {0, 0};
      for (size_t j = 0; j < T; ++j) c[g[j]] += Z.row(j), n[g[j]] += 1;
      if (n[0] == 0 || n[1] == 0) break;
      c[0] /= n[0];
      c[1] /= n[1];
      bool changed = false;
      for (size_t j = 0; j < T; ++j) {
        const int gj = (Z.row(j) - c[1]).squaredNorm() < (Z.row(j) - c[0]).squaredNorm() ? 1 : 0;
        changed |= gj != g[j];
        g[j] = gj;
      }
      if (!changed) break;
    }
    for (size_t j = 0; j < T; ++j) side[texels[j]] = g[j] ? 1 : -1;
    return side;
  }

 private:
  std::vector<float> Predict(const BasisMaterial& b) const {
    std::vector<float> p(3 * size_t(s_.size()));
    ParallelFor(s_.size(), o_.threads, [&](long i) {
      const Vec3 wi(s_.wi[0][i], s_.wi[1][i], s_.wi[2][i]), wo(s_.wo[0][i], s_.wo[1][i], s_.wo[2][i]);
      const Rgb f = EvalModelD(b.spec, b.params.data(), wi, wo) * s_.geom[i];
      for (int c = 0; c < 3; ++c) p[3 * i + c] = float(f[c]);
    }, 4096);
    return p;
  }

  const SampleSet& s_;
  const ReconstructOptions& o_;
  const int nt_;
  std::vector<char> holdout_;
  std::vector<int> train_count_;
  std::vector<char> usable_;
  std::vector<int> assign_;
  std::vector<std::vector<int>> neighbours_;
  std::vector<char> changed_;
  std::vector<BasisMaterial> basis_;
  std::vector<std::vector<float>> pred_;  // per basis: 3 values per sample
};

// Per-sample squared residuals (summed over channels) of a model on samples `ids`.
std::vector<double> SampleErrors(const ModelSpec& spec, const std::vector<double>& params, const SampleSet& s,
                                 const std::vector<int64_t>& ids) {
  std::vector<double> e(ids.size());
  for (size_t j = 0; j < ids.size(); ++j) {
    const Rgb p = PredictSample(spec, params.data(), s, ids[j]);
    e[j] = Sq(p[0] - s.y[0][ids[j]]) + Sq(p[1] - s.y[1][ids[j]]) + Sq(p[2] - s.y[2][ids[j]]);
  }
  return e;
}

// RMS residual per channel without the largest 2 % of per-sample errors:
// held-out samples of texels that the assignment got wrong must not decide
// which model describes the cluster.
double TrimmedRmse(std::vector<double> e) {
  if (e.empty()) return 0.0;
  const size_t keep = std::max<size_t>(1, e.size() - e.size() / 50);
  std::nth_element(e.begin(), e.begin() + (keep - 1), e.end());
  double sum = 0;
  for (size_t j = 0; j < keep; ++j) sum += e[j];
  return std::sqrt(sum / (3.0 * keep));
}

// Paired z statistic: how many standard errors the mean of `b` lies below `a`.
double PairedZ(const std::vector<double>& a, const std::vector<double>& b) {
  double sum = 0, sum2 = 0;
  for (size_t t = 0; t < a.size(); ++t) sum += a[t] - b[t], sum2 += (a[t] - b[t]) * (a[t] - b[t]);
  const double n = double(a.size()), var = std::max(0.0, sum2 / n - (sum / n) * (sum / n));
  return sum / std::max(1e-300, std::sqrt(var * n));
}

BasisMaterial MakeBasis(const ModelSpec& spec, const FitResult& r, int index) {
  BasisMaterial b;
  b.name = Msg("m", index);
  b.spec = spec;
  b.params = r.params;
  return b;
}

// Assign and refit until stable or `iterations` done; drops empty clusters.
void Refine(Clustering& cl, int iterations) {
  for (int it = 0; it < iterations; ++it) {
    const long changed = cl.Assign();
    for (int k = cl.K() - 1; k >= 0; --k) {
      const bool empty = std::none_of(cl.assign().begin(), cl.assign().end(), [&](int a) { return a == k; }) ||
                         cl.Ids(k, false).empty();
      if (empty && cl.K() > 1) cl.RemoveBasis(k);
    }
    if (changed == 0 && it > 0) break;
    for (int k = 0; k < cl.K(); ++k) {
      if (it > 0 && !cl.MembershipChanged(k)) continue;
      BasisMaterial b = cl.basis()[k];
      b.params = cl.Fit(b.spec, k, b.params).params;
      cl.SetBasis(k, b);
    }
  }
}

// Neighbour fill for texels without confident weights: repeated averaging of
// the 4-neighbours that have weights (a discrete harmonic fill).
void FillFromNeighbours(const Atlas& atlas, int K, std::vector<float>* w, std::vector<char>* known) {
  const int nt = static_cast<int>(atlas.texels.size());
  for (int pass = 0; pass < atlas.width + atlas.height; ++pass) {
    std::vector<int> newly;
    std::vector<float> acc(size_t(nt) * K * 3, 0.0f);
    for (int t = 0; t < nt; ++t) {
      if ((*known)[t]) continue;
      const Texel& tx = atlas.texels[t];
      int n = 0;
      const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
      for (auto& d : nb) {
        const int x = tx.x + d[0], y = tx.y + d[1];
        if (x < 0 || y < 0 || x >= atlas.width || y >= atlas.height) continue;
        const int u = atlas.At(x, y);
        if (u < 0 || !(*known)[u]) continue;
        for (int j = 0; j < K * 3; ++j) acc[size_t(t) * K * 3 + j] += (*w)[size_t(u) * K * 3 + j];
        ++n;
      }
      if (n == 0) continue;
      for (int j = 0; j < K * 3; ++j) (*w)[size_t(t) * K * 3 + j] = acc[size_t(t) * K * 3 + j] / n;
      newly.push_back(t);
    }
    if (newly.empty()) break;
    for (int t : newly) (*known)[t] = 1;
  }
}

}  // namespace

SvbrdfEstimate EstimateSvbrdf(const SampleSet& samples, const Atlas& atlas, const ReconstructOptions& o) {
  o.Check();
  if (samples.size() == 0) throw Error("reconstruct: no samples");
  Clustering cl(samples, atlas, o);
  SvbrdfEstimate est;
  const ModelSpec cluster_spec = ModelSpec::FromLabel(o.force_model.empty() ? o.cluster_model : o.force_model);
  const auto t0 = std::chrono::steady_clock::now();
  auto log = [&](const std::string& s) {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (o.progress) std::fprintf(stderr, "  [%6.1f s] %s\n", t, s.c_str());
  };

  // 1. One cluster.
  cl.stage = "initial fit";
  cl.SetBasis(0, MakeBasis(cluster_spec, cl.Fit(cluster_spec, 0, {}), 0));
  double heldout = cl.HeldoutRmse();
  est.history.push_back({1, cl.TrainRmse(), heldout, true});
  log(Msg("1 cluster: held-out RMSE ", heldout));

  cl.stage = "split";
  // 2. Progressive splitting with backtracking: a split that does not lower
  // the held-out error significantly is undone and the next-worst cluster is
  // split instead.
  struct State {
    std::vector<BasisMaterial> basis;
    std::vector<int> assign;
    double heldout;
    std::vector<double> texel_sse;  // held-out squared error per texel
  };
  std::vector<double> texel_sse;
  cl.HeldoutRmse(false, &texel_sse);
  std::vector<State> states{{cl.basis(), cl.assign(), heldout, texel_sse}};
  size_t best_state = 0;
  auto restore = [&cl](const State& st) {
    while (cl.K() > int(st.basis.size())) cl.RemoveBasis(cl.K() - 1);
    for (size_t j = 0; j < st.basis.size(); ++j) cl.SetBasis(int(j), st.basis[j]);
    cl.assign() = st.assign;
  };
  const int target = o.force_clusters > 0 ? o.force_clusters : o.max_clusters;
  constexpr int kSplitVariants = 3;
  std::vector<int> variants_tried;  // per cluster, since the last accepted split
  double best = heldout;
  int fails = 0;
  bool lookahead = false;  // the current state is one unaccepted split past the best
  int root_cluster = 0;    // the cluster of the best state whose split is being looked past
  while (cl.K() < target) {
    variants_tried.resize(cl.K(), 0);
    int k = -1;
    double worst = -1;
    for (int j = 0; j < cl.K(); ++j) {
      const double e = cl.ClusterSse(j);
      if (variants_tried[j] < kSplitVariants && e > worst) worst = e, k = j;
    }
    if (k < 0) break;
    const std::vector<int> side = cl.SplitSides(k, variants_tried[k]);
    const long plus = std::count(side.begin(), side.end(), 1), minus = std::count(side.begin(), side.end(), -1);
    // A basis material must own a meaningful part of the surface: smaller
    // groups are usually blends at region borders, which the mixing weights
    // already represent.
    const long usable_texels = std::count(cl.usable().begin(), cl.usable().end(), char(1));
    if (std::min(plus, minus) < std::max<long>(2, long(o.min_cluster_fraction * usable_texels))) {
      variants_tried[k]++;
      continue;
    }
    const int knew = cl.K();
    for (size_t t = 0; t < side.size(); ++t)
      if (side[t] < 0) cl.assign()[t] = knew;
      else if (side[t] == 0 && cl.assign()[t] == k) cl.assign()[t] = -1;  // re-assigned below
    const BasisMaterial parent = cl.basis()[k];
    cl.SetBasis(knew, MakeBasis(parent.spec, cl.Fit(parent.spec, knew, parent.params), knew));
    cl.SetBasis(k, MakeBasis(parent.spec, cl.Fit(parent.spec, k, parent.params), k));
    for (int& a : cl.assign()) if (a < 0) a = k;
    Refine(cl, o.refine_iterations);
    const double h = cl.HeldoutRmse(false, &texel_sse);
    const double drop = 1.0 - (h * h) / std::max(1e-300, best * best);
    const double z = PairedZ(states[best_state].texel_sse, texel_sse);
    est.history.push_back({cl.K(), cl.TrainRmse(), h, false});
    std::string sizes;
    for (int j = 0; j < cl.K(); ++j)
      sizes += Msg(j ? "/" : "", std::count(cl.assign().begin(), cl.assign().end(), j));
    log(Msg(cl.K(), " clusters (", sizes, " texels): held-out RMSE ", h, " (", 100 * drop,
            " % below the best so far, z = ", z, ")"));
    if (o.force_clusters > 0 || (drop >= o.min_improvement && z >= o.min_z)) {
      states.push_back({cl.basis(), cl.assign(), h, texel_sse});
      best = h;
      best_state = states.size() - 1;
      fails = 0;
      lookahead = false;
      std::fill(variants_tried.begin(), variants_tried.end(), 0);
    } else if (!lookahead && cl.K() < target) {
      // Look one split ahead before giving up: splitting 3 materials into 2
      // clusters can be worse than 1 cluster (a colour mixed into the wrong
      // basis), while the next split separates them.
      lookahead = true;
      root_cluster = k;
      variants_tried.assign(cl.K(), 0);
    } else {
      // Backtrack: undo the split(s) and try another feature set or the
      // next-worst cluster; stop after `kMaxFailedSplits` failures in a row.
      restore(states[best_state]);
      variants_tried.resize(cl.K(), 0);
      variants_tried[lookahead ? root_cluster : k]++;
      lookahead = false;
      if (++fails >= kMaxFailedSplits) break;
    }
  }
  // The last state that improved significantly on its predecessor (or the forced count).
  const size_t chosen = best_state;
  restore(states[chosen]);
  for (auto& h : est.history) h.accepted = h.clusters == cl.K();
  log(Msg("chosen: ", cl.K(), " basis materials"));

  // 3. Model economy per cluster.
  cl.stage = "model selection";
  std::vector<std::string> candidates = o.force_model.empty() ? o.candidate_models : std::vector<std::string>{o.force_model};
  for (int k = 0; k < cl.K(); ++k) {
    const std::vector<int64_t> hold = cl.Ids(k, true);
    struct Tried {
      ModelSpec spec;
      FitResult fit;
      double rmse;
      std::vector<double> errors;  // per held-out sample
    };
    // Candidates are independent small fits: one per thread pays better than
    // threads inside each Ceres solve.
    std::vector<Tried> tried(candidates.size());
    ParallelFor(long(candidates.size()), o.threads, [&](long j) {
      const ModelSpec spec = ModelSpec::FromLabel(candidates[j]);
      const FitResult r = cl.Fit(spec, k, spec == cl.basis()[k].spec ? cl.basis()[k].params : std::vector<double>{},
                                 o.selection_samples, 1);
      std::vector<double> e = SampleErrors(spec, r.params, samples, hold);
      tried[j] = {spec, r, TrimmedRmse(e), std::move(e)};
    });
    // The fewest parameters unless the best model is better by `parsimony`
    // of the signal's RMS (a difference that shows in a picture) and by
    // `model_min_z` standard errors (paired over held-out samples).
    double signal = 0;
    for (int64_t i : hold) signal += Sq(samples.y[0][i]) + Sq(samples.y[1][i]) + Sq(samples.y[2][i]);
    signal = std::sqrt(signal / std::max<double>(1.0, 3.0 * hold.size()));
    size_t best = 0;
    for (size_t j = 1; j < tried.size(); ++j)
      if (tried[j].rmse < tried[best].rmse) best = j;
    // The same trimming as TrimmedRmse for the paired test: samples among the
    // worst 2 % under the best model (misassigned texels) are left out.
    std::vector<char> keep(hold.size(), 1);
    if (!hold.empty()) {
      std::vector<double> sorted = tried[best].errors;
      const size_t cut = sorted.size() - 1 - sorted.size() / 50;
      std::nth_element(sorted.begin(), sorted.begin() + cut, sorted.end());
      for (size_t i = 0; i < hold.size(); ++i) keep[i] = tried[best].errors[i] <= sorted[cut];
    }
    auto trimmed = [&](const std::vector<double>& e) {
      std::vector<double> out;
      for (size_t i = 0; i < e.size(); ++i)
        if (keep[i]) out.push_back(e[i]);
      return out;
    };
    int chosen = int(best);
    for (size_t j = 0; j < tried.size(); ++j) {
      const bool clearly_worse = tried[j].rmse - tried[best].rmse > o.parsimony * signal &&
                                 PairedZ(trimmed(tried[j].errors), trimmed(tried[best].errors)) >= o.model_min_z;
      if (!clearly_worse && tried[j].spec.NumParams() < tried[chosen].spec.NumParams()) chosen = int(j);
    }
    for (size_t j = 0; j < tried.size(); ++j)
      est.model_choices.push_back({k, tried[j].spec.Label(), tried[j].rmse, tried[j].spec.NumParams(), int(j) == chosen});
    log(Msg("cluster ", k, ": model ", tried[chosen].spec.Label(), " (held-out RMSE ", tried[chosen].rmse, ")"));
    cl.SetBasis(k, MakeBasis(tried[chosen].spec, tried[chosen].fit, k));
  }
  cl.stage = "final refinement";
  Refine(cl, std::max(1, o.refine_iterations - 1));

  // 4. Mixing weights: scalar or per channel, by held-out error.
  est.heldout_rmse_scalar = cl.HeldoutRmse(false, nullptr, true);
  est.heldout_rmse_channel = cl.HeldoutRmse(true, nullptr, true);
  est.per_channel_weights = est.heldout_rmse_channel < est.heldout_rmse_scalar;
  est.heldout_rmse = std::min(est.heldout_rmse_scalar, est.heldout_rmse_channel);
  log(Msg("weights: ", est.per_channel_weights ? "per channel" : "scalar", " (held-out RMSE scalar ",
          est.heldout_rmse_scalar, ", per channel ", est.heldout_rmse_channel, ")"));
  cl.FinalWeights(est.per_channel_weights, &est.weights, &est.residual);

  // 5. Confidence and neighbour fill.
  const int K = cl.K();
  const int nt = samples.num_texels;
  est.num_texels = nt;
  est.confidence.assign(nt, 0.0f);
  std::vector<char> known(nt, 0);
  for (int t = 0; t < nt; ++t) {
    const int64_t b = samples.texel_begin[t], e = samples.texel_begin[t + 1];
    // Spread: RMS distance of the half vectors from their mean (0 = one direction only).
    Vec3 mean = Vec3::Zero();
    std::vector<Vec3> hs;
    for (int64_t i = b; i < e; ++i) {
      const Vec3 h = Vec3(samples.wi[0][i] + samples.wo[0][i], samples.wi[1][i] + samples.wo[1][i],
                          samples.wi[2][i] + samples.wo[2][i]).normalized();
      hs.push_back(h);
      mean += h;
    }
    double spread = 0;
    if (!hs.empty()) {
      mean /= double(hs.size());
      for (const Vec3& h : hs) spread += (h - mean).squaredNorm();
      spread = std::sqrt(spread / hs.size());
    }
    const double count_term = std::min(1.0, double(e - b) / (2.0 * o.min_samples));
    const double spread_term = std::min(1.0, spread / 0.1);
    est.confidence[t] = float(count_term * spread_term);
    known[t] = (e - b) >= o.min_samples && spread > 0.02;
    est.confidence[t] *= known[t] ? 1.0f : 0.25f;
  }
  for (int t = 0; t < nt; ++t)
    if (!known[t]) std::fill(est.weights.begin() + size_t(t) * K * 3, est.weights.begin() + size_t(t + 1) * K * 3, 0.0f);
  FillFromNeighbours(atlas, K, &est.weights, &known);
  est.label.assign(nt, -1);
  for (int t = 0; t < nt; ++t) {
    double best = -1;
    for (int k = 0; k < K; ++k) {
      const double w = est.weights[(size_t(t) * K + k) * 3] + est.weights[(size_t(t) * K + k) * 3 + 1] +
                       est.weights[(size_t(t) * K + k) * 3 + 2];
      if (w > best) best = w, est.label[t] = k;
    }
  }
  for (int k = 0; k < K; ++k) cl.basis()[k].name = Msg("m", k);
  est.basis = cl.basis();
  return est;
}

Material ToMaterial(const SvbrdfEstimate& est, const Atlas& atlas, const Mesh& mesh) {
  Material m;
  m.mesh = mesh;
  m.width = atlas.width;
  m.height = atlas.height;
  m.basis = est.basis;
  const int K = static_cast<int>(est.basis.size());
  for (int k = 0; k < K; ++k) m.weights.emplace_back(atlas.width, atlas.height, 3, 0.0f);
  m.confidence = Image(atlas.width, atlas.height, 1, 0.0f);
  m.material_id = Image(atlas.width, atlas.height, 1, 0.0f);  // texels outside the atlas: 0 (their weights are 0)
  for (size_t t = 0; t < atlas.texels.size(); ++t) {
    const Texel& tx = atlas.texels[t];
    for (int k = 0; k < K; ++k)
      for (int c = 0; c < 3; ++c) m.weights[k].at(tx.x, tx.y, c) = est.weights[(t * K + k) * 3 + c];
    m.confidence.at(tx.x, tx.y, 0) = est.confidence[t];
    m.material_id.at(tx.x, tx.y, 0) = float(est.label[t]);
  }
  return m;
}

}  // namespace svbrdf
