// The working state of the progressive clustering (internal to lib/cluster):
// samples split into training and held-out sets, per-texel sample counts and
// neighbours, the current basis materials with their predictions for every
// sample, and the texel-to-cluster assignment. The stages (split search,
// model selection, weights, confidence) each live in their own file and
// work on this state.
#pragma once
#include <algorithm>
#include <chrono>
#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "atlas/atlas.h"
#include "cluster/reconstruct.h"
#include "fit/fit.h"
#include "gather/samples.h"
#include "io/material.h"

namespace svbrdf {

inline double Sq(double x) { return x * x; }
// Least-squares brightness of a texel relative to a basis material (sums of
// y*p and p*p), limited to [0.5, 2]: darker or brighter, not another material.
inline double BrightnessScale(double yp, double pp) { return std::clamp(yp / pp, 0.5, 2.0); }

// How per-texel mixing weights are estimated (weights.cc): NNLS per texel
// over the basis materials of the clusters near it, with a ridge prior
// towards its own cluster's material (at the brightness that fits it best),
// and optionally a second pass with the prior towards the mean of its
// neighbours' first-pass weights.
struct WeightModel {
  bool per_channel = false;  // one weight per material and colour channel (else one per material)
  // Materials of the clusters within this many neighbour steps (8-neighbours
  // in the atlas: the Chebyshev distance) may mix into a texel.
  int radius = 2;
  bool smooth = false;       // the second (neighbour) pass
  // Prior strengths in samples. Trace prior (per_material_prior = false, the
  // split search's measure): one ridge for all materials, `prior_samples`
  // times the texel's mean squared prediction over all materials. Per
  // material: each weight's ridge is that many samples of its own material's
  // mean squared prediction, so a highlight that one material puts on a
  // mixed texel does not pin the weights of the others (seen: the dull
  // material's weight in a blend zone pulled to 0 by a glossy neighbour's
  // highlight).
  double prior_samples = 1.0;
  double smooth_samples = 3.0;
  bool per_material_prior = false;
  // Prior on the sum of a texel's weights (per channel) towards 1, in samples
  // of the texel's mean squared prediction per material: the texel is a blend
  // of the basis materials as fitted (a partition of unity), not at a
  // brightness of its own. 0: free brightness (the cluster's material at the
  // brightness that fits the texel best is the prior's target).
  double unit_sum_samples = 0.0;
  // Robust re-weighting (Cauchy IRLS) after the least-squares solve: each
  // training sample's weight is 1 / (1 + r^2 / s^2), s = robust_c x the
  // texel's median absolute residual (as a standard deviation, x 1.4826),
  // floored at 1 % of its RMS value. Light that no mix of the materials
  // describes (a mirror-like texel reflecting a lit neighbour, indirect
  // light the removal missed) otherwise buys the neighbour's material a
  // weight in the texel, which then glows in every relit view.
  //   robust_passes  re-weighted solves at most (0 = least squares)   [0, 10]
  //   robust_c       Cauchy scale in robust standard deviations         > 0
  //   robust_skip    no re-weighted solve while every sample keeps more
  //                  than this weight (most texels: nothing to discount) [0, 1)
  int robust_passes = 5;
  double robust_c = 1.5;
  double robust_skip = 0.5;
  // Held-out errors on this display scale (stats.h; null or empty: linear).
  // Only the scoring changes: the weights are fitted on linear samples.
  const std::vector<Rgb>* display = nullptr;
  std::string Label() const;
};

class Clustering {
 public:
  static constexpr uint8_t kFar = 255;

  Clustering(const SampleSet& s, const Atlas& atlas, const ReconstructOptions& o);

  int K() const { return static_cast<int>(basis_.size()); }
  int num_texels() const { return nt_; }
  std::vector<BasisMaterial>& basis() { return basis_; }
  const std::vector<BasisMaterial>& basis() const { return basis_; }
  std::vector<int>& assign() { return assign_; }
  const std::vector<int>& assign() const { return assign_; }
  const std::vector<char>& usable() const { return usable_; }
  const std::vector<char>& holdout() const { return holdout_; }
  const std::vector<int>& train_count() const { return train_count_; }
  const std::vector<std::vector<int>>& neighbours() const { return neighbours_; }
  const SampleSet& samples() const { return s_; }
  const ReconstructOptions& options() const { return o_; }
  // Threads of this clustering's loops and fits: the options' unless set
  // (> 0), e.g. to share the cores between two copies worked side by side.
  int threads() const { return threads_ > 0 ? threads_ : o_.threads; }
  void SetThreads(int threads) { threads_ = threads; }
  // Its fits end early once `cancel` is set (FitOptions::cancel); null: never.
  const std::atomic<bool>* cancel() const { return cancel_; }
  void SetCancel(const std::atomic<bool>* cancel) { cancel_ = cancel; }

  // Sample ids of usable texels in cluster k (all clusters when k < 0), train
  // or held-out; with well_seen_fits (final materials): of its texels with
  // min_samples or more training samples when those hold at least half of
  // its training samples, else of all; of those, the core's (CoreTexels,
  // ReconstructOptions::core_fit_rings) when it holds half of their
  // training samples, unless cluster k fits on all its texels
  // (SetAllTexelFits).
  std::vector<int64_t> Ids(int k, bool heldout) const;
  // Whether Ids(k, ...) takes cluster k's core.
  bool FitsOnCore(int k) const;
  // Cluster k's fits on all its texels from now on, not its core (model
  // selection's fallback for a core fit at its bounds, estimate.cc).
  void SetAllTexelFits(int k);

  // Sets basis k (k == K() appends one) and its predictions.
  void SetBasis(int k, const BasisMaterial& b);
  void RemoveBasis(int k);
  // Back to an earlier state: these basis materials (predictions recomputed
  // only for those that differ) and this assignment.
  void Restore(const std::vector<BasisMaterial>& basis, const std::vector<int>& assign);

  // From model selection on (FinishEstimate): fits and validation on the well-seen texels (Ids).
  bool well_seen_fits_ = false;

  // Names the current stage in fit errors ("reconstruct: cluster 2 (split): ...").
  const char* stage = "clustering";

  // Robust fit of `spec` to cluster k's training samples (see clustering.cc).
  // multi_start = false: refine from `init` only (a warm start, e.g. the
  // cluster's own material after its membership changed a little).
  FitResult Fit(const ModelSpec& spec, int k, const std::vector<double>& init, int64_t max_samples = 0,
                int threads = -1, bool multi_start = true) const;
  // The same on the samples `ids` (of cluster `k`, named in fit errors; < 0: not one cluster).
  // init_is_fit: `init` is already a least-squares fit to (a random subset
  // of) these samples, e.g. a screening fit, so the robust fit starts from it
  // directly instead of after a least-squares solve of its own.
  FitResult FitIds(const ModelSpec& spec, const std::vector<int64_t>& ids, const std::vector<double>& init,
                   int64_t max_samples = 0, int threads = -1, int k = -1, bool multi_start = true,
                   bool init_is_fit = false) const;

  // Squared error of texel t's samples under basis k with the best brightness
  // scale a in [0.5, 2] shared by the channels (a texel may be darker or
  // brighter than its material, but not of another colour).
  double ScaledError(int t, int k, bool heldout) const;
  // The same on training (which = 0), held-out (1) or all (2) samples.
  double ScaledError(int t, int k, int which) const;

  // Before the final weights (which use all samples): texels that only
  // held-out photos saw get their label from their own samples (pooled
  // with their neighbours' as in Assign) instead of from their neighbours'
  // labels alone, and texels no photo saw are filled again from those.
  // Seen with 8 photos: a few such texels at a region border kept the
  // filled label of the other region and made most of the worst held-out
  // view's error.
  void LabelUnseenByAllSamples();

  // Whether cluster k gained or lost texels in the last Assign().
  bool MembershipChanged(int k) const { return k < int(changed_.size()) && changed_[k]; }
  // Assigns every usable texel to its best basis; returns how many changed.
  long Assign();

  // Mixing weights (weights.cc). Per-texel NNLS mixing weights from one
  // subset of samples (train, or all), error on another (held-out, or all).
  // Returns the summed squared error and its sample-channel count; `weights`
  // (texel-major [t][k][c]) when non-null.
  double MixtureError(const WeightModel& m, bool fit_on_all, bool eval_on_all, int64_t* count,
                      std::vector<float>* weights, std::vector<float>* residual,
                      std::vector<double>* per_texel = nullptr,
                      const std::vector<float>* smooth_from = nullptr) const;
  // Held-out RMSE of the weights (both passes when m.smooth).
  double HeldoutRmse(const WeightModel& m, std::vector<double>* per_texel = nullptr) const;
  // The split search's measure: one pass, trace prior, options().mix_radius.
  WeightModel SearchWeightModel(bool per_channel = false) const;
  double HeldoutRmse(bool per_channel = false, std::vector<double>* per_texel = nullptr) const;
  // Squared error (and sample-channel count) of the held-out samples of
  // usable texels under the given weights (texel-major [t][k][c]).
  double HeldoutSse(const std::vector<float>& weights, int64_t* count) const;
  // Final weights on all samples: a first pass, then the smoothness pass.
  void FinalWeights(const WeightModel& m, std::vector<float>* weights, std::vector<float>* residual) const;
  // Distance of every texel to the nearest texel of each cluster in
  // neighbour steps (texel-major [t][k]; kFar when unreachable), over texels
  // that have training samples.
  std::vector<uint8_t> ClusterDistances() const;

  double TrainRmse(int k = -1) const;
  double ClusterSse(int k) const;

 private:
  std::vector<float> Predict(const BasisMaterial& b) const;
  // ScaledError(t, k, which) of every texel with count[t] > 0, t-major (K per texel).
  std::vector<double> TexelErrors(const std::vector<int>& count, int which) const;
  // The cluster with the lowest error of texel t pooled with half its
  // neighbours' (those with count > 0), as Assign chooses; -1 if none.
  int PooledBest(const std::vector<double>& err, int t, const std::vector<int>& count) const;
  // Ids' fewest training samples per texel of cluster k (the well-seen rule).
  int FitMinCount(int k) const;
  // Cluster k's core for Ids (empty: all its texels).
  std::vector<char> FitCore(int k, int min_count) const;

  const SampleSet& s_;
  int threads_ = 0;
  const std::atomic<bool>* cancel_ = nullptr;
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
  std::vector<char> all_texel_fits_;      // per basis: SetAllTexelFits
};

// Per texel: whether every surface neighbour up to `rings` rings out (8-
// neighbours in the atlas, across seams) carries the texel's own label.
std::vector<char> CoreTexels(const std::vector<std::vector<int>>& neighbours, const std::vector<int>& label, int rings);

// Labels of texels without training samples (no training photo saw them)
// from their neighbours: the majority label of the neighbours that have one,
// front by front inwards from the seen texels. A label left over from an
// earlier state would otherwise decide their material (seen with 8 photos: a
// strip seen only by the held-out photos kept a split half's label and was
// relit green on a blue region).
void FillLabels(const std::vector<std::vector<int>>& neighbours, const std::vector<int>& train_count, int K,
                std::vector<int>* label);

// Canonical key of a texel partition: the same for any numbering of the
// clusters (labels renumbered in order of first appearance, then hashed).
uint64_t PartitionKey(const std::vector<int>& assign);

BasisMaterial MakeBasis(const ModelSpec& spec, const FitResult& r, int index);

// The clusters' robust fit (Clustering::FitIds) on any sample set: least
// squares (unless `init_is_fit`), then a Cauchy refit at 3 robust sigmas of
// its residuals when o.robust_scale < 0; `fo` gives the solver's budget.
FitResult RobustFit(const ModelSpec& spec, const SampleSet& s, const std::vector<int64_t>& ids,
                    const ReconstructOptions& o, FitOptions fo, const std::vector<double>& init, bool init_is_fit);

// Assign and refit until stable or `iterations` done; drops empty clusters.
// fits_current: every basis was fitted on its cluster's current texels (all
// training samples, as Clustering::Fit does), so the first pass refits only
// the clusters whose membership the assignment changes.
// `stop` (optional) set: returns at the next refit, the state unusable.
void Refine(Clustering& cl, int iterations, bool fits_current = false, const std::atomic<bool>* stop = nullptr);

// Progress lines with the wall and CPU time since the process started.
class StageLog {
 public:
  explicit StageLog(bool on);
  void operator()(const std::string& s) const;

 private:
  bool on_;
  std::chrono::steady_clock::time_point t0_;
};

}  // namespace svbrdf
