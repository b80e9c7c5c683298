#include <algorithm>
#include <chrono>
#include <string>

#include "cluster/basis_refit.h"
#include "cluster/clustering.h"
#include "cluster/confidence.h"
#include "cluster/model_selection.h"
#include "cluster/prune.h"
#include "cluster/quality.h"
#include "cluster/split.h"
#include "cluster/weights.h"
#include "core/error.h"

namespace svbrdf {

namespace {
void FinishEstimate(Clustering& cl, const Atlas& atlas, double search_seconds, bool refit_basis, bool prune,
                    const StageLog& log, SvbrdfEstimate* est);
}  // namespace

namespace {

// Steps 1-2, then (unless `search_only`) 3-6.
SvbrdfEstimate Estimate(const SampleSet& samples, const Atlas& atlas, const ReconstructOptions& o,
                        const SampleSet* fit_samples, bool search_only) {
  o.Check();
  if (samples.size() == 0) throw Error("reconstruct: no samples");
  Clustering cl(samples, atlas, o);
  SvbrdfEstimate est;
  const StageLog log(o.progress);
  const auto start = std::chrono::steady_clock::now();

  // 1. One cluster.
  cl.stage = "initial fit";
  cl.SetBasis(0, FitSplitModel(cl, 0, nullptr));
  const double heldout = cl.HeldoutRmse();
  est.history.push_back({1, cl.TrainRmse(), heldout, true, PartitionKey(cl.assign())});
  log(Msg("1 cluster: held-out RMSE ", heldout));

  // 2. Progressive splitting with backtracking (split_search.cc). Under a
  // deadline, not even one split when it would not fit with model selection
  // after it (SplitSearchReserve): a split costs about four fits like the
  // first (two halves, then refinement refits).
  const double first_fit_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  cl.stage = "split";
  if (o.SecondsLeft() > 4 * first_fit_seconds + SplitSearchReserve(first_fit_seconds)) {
    SearchClusters(cl, &est, log, 4 * first_fit_seconds, first_fit_seconds);
  } else {
    est.cut_by_deadline.push_back("split search");
    log(Msg("time budget: no time for a split (", o.SecondsLeft(), " s left)"));
  }

  // 3. Model economy per cluster (model_selection.cc). Under a deadline it
  // runs per cluster while it fits (the clustering model is the fallback).
  const double search_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // Steps 3-6 fit with linear residuals: the brightness compression
  // (FitOptions::compression) serves the search, whose splits it keeps from
  // chasing the fits' highlight errors; the materials themselves are chosen
  // and fitted for the light they send, highlights included (with
  // compressed fits a metal's model selection can prefer a coated
  // material, whose diffuse follows the dark flanks of the metal's lobe).
  ReconstructOptions linear = o;
  linear.fit.compression = 0;
  const bool subset = fit_samples != nullptr && fit_samples != &samples;
  if (subset && (fit_samples->num_texels != samples.num_texels || fit_samples->size() == 0))
    throw Error(Msg("reconstruct: the fit samples (", fit_samples->size(), " on ", fit_samples->num_texels,
                    " texels) are not a subset of the ", samples.num_texels, " texels' samples"));
  est.search = {cl.basis(), cl.assign(), search_seconds, {}};
  if (search_only) {
    // Mixing weights of the search's materials, for light transport with them
    // (the interreflection's second pass): blends as wide as the widest
    // radius allows, a partition of unity; one solve, no choice.
    const std::vector<WeightModel> models = CandidateWeightModels(o);
    WeightModel m = models.front();
    for (const WeightModel& c : models)
      if (c.radius >= m.radius && c.unit_sum_samples >= m.unit_sum_samples) m = c;
    cl.FinalWeights(m, &est.search.weights, nullptr);
    return est;
  }
  if (!subset && !(o.fit.compression > 0)) {
    FinishEstimate(cl, atlas, search_seconds, o.refit_basis_on_weights, true, log, &est);
    return est;
  }
  // Steps 3-6 on the fit samples: the search's partition and materials carry over.
  Clustering fit(subset ? *fit_samples : samples, atlas, linear);
  for (int k = 0; k < cl.K(); ++k) fit.SetBasis(k, cl.basis()[k]);
  fit.assign() = cl.assign();
  if (subset) log(Msg("fits and weights on ", fit_samples->size(), " of the ", samples.size(), " samples"));
  FinishEstimate(fit, atlas, search_seconds, o.refit_basis_on_weights, true, log, &est);
  return est;
}

}  // namespace

SvbrdfEstimate EstimateSvbrdf(const SampleSet& samples, const Atlas& atlas, const ReconstructOptions& o,
                              const SampleSet* fit_samples) {
  return Estimate(samples, atlas, o, fit_samples, false);
}

SvbrdfEstimate SearchSvbrdf(const SampleSet& samples, const Atlas& atlas, const ReconstructOptions& o) {
  return Estimate(samples, atlas, o, nullptr, true);
}

namespace {

// Steps 3-6 (FinishEstimate) with linear residuals on `samples`, from the
// partition `assign` (values < 0 join cluster 0; the refinement reassigns
// them) and `basis` as starting points.
SvbrdfEstimate FinishFrom(const SampleSet& samples, const Atlas& atlas, const ReconstructOptions& o,
                          const std::vector<BasisMaterial>& basis, const std::vector<int>& assign,
                          const std::string& what, double search_seconds, bool as_estimate, SvbrdfEstimate est) {
  o.Check();
  if (samples.size() == 0) throw Error("reconstruct: no samples");
  if (basis.empty() || int(assign.size()) != samples.num_texels)
    throw Error(Msg("reconstruct: ", what, " needs materials and a partition of the same ", samples.num_texels,
                    " texels"));
  ReconstructOptions linear = o;  // as steps 3-6 of EstimateSvbrdf
  linear.fit.compression = 0;
  Clustering cl(samples, atlas, linear);
  const StageLog log(o.progress);
  cl.stage = what.c_str();
  for (int k = 0; k < int(basis.size()); ++k) cl.SetBasis(k, basis[k]);
  for (int t = 0; t < samples.num_texels; ++t) cl.assign()[t] = std::max(0, assign[t]);
  log(Msg(what, ": ", cl.K(), " basis materials on the given samples"));
  FinishEstimate(cl, atlas, search_seconds, as_estimate && o.refit_basis_on_weights, as_estimate, log, &est);
  return est;
}

}  // namespace

SvbrdfEstimate FinishEstimateOnNewSamples(const SampleSet& samples, const Atlas& atlas, const ReconstructOptions& o,
                                          const SvbrdfEstimate& previous) {
  SvbrdfEstimate est;
  est.history = previous.history;
  est.states_revisited = previous.states_revisited;
  est.blend_splits = previous.blend_splits;
  est.holes_relabelled = previous.holes_relabelled;
  est.search = previous.search;
  return FinishFrom(samples, atlas, o, previous.search.basis, previous.search.assign, "steps 3-6 from the split search",
                    previous.search.seconds, true, std::move(est));
}

SvbrdfEstimate RefitSvbrdf(const SampleSet& samples, const Atlas& atlas, const ReconstructOptions& o,
                           const SvbrdfEstimate& previous) {
  SvbrdfEstimate est;
  est.history = previous.history;
  est.pruned = previous.pruned;
  // The partition of `previous`, its materials as starting points. No
  // pruning and no basis refit on the weights here: the normal stage's
  // rounds refit in the refined normals' frames and polish the basis with
  // the tilts; a refit on the weights inside them drifts (default_bump: the
  // final photo check and the held-out views get worse;
  // bench_results/independent.md).
  return FinishFrom(samples, atlas, o, previous.basis, previous.label, "refit", 0.0, false, std::move(est));
}

namespace {

// Steps 3-6 of EstimateSvbrdf on a clustering state (shared with RefitSvbrdf).
void FinishEstimate(Clustering& cl, const Atlas& atlas, double search_seconds, bool refit_basis, bool prune,
                    const StageLog& log, SvbrdfEstimate* est_out) {
  SvbrdfEstimate& est = *est_out;
  const ReconstructOptions& o = cl.options();
  const SampleSet& samples = cl.samples();
  cl.stage = "model selection";
  cl.well_seen_fits_ = true;
  // Selection of all clusters together costs about a third of the search's
  // time, at most about three quarters (the randomized captures'
  // development scenes, docs/measurements.md); half the search's time,
  // shared equally among the clusters, is predicted for the first wave
  // (SelectModels measures the rest).
  SelectModels(cl, &est, log, 0.5 * search_seconds / std::max(1, cl.K()));
  // A cluster whose core fit leans on the model's bounds is fitted again on
  // all its texels (the model chosen stays), and from here on. The core
  // leaves out the blend zones (ReconstructOptions::core_fit_rings), but
  // where model error, not blending, dominates, the core alone can miss
  // what the borders show and pin a parameter: on a bump-mapped capture a
  // Cook-Torrance fitted on the core took its specular amplitude to its
  // bound and relit its texels far worse, and the normal stage then kept no
  // normal (NormalRefinement.LowersHeldOutErrorOnABumpMappedCapture).
  // A metallic of 0 or 1 is a dielectric or a metal, which the core does
  // tell: refitted on all texels, a principled plastic of metallic 0 took
  // the blend zone's highlights back (extra seed 29, docs/measurements.md,
  // "Fits on the regions' cores").
  for (int k = 0; k < cl.K() && o.SecondsLeft() > 0; ++k) {
    const BasisMaterial core_fit = cl.basis()[k];
    if (!cl.FitsOnCore(k) || !FitAtBound(core_fit.spec, core_fit.params, false)) continue;
    cl.SetAllTexelFits(k);
    cl.SetBasis(k, MakeBasis(core_fit.spec, cl.Fit(core_fit.spec, k, core_fit.params, o.selection_samples), k));
    log(Msg("cluster ", k, ": the core's ", core_fit.spec.Label(), " fit is at a bound; fitted on all its texels"));
  }
  if (o.SecondsLeft() > 0) {
    cl.stage = "final refinement";
    Refine(cl, std::max(1, o.refine_iterations - 1));
  } else {
    est.cut_by_deadline.push_back("final refinement");
  }

  // 4. Mixing weights: scalar or per channel, and how far materials mix, by held-out error (weights.cc).
  const WeightModel weight_model = ChooseWeightModel(cl, &est, log);
  // 4a. Materials the others, mixed by these weights, explain (prune.h).
  if (prune) PruneMaterials(cl, weight_model, &est, log);
  // 4b. The basis refitted given the weights (basis_refit.h).
  // Only where every cluster's model explains its samples: the refit
  // subtracts the other materials' predicted shares, which model error
  // (unmodelled bumps, interreflection) makes wrong: on default_bump (two
  // clusters poorly explained by the mesh normals) a refit kept at this
  // stage leads the normal stage astray.
  // The quality is a full weight solve: measured here once, and again in
  // step 6 only when the refit changed the basis (nothing else below changes
  // what it measures).
  std::vector<ClusterQuality> quality;
  bool refitted = false;
  if (refit_basis && o.SecondsLeft() > 0) {
    quality = MeasureClusterQuality(cl, weight_model);
    int poor = -1;
    for (const ClusterQuality& q : quality)
      if (q.poorly_explained && poor < 0) poor = q.cluster;
    if (poor >= 0) log(Msg("basis refit on the weights skipped: cluster ", poor, " is poorly explained"));
    else refitted = RefitBasisOnWeights(cl, weight_model, {}, &est, log);
  }
  const std::vector<int> training_labels = cl.assign();
  cl.LabelUnseenByAllSamples();
  ChooseWeightSmoothing(cl, weight_model, &est, log);
  cl.FinalWeights(weight_model, &est.weights, &est.residual);
  cl.assign() = training_labels;  // the quality below is measured as the weights were chosen

  // 6. What the model explains poorly (quality.cc).
  est.cluster_quality = quality.empty() || refitted ? MeasureClusterQuality(cl, weight_model) : quality;
  for (const ClusterQuality& q : est.cluster_quality)
    log(Msg("cluster ", q.cluster, " (", cl.basis()[q.cluster].spec.Label(), ", ", q.texels, " texels): held-out RMSE ",
            q.heldout_rmse, " = ", 100 * q.heldout_rmse / std::max(1e-300, q.signal_rms), " % of its signal",
            q.poorly_explained ? ": POORLY EXPLAINED by every candidate model" : ""));

  // 5. Confidence and neighbour fill (confidence.cc).
  ConfidenceAndFill(samples, atlas, o, cl.K(), cl.neighbours(), &est);
  log(Msg(est.texels_without_samples, " texels no photo saw: ", est.texels_filled,
          " filled from their neighbours on the surface"));
  for (int k = 0; k < cl.K(); ++k) cl.basis()[k].name = Msg("m", k);
  est.basis = cl.basis();
}

}  // namespace

}  // namespace svbrdf
