#include "cluster/basis_refit.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"

namespace svbrdf {

namespace {

// One round: returns whether the refit was kept (cl's basis set), with the
// held-out RMSE before and after.
bool RefitRound(Clustering& cl, const WeightModel& m, const BasisRefitOptions& ro, double* before_out,
                double* after_out, std::string* line_out) {
  const SampleSet& s = cl.samples();
  const int K = cl.K();
  // Weights from the training samples only: the held-out check below must
  // not see its own samples through them.
  int64_t n = 0;
  std::vector<float> first, w;
  if (m.smooth) cl.MixtureError(m, false, false, &n, &first, nullptr);
  cl.MixtureError(m, false, false, &n, &w, nullptr, nullptr, m.smooth ? &first : nullptr);
  std::vector<double> texel_before;
  const double before = cl.HeldoutRmse(m, &texel_before);
  const std::vector<BasisMaterial> old = cl.basis();
  auto weight = [&](int t, int k, int c) { return double(w[(size_t(t) * K + k) * 3 + c]); };
  std::vector<BasisMaterial> refit = old;
  std::string line;
  for (int k = 0; k < K; ++k) {
    std::vector<char> keep(s.size(), 0);
    long texels = 0;
    for (int t = 0; t < s.num_texels; ++t) {
      if (!cl.usable()[t] || s.texel_begin[t] == s.texel_begin[t + 1]) continue;
      bool own = true;
      for (int c = 0; c < 3; ++c) own = own && weight(t, k, c) >= ro.min_own_weight;
      if (!own) continue;
      ++texels;
      for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) keep[i] = !cl.holdout()[i];
    }
    SampleSet own = KeepSamples(s, keep);
    if (own.size() == 0) continue;
    // The others' share, subtracted sample by sample (every prediction with
    // the sample's footprint, as the fits make them).
    std::vector<int64_t> source;
    source.reserve(own.size());
    for (int64_t i = 0; i < int64_t(s.size()); ++i)
      if (keep[i]) source.push_back(i);
    ParallelFor(long(own.size()), cl.options().threads, [&](long j) {
      const int64_t i = source[j];
      const int t = s.texel[i];
      Rgb others = Rgb::Zero();
      for (int q = 0; q < K; ++q) {
        if (q == k) continue;
        bool any = false;
        for (int c = 0; c < 3; ++c) any = any || weight(t, q, c) > 0;
        if (!any) continue;
        const Rgb p = PredictSample(old[q].spec, old[q].params.data(), s, i);
        for (int c = 0; c < 3; ++c) others[c] += weight(t, q, c) * p[c];
      }
      for (int c = 0; c < 3; ++c) own.y[c][j] = float((s.y[c][i] - others[c]) / weight(t, k, c));
    }, 4096);
    std::vector<int64_t> ids(own.size());
    for (size_t j = 0; j < ids.size(); ++j) ids[j] = int64_t(j);
    FitOptions fo = cl.options().fit;
    fo.multi_start = false;
    fo.context = Msg("reconstruct: material ", k, " (refit on the weights)");
    // A refit the solver fails on leaves the material as it was: it is an
    // improvement step, not a stage that can end the reconstruction.
    try {
      refit[k].params = RobustFit(old[k].spec, own, ids, cl.options(), fo, old[k].params, false).params;
      line += Msg(k ? "; " : "", "m", k, " ", texels, " texels");
    } catch (const Error& e) {
      line += Msg(k ? "; " : "", "m", k, " not refitted (", e.what(), ")");
    }
  }
  // Per material: its refit is kept where the held-out error of the
  // texels it dominates rises by at most max_loss (one material's refit may
  // pay while another's does not), then the whole set is checked once more.
  for (int k = 0; k < K; ++k) cl.SetBasis(k, refit[k]);
  std::vector<double> texel_after;
  double after = cl.HeldoutRmse(m, &texel_after);
  std::vector<char> take(K, 0);
  int taken = 0;
  for (int k = 0; k < K; ++k) {
    double b = 0, a = 0;
    for (int t = 0; t < s.num_texels && t < int(texel_before.size()) && t < int(texel_after.size()); ++t)
      if (weight(t, k, 0) + weight(t, k, 1) + weight(t, k, 2) >= 3 * ro.min_own_weight)
        b += texel_before[t], a += texel_after[t];
    take[k] = a < b * (1.0 + ro.max_loss);
    taken += take[k];
    line += Msg("; m", k, take[k] ? " refitted" : " kept as it was");
  }
  if (taken > 0 && taken < K) {
    for (int k = 0; k < K; ++k) cl.SetBasis(k, take[k] ? refit[k] : old[k]);
    after = cl.HeldoutRmse(m);
  }
  const bool kept = taken > 0 && after < before * (1.0 + ro.max_loss);
  if (!kept)
    for (int k = 0; k < K; ++k) cl.SetBasis(k, old[k]);
  *before_out = before, *after_out = after, *line_out = line;
  return kept;
}

}  // namespace

bool RefitBasisOnWeights(Clustering& cl, const WeightModel& m, const BasisRefitOptions& ro, SvbrdfEstimate* est,
                         const StageLog& log) {
  if (cl.K() == 0 || cl.samples().size() == 0) return false;
  bool any = false;
  for (int round = 1; round <= ro.max_rounds; ++round) {
    double before = 0, after = 0;
    std::string line;
    const bool kept = RefitRound(cl, m, ro, &before, &after, &line);
    log(Msg("basis refit on the weights, round ", round, " (", line, "): held-out RMSE ", before, " -> ", after,
            kept ? ": kept" : ": not kept"));
    if (!kept) break;
    any = true;
    est->heldout_rmse = after;
    if (after > before * (1.0 - ro.min_round_gain)) break;  // converged (or within the tolerance)
    if (cl.options().SecondsLeft() <= 0) break;
  }
  return any;
}

}  // namespace svbrdf
