#include "pipeline/merge_stage.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

#include "cluster/holdout.h"
#include "core/error.h"
#include "core/parallel.h"
#include "fit/fit.h"
#include "normals/refine.h"
#include "pipeline/normal_stage.h"

namespace svbrdf {

SvbrdfEstimate WithMaterialsMerged(const SvbrdfEstimate& est, int into, int from) {
  const int K = int(est.basis.size());
  if (into == from || into < 0 || from < 0 || into >= K || from >= K)
    throw Error(Msg("merge: materials ", into, " and ", from, " of ", K, " cannot be merged"));
  SvbrdfEstimate out = est;
  // The larger cluster's material (most texels) starts the refit.
  long n_into = 0, n_from = 0;
  for (int l : est.label) n_into += l == into, n_from += l == from;
  if (n_from > n_into) out.basis[into] = est.basis[from];
  out.basis.erase(out.basis.begin() + from);
  for (int& l : out.label) {
    if (l == from) l = into;
    if (l > from) --l;
  }
  out.weights.clear();
  return out;
}

bool MergePays(double merged_rmse, double apart_rmse, double min_improvement) {
  return apart_rmse >= (1.0 - min_improvement) * merged_rmse;
}

namespace {

// Held-out squared error of one texel's samples predicted by a material
// scaled by a non-negative weight, the weight solved on the texel's
// training samples (as a scalar mixing weight is).
double ScaledTexelError(const SampleSet& samples, const std::vector<int64_t>& train, const std::vector<int64_t>& hold,
                        const BasisMaterial& m) {
  double pp = 0, py = 0;
  for (int64_t s : train) {
    const Rgb p = PredictSample(m.spec, m.params.data(), samples, s);
    for (int c = 0; c < 3; ++c) pp += p[c] * p[c], py += p[c] * samples.y[c][s];
  }
  const double w = pp > 0 ? std::max(0.0, py / pp) : 0.0;
  double sse = 0;
  for (int64_t s : hold) {
    const Rgb p = w * PredictSample(m.spec, m.params.data(), samples, s);
    for (int c = 0; c < 3; ++c) sse += (p[c] - samples.y[c][s]) * (p[c] - samples.y[c][s]);
  }
  return sse;
}

// Whether sample s is of a held-out photo.
bool HeldSample(const SampleSet& samples, const std::vector<char>& held_image, int64_t s) {
  const int im = samples.image[s];
  return im >= 0 && im < int(held_image.size()) && held_image[im];
}

// The training samples of the texels labelled k, in texel order.
std::vector<int64_t> TrainingSamples(const SampleSet& samples, const std::vector<int>& label, int k,
                                     const std::vector<char>& held_image) {
  std::vector<int64_t> train;
  for (int t = 0; t < samples.num_texels; ++t) {
    if (t >= int(label.size()) || label[t] != k) continue;
    for (int64_t s = samples.texel_begin[t]; s < samples.texel_begin[t + 1]; ++s)
      if (!HeldSample(samples, held_image, s)) train.push_back(s);
  }
  return train;
}

}  // namespace

std::optional<BasisMaterial> FitMaterialApart(const SampleSet& samples, const std::vector<int>& label,
                                              const std::vector<BasisMaterial>& basis, int k,
                                              const std::vector<char>& held_image, const FitOptions& fo) {
  const std::vector<int64_t> train = TrainingSamples(samples, label, k, held_image);
  if (train.empty()) return std::nullopt;
  BasisMaterial apart = basis[k];
  apart.params = FitModel(apart.spec, samples, train, fo, apart.params).params;
  return apart;
}

MergeTest TestMerge(const SampleSet& samples, const std::vector<int>& label, const std::vector<BasisMaterial>& basis,
                    int i, int j, const std::vector<char>& held_image, const FitOptions& fo) {
  const std::optional<BasisMaterial> apart_i = FitMaterialApart(samples, label, basis, i, held_image, fo);
  if (!apart_i) return MergeTest{};
  const std::optional<BasisMaterial> apart_j = FitMaterialApart(samples, label, basis, j, held_image, fo);
  if (!apart_j) return MergeTest{};
  return TestMerge(samples, label, basis, i, j, held_image, fo, *apart_i, *apart_j);
}

MergeTest TestMerge(const SampleSet& samples, const std::vector<int>& label, const std::vector<BasisMaterial>& basis,
                    int i, int j, const std::vector<char>& held_image, const FitOptions& fo,
                    const BasisMaterial& apart_i, const BasisMaterial& apart_j) {
  auto held = [&](int64_t s) { return HeldSample(samples, held_image, s); };
  std::vector<int64_t> train_both;
  std::vector<std::pair<int, int>> texels;  // (texel, side)
  bool trained[2] = {false, false};
  for (int t = 0; t < samples.num_texels; ++t) {
    const int side = label[t] == i ? 0 : label[t] == j ? 1 : -1;
    if (side < 0) continue;
    texels.emplace_back(t, side);
    for (int64_t s = samples.texel_begin[t]; s < samples.texel_begin[t + 1]; ++s) {
      if (held(s)) continue;
      trained[side] = true;
      train_both.push_back(s);
    }
  }
  MergeTest r;
  if (!trained[0] || !trained[1]) return r;
  // Apart: each material fitted again on its own training samples, as the
  // merged one is (the same options), from its current parameters
  // (FitMaterialApart).
  const BasisMaterial* apart[2] = {&apart_i, &apart_j};
  // Merged: either material's model fitted on the union (the better one on
  // the held-out photos is kept).
  BasisMaterial merged[2] = {basis[i], basis[j]};
  for (int side = 0; side < 2; ++side)
    merged[side].params = FitModel(merged[side].spec, samples, train_both, fo, merged[side].params).params;
  // Per texel, one scalar weight (as many unknowns either way): of its own
  // cluster's material (apart) or of the merged one, solved on the texel's
  // training samples, errors on its held-out ones; texels without both kinds
  // of samples are left out. Two free weights per texel apart overfit a
  // texel's few samples and made merging look better than it is (the small
  // bumped capture's glossy paint and red plastic).
  double apart_sse = 0, merged_sse[2] = {0, 0};
  int64_t count = 0;
  for (const auto& [t, side] : texels) {
    std::vector<int64_t> tr, ho;
    for (int64_t s = samples.texel_begin[t]; s < samples.texel_begin[t + 1]; ++s) (held(s) ? ho : tr).push_back(s);
    if (tr.empty() || ho.empty()) continue;
    apart_sse += ScaledTexelError(samples, tr, ho, *apart[side]);
    for (int k = 0; k < 2; ++k) merged_sse[k] += ScaledTexelError(samples, tr, ho, merged[k]);
    count += int64_t(ho.size());
  }
  if (count == 0) return r;
  const int m = merged_sse[1] < merged_sse[0] ? 1 : 0;
  r.merged_model = merged[m].spec.Label();
  r.apart_rmse = std::sqrt(apart_sse / (3.0 * double(count)));
  r.merged_rmse = std::sqrt(merged_sse[m] / (3.0 * double(count)));
  r.tested = true;
  return r;
}

std::vector<int> InteriorLabels(const Atlas& atlas, const std::vector<int>& label) {
  std::vector<int> out = label;
  for (size_t t = 0; t < atlas.texels.size() && t < label.size(); ++t)
    for (int u : TexelNeighbours8(atlas, int(t), int(label.size())))
      if (label[u] != label[t]) out[t] = -1;
  return out;
}

MergeReport MergeSameMaterials(const GatherResult& g, const ReconstructOptions& eo, const NormalRefinement& nr,
                               const MergeOptions& mo, double cluster_seconds, StageTimer* timer, SvbrdfEstimate* est,
                               NormalRefinement* follow) {
  mo.Check();
  MergeReport report;
  if (!mo.enabled || !nr.kept || est->basis.size() < 2) return report;
  timer->Start("merge materials");
  const SampleSet reoriented = ReorientSamples(g.samples, nr.tilt);
  int num_images = 0;
  for (int32_t im : reoriented.image) num_images = std::max(num_images, int(im) + 1);
  // The clustering's held-out photos (holdout.h), so that the test is on
  // photos no fit here saw.
  const std::vector<char> held = HeldOutImages(num_images, eo.holdout_fraction, eo.seed);
  FitOptions fo = eo.fit;
  fo.max_samples = std::min<int64_t>(fo.max_samples, eo.selection_samples);
  fo.threads = 1;
  fo.context = "reconstruct: merge test";
  ReconstructOptions quiet = eo;
  quiet.progress = false;
  SvbrdfEstimate apart;  // the current state refitted on the reoriented samples
  bool have_apart = false;
  while (est->basis.size() >= 2) {
    const int K = int(est->basis.size());
    std::vector<std::pair<int, int>> pairs;
    for (int i = 0; i < K; ++i)
      for (int j = i + 1; j < K; ++j) pairs.emplace_back(i, j);
    // Two screens per pair, on all the pair's texels and on its
    // region-interior texels only; a pair that passes either goes on to the
    // refit below, which decides. Neither screen alone is right: a
    // blend-zone texel mixes its cluster's material with a neighbour's,
    // which neither one material apart nor the merged one (one weight per
    // texel here) represents, so a cluster made of blend zones can look
    // better apart on all texels while its interior says merge, and the
    // other way round on another seed of the same capture (the mixed
    // preset's copper split); the refit confirms either.
    const std::vector<int> interior = InteriorLabels(g.atlas, est->label);
    const size_t np = pairs.size();
    const std::vector<int>* screen_labels[2] = {&est->label, &interior};
    // A material's fit apart depends only on its own texels, so it is made
    // once per screen rather than once per pair it is in. A failed fit
    // (Ceres) leaves its pairs untested, not the run failed.
    std::vector<std::optional<BasisMaterial>> apart_fit(2 * size_t(K));
    ParallelFor(long(2 * K), eo.threads, [&](long q) {
      try {
        apart_fit[q] = FitMaterialApart(reoriented, *screen_labels[q / K], est->basis, int(q % K), held, fo);
      } catch (const Error& e) {
        apart_fit[q].reset();
      }
    });
    std::vector<MergeTest> tests(2 * np);
    ParallelFor(long(2 * np), eo.threads, [&](long q) {
      const size_t p = size_t(q) % np, screen = size_t(q) < np ? 0 : 1;
      const std::optional<BasisMaterial>& a = apart_fit[screen * K + pairs[p].first];
      const std::optional<BasisMaterial>& b = apart_fit[screen * K + pairs[p].second];
      if (!a || !b) return;
      try {
        tests[q] = TestMerge(reoriented, *screen_labels[screen], est->basis, pairs[p].first, pairs[p].second, held,
                             fo, *a, *b);
      } catch (const Error& e) {
        tests[q] = MergeTest{};
      }
    });
    int best = -1;
    double best_ratio = 0;
    for (size_t q = 0; q < 2 * np; ++q) {
      const size_t p = q % np;
      const MergeTest& t = tests[q];
      if (!t.tested) continue;
      const bool pays = MergePays(t.merged_rmse, t.apart_rmse, eo.min_improvement);
      report.lines.push_back(Msg("materials ", pairs[p].first, " (", est->basis[pairs[p].first].spec.Label(), ") and ",
                                 pairs[p].second, " (", est->basis[pairs[p].second].spec.Label(), ")",
                                 q < np ? "" : ", interior texels", ": held-out RMSE apart ", t.apart_rmse,
                                 ", merged (", t.merged_model, ") ", t.merged_rmse, pays ? ": merge" : ": apart"));
      std::fprintf(stderr, "  merge test: %s\n", report.lines.back().c_str());
      const double ratio = t.merged_rmse / t.apart_rmse;
      if (pays && (best < 0 || ratio < best_ratio)) best = int(p), best_ratio = ratio;
    }
    if (best < 0) break;
    // The test above leaves out what the final weights add (their priors
    // towards the cluster's material and the neighbours' weights): with few
    // samples per texel two free weights overfit, and the small bumped
    // capture's test can prefer merging its glossy paint with its red
    // plastic, which relights far worse. So the passing pair is confirmed on
    // the whole estimate, refitted apart and merged (model choice, weights)
    // on the samples in the refined frames, by the same bar; a refit costs
    // about a material round.
    if (eo.SecondsLeft() <= cluster_seconds * (have_apart ? 0.5 : 1.0)) {
      est->cut_by_deadline.push_back("merge of basis materials");
      break;
    }
    if (!have_apart) apart = RefitSvbrdf(reoriented, g.atlas, quiet, *est), have_apart = true;
    SvbrdfEstimate merged =
        RefitSvbrdf(reoriented, g.atlas, quiet, WithMaterialsMerged(*est, pairs[best].first, pairs[best].second));
    const bool confirmed = MergePays(merged.heldout_rmse, apart.heldout_rmse, eo.min_improvement);
    report.lines.push_back(Msg("materials ", pairs[best].first, " and ", pairs[best].second,
                               " refitted: held-out RMSE apart ", apart.heldout_rmse, ", merged ", merged.heldout_rmse,
                               confirmed ? ": merged" : ": kept apart"));
    std::fprintf(stderr, "  merge: %s\n", report.lines.back().c_str());
    if (!confirmed) {
      if (report.merges == 0) report.refit_apart = std::move(apart);
      break;
    }
    if (follow) FollowMerge(pairs[best].first, pairs[best].second, merged, follow);
    *est = merged;
    apart = std::move(merged);
    ++report.merges;
  }
  return report;
}

}  // namespace svbrdf
