#include "cluster/clustering.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "atlas/surface_neighbours.h"
#include "cluster/holdout.h"
#include "core/error.h"
#include "core/parallel.h"
#include "core/progress.h"

namespace svbrdf {

Clustering::Clustering(const SampleSet& s, const Atlas& atlas, const ReconstructOptions& o)
    : s_(s), o_(o), nt_(s.num_texels) {
  // Whole photos are held out: held-out error then measures what relighting
  // needs (new views and lights); per-sample hold-out leaks through
  // neighbouring texels seen in the same photo.
  int num_images = 0;
  for (int32_t im : s.image) num_images = std::max(num_images, im + 1);
  const std::vector<char> held_image = HeldOutImages(num_images, o.holdout_fraction, o.seed);
  holdout_.resize(s.size());
  train_count_.assign(nt_, 0);
  for (int t = 0; t < nt_; ++t)
    for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) {
      holdout_[i] = held_image[s.image[i]];
      train_count_[t] += !holdout_[i];
    }
  // Neighbours on the surface (8-neighbours in the atlas, and across chart
  // borders and seams), for spatially pooled assignment, mixing and the
  // labels of texels that no training photo saw.
  neighbours_ = SurfaceNeighbours(atlas);
  neighbours_.resize(nt_);
  for (auto& nb : neighbours_) nb.erase(std::remove_if(nb.begin(), nb.end(), [this](int u) { return u >= nt_; }), nb.end());
  usable_.resize(nt_);
  for (int t = 0; t < nt_; ++t) usable_[t] = train_count_[t] >= o.min_fit_samples;
  if (std::count(usable_.begin(), usable_.end(), true) == 0)
    throw Error(Msg("reconstruct: no texel has ", o.min_fit_samples, " or more training samples; more photos or a coarser --texture-size are needed"));
  assign_.assign(nt_, 0);
}

std::vector<int64_t> Clustering::Ids(int k, bool heldout) const {
  // Final materials (well_seen_fits): the well-seen texels (min_samples or
  // more training samples) alone when they hold most of the cluster's
  // training samples. Texels seen once or twice sit where few photos reach
  // (grazing views, region borders) and bias a fit (mixed_tiny: the copper's
  // F0 too low with them). With few photos they are most of the data and
  // all texels take part (default preset at 8 photos: the well-seen alone
  // relight the held-out views far worse). Not while splitting: the split
  // search's measure scores every texel with training samples, and fits
  // that never saw some of them extrapolate there (at 12 photos the
  // one-cluster fit read a large held-out error and the search kept 1
  // cluster).
  const int min_count = FitMinCount(k);
  const std::vector<char> core = FitCore(k, min_count);
  std::vector<int64_t> ids;
  for (int t = 0; t < nt_; ++t) {
    if (!usable_[t] || train_count_[t] < min_count || (k >= 0 && assign_[t] != k)) continue;
    if (!core.empty() && !core[t]) continue;
    for (int64_t i = s_.texel_begin[t]; i < s_.texel_begin[t + 1]; ++i)
      if (bool(holdout_[i]) == heldout) ids.push_back(i);
  }
  return ids;
}

int Clustering::FitMinCount(int k) const {
  int64_t all_train = 0, well_train = 0;
  for (int t = 0; t < nt_; ++t) {
    if (!usable_[t] || (k >= 0 && assign_[t] != k)) continue;
    all_train += train_count_[t];
    if (train_count_[t] >= o_.min_samples) well_train += train_count_[t];
  }
  return well_seen_fits_ && 2 * well_train >= all_train ? std::max(o_.min_samples, o_.min_fit_samples)
                                                        : o_.min_fit_samples;
}

std::vector<char> Clustering::FitCore(int k, int min_count) const {
  // The core of the cluster (ReconstructOptions::core_fit_rings), when it
  // holds half of the cluster's training samples or more.
  if (!well_seen_fits_ || k < 0 || o_.core_fit_rings <= 0) return {};
  if (size_t(k) < all_texel_fits_.size() && all_texel_fits_[size_t(k)]) return {};
  std::vector<char> core = CoreTexels(neighbours_, assign_, o_.core_fit_rings);
  int64_t in_core = 0, in_all = 0;
  for (int t = 0; t < nt_; ++t) {
    if (!usable_[t] || train_count_[t] < min_count || assign_[t] != k) continue;
    in_all += train_count_[t];
    if (core[t]) in_core += train_count_[t];
  }
  if (2 * in_core < in_all) core.clear();
  return core;
}

void Clustering::SetAllTexelFits(int k) {
  if (size_t(k) >= all_texel_fits_.size()) all_texel_fits_.resize(size_t(k) + 1, 0);
  all_texel_fits_[size_t(k)] = 1;
}

bool Clustering::FitsOnCore(int k) const {
  // Whether Ids takes a core, judged on all the cluster's texels with
  // training samples (the well-seen rule's count barely moves the core's
  // share of the samples, and this is what the benchmarks measured).
  return !FitCore(k, o_.min_fit_samples).empty();
}

std::vector<char> CoreTexels(const std::vector<std::vector<int>>& neighbours, const std::vector<int>& label, int rings) {
  const int nt = int(label.size());
  // Breadth-first from the texels that touch another label: distance in rings.
  std::vector<int> dist(nt, rings);
  std::vector<int> frontier;
  for (int t = 0; t < nt; ++t)
    for (int u : neighbours[t])
      if (u < nt && label[u] != label[t]) {
        dist[t] = 0;
        frontier.push_back(t);
        break;
      }
  for (int r = 1; r < rings && !frontier.empty(); ++r) {
    std::vector<int> next;
    for (int t : frontier)
      for (int u : neighbours[t])
        if (u < nt && dist[u] > r) dist[u] = r, next.push_back(u);
    frontier.swap(next);
  }
  std::vector<char> core(nt);
  for (int t = 0; t < nt; ++t) core[t] = dist[t] >= rings;
  return core;
}

void Clustering::SetBasis(int k, const BasisMaterial& b) {
  if (k == K()) {
    basis_.push_back(b);
    pred_.emplace_back();
    all_texel_fits_.resize(basis_.size(), 0);
  } else {
    // Restoring a search state sets every basis again; the ones it did not
    // change keep their predictions (a prediction visits every sample).
    const bool same = basis_[k].spec == b.spec && basis_[k].params == b.params && !pred_[k].empty();
    basis_[k] = b;
    if (same) return;
  }
  pred_[k] = Predict(b);
}

void Clustering::Restore(const std::vector<BasisMaterial>& basis, const std::vector<int>& assign) {
  while (K() > int(basis.size())) RemoveBasis(K() - 1);
  for (size_t j = 0; j < basis.size(); ++j) SetBasis(int(j), basis[j]);
  assign_ = assign;
}

void Clustering::RemoveBasis(int k) {
  basis_.erase(basis_.begin() + k);
  pred_.erase(pred_.begin() + k);
  if (size_t(k) < all_texel_fits_.size()) all_texel_fits_.erase(all_texel_fits_.begin() + k);
  for (int& a : assign_) a = a == k ? 0 : (a > k ? a - 1 : a);
}

// Cluster fits are robust by default: texels that the assignment got wrong
// (their samples missed the highlight that tells them apart) must not pull
// the basis material. A least-squares fit first (so that true highlights
// are explained, not discarded as outliers), then a Cauchy refit from it
// with a scale of 3 robust sigmas (1.4826 MAD) of its residuals.
FitResult Clustering::Fit(const ModelSpec& spec, int k, const std::vector<double>& init, int64_t max_samples,
                          int threads, bool multi_start) const {
  return FitIds(spec, Ids(k, false), init, max_samples, threads, k, multi_start);
}

FitResult Clustering::FitIds(const ModelSpec& spec, const std::vector<int64_t>& ids, const std::vector<double>& init,
                             int64_t max_samples, int threads, int k, bool multi_start, bool init_is_fit) const {
  FitOptions fo = o_.fit;
  fo.multi_start = fo.multi_start && multi_start;
  if (max_samples > 0) fo.max_samples = std::min(fo.max_samples, max_samples);
  if (threads >= 0) fo.threads = threads;
  else if (threads_ > 0) fo.threads = threads_;
  fo.cancel = cancel_;
  fo.context = k >= 0 ? Msg("reconstruct: cluster ", k, " (", stage, ")") : Msg("reconstruct: ", stage);
  return RobustFit(spec, s_, ids, o_, fo, init, init_is_fit);
}

FitResult RobustFit(const ModelSpec& spec, const SampleSet& s, const std::vector<int64_t>& ids,
                    const ReconstructOptions& o, FitOptions fo, const std::vector<double>& init, bool init_is_fit) {
  fo.robust_scale = std::max(0.0, o.robust_scale);
  // One reference brightness for the least-squares and the robust fit, so
  // that the robust scale below is in the units of the fit's residuals.
  if (fo.compression > 0 && !(fo.compression_reference > 0)) fo.compression_reference = MedianBrightness(s, ids);
  const bool skip_ls = init_is_fit && !init.empty() && o.robust_scale < 0 && !ids.empty();
  FitResult ls;
  if (skip_ls) ls.params = init;
  else ls = FitModel(spec, s, ids, fo, init);
  if (o.robust_scale >= 0 || ids.empty()) return ls;
  std::vector<float> r;
  const size_t step = std::max<size_t>(1, ids.size() / 20000);
  for (size_t j = 0; j < ids.size(); j += step) {
    const Rgb p = PredictSample(spec, ls.params.data(), s, ids[j]);
    const double w = ResidualWeight(fo, SampleBrightness(s, ids[j]));
    for (int c = 0; c < 3; ++c) r.push_back(float(w) * std::abs(s.y[c][ids[j]] - float(p[c])));
  }
  std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
  fo.robust_scale = std::max(1e-6, 3.0 * 1.4826 * r[r.size() / 2]);
  fo.multi_start = false;
  // A robust refit that Ceres gives up on (e.g. too many invalid steps near a
  // bound) leaves the least-squares fit, which is a valid material; only
  // without one does the failure end the fit.
  FitResult robust;
  try {
    robust = FitModel(spec, s, ids, fo, ls.params);
  } catch (const Error& e) {
    if (skip_ls) throw;
    std::fprintf(stderr, "  warning: %s; the least-squares fit is kept\n", e.what());
    return ls;
  }
  return skip_ls || robust.converged || !ls.converged ? robust : ls;
}

double Clustering::ScaledError(int t, int k, bool heldout) const { return ScaledError(t, k, heldout ? 1 : 0); }

double Clustering::ScaledError(int t, int k, int which) const {
  double yp = 0, pp = 0, yy = 0;
  const std::vector<float>& p = pred_[k];
  for (int64_t i = s_.texel_begin[t]; i < s_.texel_begin[t + 1]; ++i) {
    if (which != 2 && int(holdout_[i]) != which) continue;
    for (int c = 0; c < 3; ++c) {
      const double y = s_.y[c][i], q = p[3 * i + c];
      yp += y * q, pp += q * q, yy += y * y;
    }
  }
  const double a = pp > 0 ? BrightnessScale(yp, pp) : 0.0;
  return std::max(0.0, yy - 2 * a * yp + a * a * pp);
}

// Errors are pooled over the texel and half-weighted 8-neighbours: materials
// are spatially coherent, and a texel's own few samples often miss the
// highlight that tells its material apart.
long Clustering::Assign() {
  std::vector<int> next(assign_);
  const int K = this->K();
  // Texels too sparse for fits are still assigned (their neighbours help),
  // so that their weights mix the right materials.
  const std::vector<double> err = TexelErrors(train_count_, 0);
  ParallelFor(nt_, threads(), [&](long t) {
    if (train_count_[t] == 0) return;
    const int k = PooledBest(err, int(t), train_count_);
    if (k >= 0) next[t] = k;
  }, 512);
  FillLabels(neighbours_, train_count_, K, &next);
  long changed = 0;
  changed_.assign(K, 0);
  for (int t = 0; t < nt_; ++t)
    if (next[t] != assign_[t] && train_count_[t] > 0) {
      ++changed;
      if (assign_[t] >= 0 && assign_[t] < K) changed_[assign_[t]] = 1;
      changed_[next[t]] = 1;
    }
  assign_ = next;
  return changed;
}

void FillLabels(const std::vector<std::vector<int>>& neighbours, const std::vector<int>& train_count, int K,
                std::vector<int>* label) {
  const int nt = static_cast<int>(label->size());
  std::vector<char> known(nt);
  std::vector<int> unknown;
  for (int t = 0; t < nt; ++t) {
    known[t] = train_count[t] > 0;
    if (!known[t]) unknown.push_back(t);
  }
  std::vector<int> votes(std::max(1, K));
  while (!unknown.empty()) {
    std::vector<std::pair<int, int>> newly;
    std::vector<int> still;
    for (int t : unknown) {
      std::fill(votes.begin(), votes.end(), 0);
      int n = 0;
      for (int u : neighbours[t])
        if (known[u] && (*label)[u] >= 0 && (*label)[u] < K) votes[(*label)[u]]++, ++n;
      if (n == 0) still.push_back(t);
      else newly.emplace_back(t, int(std::max_element(votes.begin(), votes.end()) - votes.begin()));
    }
    if (newly.empty()) break;
    for (const auto& [t, k] : newly) (*label)[t] = k, known[t] = 1;
    unknown.swap(still);
  }
}

std::vector<double> Clustering::TexelErrors(const std::vector<int>& count, int which) const {
  const int K = this->K();
  std::vector<double> err(size_t(nt_) * K, 0.0);
  ParallelFor(nt_, threads(), [&](long t) {
    if (count[t] == 0) return;
    for (int k = 0; k < K; ++k) err[size_t(t) * K + k] = ScaledError(int(t), k, which);
  }, 512);
  return err;
}

int Clustering::PooledBest(const std::vector<double>& err, int t, const std::vector<int>& count) const {
  const int K = this->K();
  double best = 1e300;
  int chosen = -1;
  for (int k = 0; k < K; ++k) {
    double e = err[size_t(t) * K + k];
    for (int u : neighbours_[t])
      if (count[u] > 0) e += 0.5 * err[size_t(u) * K + k];
    if (e < best) best = e, chosen = k;
  }
  return chosen;
}

void Clustering::LabelUnseenByAllSamples() {
  const int K = this->K();
  std::vector<int> count(nt_), next(assign_);
  for (int t = 0; t < nt_; ++t) count[t] = int(s_.texel_begin[t + 1] - s_.texel_begin[t]);
  const std::vector<double> err = TexelErrors(count, 2);
  // Texels that only held-out photos saw: pooled as in Assign, on all samples.
  for (int t = 0; t < nt_; ++t) {
    if (train_count_[t] > 0 || count[t] == 0) continue;
    const int k = PooledBest(err, t, count);
    if (k >= 0) next[t] = k;
  }
  FillLabels(neighbours_, count, K, &next);
  assign_ = next;
}

double Clustering::TrainRmse(int k) const {
  int64_t n = 0;
  double sse = 0;
  for (int t = 0; t < nt_; ++t)
    if (usable_[t] && (k < 0 || assign_[t] == k)) {
      sse += ScaledError(t, assign_[t], false);
      n += 3 * train_count_[t];
    }
  return n ? std::sqrt(sse / n) : 0.0;
}

double Clustering::ClusterSse(int k) const {
  double sse = 0;
  for (int t = 0; t < nt_; ++t)
    if (usable_[t] && assign_[t] == k) sse += ScaledError(t, k, false);
  return sse;
}

std::vector<float> Clustering::Predict(const BasisMaterial& b) const {
  std::vector<float> p(3 * size_t(s_.size()));
  constexpr int64_t kChunk = 4096;
  ParallelFor((s_.size() + kChunk - 1) / kChunk, threads(), [&](long k) {
    const int64_t first = k * kChunk, n = std::min<int64_t>(kChunk, s_.size() - first);
    std::vector<Rgb> f(n);
    PredictSamples(b.spec, b.params.data(), s_, nullptr, first, n, f.data());
    for (int64_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) p[3 * (first + i) + c] = float(f[i][c]);
  });
  return p;
}

uint64_t PartitionKey(const std::vector<int>& assign) {
  std::vector<int> renumber;
  uint64_t h = 1469598103934665603ull;  // FNV-1a, 64 bit
  for (int a : assign) {
    int c = -1;
    if (a >= 0) {
      if (a >= int(renumber.size())) renumber.resize(a + 1, -1);
      if (renumber[a] < 0) renumber[a] = int(std::count_if(renumber.begin(), renumber.end(), [](int r) { return r >= 0; }));
      c = renumber[a];
    }
    h = (h ^ uint64_t(uint32_t(c))) * 1099511628211ull;
  }
  return h;
}

BasisMaterial MakeBasis(const ModelSpec& spec, const FitResult& r, int index) {
  BasisMaterial b;
  b.name = Msg("m", index);
  b.spec = spec;
  b.params = r.params;
  return b;
}

// Assign and refit until stable or `iterations` done; drops empty clusters.
void Refine(Clustering& cl, int iterations, bool fits_current, const std::atomic<bool>* stop) {
  for (int it = 0; it < iterations; ++it) {
    if (stop && *stop) return;
    const long changed = cl.Assign();
    bool removed = false;  // renumbers the clusters: MembershipChanged no longer applies
    for (int k = cl.K() - 1; k >= 0; --k) {
      const bool empty = std::none_of(cl.assign().begin(), cl.assign().end(), [&](int a) { return a == k; }) ||
                         cl.Ids(k, false).empty();
      if (empty && cl.K() > 1) cl.RemoveBasis(k), removed = true;
    }
    if (changed == 0 && it > 0) break;
    // A cluster whose texels did not change keeps its fit when that fit
    // was made on exactly these texels (after the first pass, or when the
    // caller says so: the split search's untouched clusters and halves).
    std::vector<int> refit;
    for (int k = 0; k < cl.K(); ++k)
      if (!((it > 0 || fits_current) && !removed && !cl.MembershipChanged(k))) refit.push_back(k);
    // The refits are independent: side by side, one thread each, rather
    // than one after the other on all threads (a small fit leaves most of
    // its threads idle through Ceres' serial steps). Staged fits use about
    // the same number of samples whatever the cluster's size, so they take
    // about as long. Messages are printed in cluster order afterwards.
    const int threads = ResolveThreads(cl.threads());
    const int side_by_side = std::max(1, std::min<int>(threads, int(refit.size())));
    std::vector<BasisMaterial> next(refit.size());
    std::vector<std::string> notes(refit.size());
    ParallelFor(long(refit.size()), side_by_side, [&](long j) {
      if (stop && *stop) return;
      const int k = refit[j];
      BasisMaterial& b = next[j] = cl.basis()[k];
      // Warm start: the material already fits most of the cluster's texels.
      // A refit that fails keeps that material (a valid fit of nearly the
      // same texels) instead of ending the reconstruction.
      // So does a refit that reflects far more light than it receives (a
      // Lafortune lobe grown where no photo saw it) when the previous did not.
      try {
        const std::vector<double> params =
            cl.Fit(b.spec, k, b.params, 0, std::max(1, threads / side_by_side), false).params;
        double albedo = 0;
        if (ReflectsMoreThanItReceives(b.spec, params, &albedo) && !ReflectsMoreThanItReceives(b.spec, b.params))
          notes[j] = Msg("  cluster ", k, " keeps its previous fit: the refit reflects more light than it receives "
                         "(directional albedo up to ", albedo, ")\n");
        else
          b.params = params;
      } catch (const Error& e) {
        notes[j] = Msg("  warning: ", e.what(), "; cluster ", k, " keeps its previous fit\n");
      }
    });
    if (stop && *stop) return;
    for (size_t j = 0; j < refit.size(); ++j) {
      std::fputs(notes[j].c_str(), stderr);
      cl.SetBasis(refit[j], next[j]);
    }
  }
}

namespace {
// Process start (static initialisation): the log's wall clock runs on across
// the estimates of one run (the interreflection's second pass, the normal
// stage's second clustering), as its CPU clock does.
const std::chrono::steady_clock::time_point kProcessStart = std::chrono::steady_clock::now();
}  // namespace

StageLog::StageLog(bool on) : on_(on), t0_(kProcessStart) {}

void StageLog::operator()(const std::string& s) const {
  const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  if (on_) std::fprintf(stderr, "  [%6.1f s, CPU %6.1f s] %s\n", t, ProcessCpuSeconds(), s.c_str());
}

}  // namespace svbrdf
