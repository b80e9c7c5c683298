// Progressive clustering in the style of Lensch et al. 2001 ("Image-based
// reconstruction of spatially varying materials", EGWR 2001), with the number
// of basis materials and each material's model chosen from held-out data.
//
// Algorithm (every step deterministic for a given seed):
//  0. Split samples into training and held-out sets (per sample, by a hash of
//     seed, texel and image; `holdout_fraction`). Texels with fewer than
//     `min_fit_samples` training samples do not take part in fits.
//  1. One cluster holding every texel; fit `cluster_model` and the
//     `split_models` to it, keep the one with the lowest held-out error
//     (every cluster made by a split below chooses its model the same way).
//  2. Repeat until `max_clusters`:
//     a. Take the cluster with the largest training error.
//     b. Direction of largest parameter variance: each texel's linearised
//        parameter deviation d_t = (n/n_t) H^-1 J_t^T r_t (one Gauss-Newton
//        step on its own samples, H the cluster's J^T J), whitened per
//        parameter; its principal component v.
//     c. Split the cluster's texels by the sign of (d_t - mean) . v (the
//        parameter offsets +-v of Lensch's split), fit a model to each half.
//     d. Refinement: assign every texel to the basis material that explains its
//        training samples best (with one free brightness scale per texel),
//        refit the clusters that changed; `refine_iterations` times.
//     e. Held-out error: whole photos are held out; every texel's training
//        samples are projected onto the basis materials of its own and its
//        neighbours' clusters with non-negative scalar weights (NNLS, with a
//        weak prior towards its own cluster), and the squared error on its
//        held-out samples is measured. A split counts as an improvement when
//        the error drops by `min_improvement` (relative, without the worst
//        2 % of texels of either state: TrimmedDrop) and by `min_z`
//        standard errors (paired tests over texels: on squared errors, or on
//        bounded per-texel changes), and beats a control split of the same
//        cluster along a non-material direction by as much (`control_split`:
//        honest when model error dominates); otherwise the split is
//        undone and the next-worst cluster is split instead
//        (`max_failed_splits` failures in a row end the search, once every
//        poorly explained cluster has been tried); a split whose smaller
//        half has fewer than `min_cluster_fraction` of the texels is not
//        made. No clustering state (texel partition) is evaluated twice.
//  3. Model economy per cluster: screen every candidate model by a quick fit
//     to a small random subset of the cluster's training samples, fit the
//     best few fully (`selection_samples` of them), keep the model with the
//     fewest parameters unless the best model's held-out RMSE (trimmed of the
//     worst 2 % of samples: misassigned texels) is lower by `parsimony` times
//     the RMS of the signal and by `model_min_z` standard errors (paired); refine again.
//  4. Mixing weights: NNLS per texel over all its samples (a weak prior
//     towards its cluster's material, then towards its neighbours' weights),
//     either one scalar weight per basis material or one per colour channel,
//     mixing the materials of the clusters within one of `weight_radii`
//     texels, whichever predicts the held-out samples best.
//  5. Texels with too few or poorly spread samples: low confidence; texels
//     no photo saw: weights filled in from their neighbours on the surface
//     (across chart borders and seams too).
//  6. Per cluster: held-out RMSE relative to the signal; clusters above
//     `poor_fit` are reported as poorly explained (no candidate fits them).
#pragma once
#include <chrono>
#include <string>
#include <vector>

#include "atlas/atlas.h"
#include "fit/fit.h"
#include "gather/samples.h"
#include "io/material.h"

namespace svbrdf {

struct ReconstructOptions {
  // Models tried for every basis material (model selection); `force_model` skips the choice.
  std::vector<std::string> candidate_models = {"lambert", "oren_nayar", "lafortune-1", "lafortune-2",
                                               "cook_torrance-beckmann", "cook_torrance-ggx", "conductor-ggx-schlick",
                                               "conductor-ggx", "conductor-beckmann", "coated-ggx", "coated-beckmann",
                                               "plastic", "gltf", "principled", "principled-clearcoat"};
  std::string force_model;
  std::string cluster_model = "lafortune-1";  // model used while splitting (with split_models)
  // Beside `cluster_model`, models fitted to every cluster while splitting
  // (those also among the candidates); each cluster keeps the one with the
  // lowest error on its held-out samples. One model cannot represent every
  // material: a Lafortune lobe fitted to a glossy plastic extrapolates
  // wildly to unseen directions, and no dielectric reflects like a metal
  // (coloured, near 1, no diffuse), so splits into such materials looked
  // worse than no split. A physically bounded dielectric and a conductor
  // cover the two kinds of interface.
  std::vector<std::string> split_models = {"coated-ggx", "conductor-ggx-schlick"};
  int max_clusters = 6;
  int force_clusters = 0;        // > 0: exactly this many basis materials (no stopping rule)
  double holdout_fraction = 0.2;
  double min_improvement = 0.02; // a split must lower the held-out squared error by this (relative)
  double min_z = 3.0;            // ... and by this many standard errors (paired over texels)
  // A split must also beat, by min_z and by min_improvement (or by
  // control_min_share of its own drop, whichever is smaller), the control
  // split of the same cluster along a non-material direction (honest stopping
  // when model error dominates the residuals; see split.h GeometrySplitSides).
  // The share lets a small material (a split that lowers the error by a few
  // percent) pass when most of its gain is material, while splits of model
  // error (large drop, control nearly as good) still fail.
  bool control_split = true;
  double control_min_share = 1.0 / 3.0;
  // After the split search: specks of other clusters inside one cluster's
  // region (region_holes.h), smaller than a split may make a cluster,
  // relabelled to it; that cluster chooses its split model again, the
  // others are refitted; kept when the held-out error drops as a split's
  // must (min_improvement, min_z).
  bool absorb_region_holes = true;
  // A split must leave regions, not a salt-and-pepper pattern: the share of
  // 8-neighbour pairs of the split cluster's texels whose labels differ,
  // relative to that share under random labels of the same proportions,
  // must be at most 1 - min_split_coherence. Halves interleaved texel by
  // texel are texels that both materials explain about equally (model error
  // specialised to the directions each texel saw, e.g. the copper of the
  // Mitsuba sphere split texel by texel after the refinement's neighbour
  // pooling), not two materials; such a split is undone without looking a
  // split further. Clean material splits score close to 1
  // (docs/method/reconstruction.md); a stripe w texels wide inside another
  // region scores about 1 - 0.75/w, so 0.7 keeps regions >= 3 texels wide.
  // 0 = off.
  double min_split_coherence = 0.7;
  // The split search stops after this many splits in a row that did not
  // improve on the best state (each tries another feature set or the
  // next-worst cluster, with backtracking).                          [1, 20]
  // On the generalization benchmark's dev half every kept split came after
  // at most one failed one, while the search went on for 2.5-19 s after
  // its last kept split with 4 (bench_results/generalization.md).
  int max_failed_splits = 2;
  // ... but not while a cluster of the best state is poorly explained
  // (held-out RMSE above `poor_fit` of its signal RMS, with the search's
  // weights) and no split of it has been tried since that state was kept:
  // each such cluster is tried once more. The failures in a row can all fall
  // on the worst cluster by squared error (the largest, or the brightest),
  // while a smaller cluster mixing two materials is never tried (seen on a
  // Mitsuba elephant scan of five materials: two failed splits of the
  // larger diffuse cluster ended the search at 2 materials, the other
  // cluster, far above `poor_fit`, untried; docs/measurements.md).
  bool split_poor_clusters = true;
  // A split that fails is followed by one more split of the same state (a
  // look-ahead: 3 materials split into 2 clusters can be worse than 1, the
  // next split separates them) this many times per best state; later
  // failures from it backtrack at once. On the generalization benchmark's
  // dev and extra halves and the four issue captures a look-ahead was kept
  // after the first failure from a state (4 of the 21 tried there), never
  // after the second (0 of 10 tried), each of those costing about a second
  // (docs/measurements.md, "One look-ahead per state").               [0, 20]
  int lookaheads_per_state = 1;
  double poor_fit = 0.10;        // report clusters whose held-out RMSE exceeds this share of their signal RMS
  double model_min_z = 1.0;      // a model with more parameters must win by this many standard errors
  double min_cluster_fraction = 0.03;  // a split's halves must each hold this share of texels
  double parsimony = 0.001;      // prefer fewer parameters unless the best's RMSE is lower by this x signal RMS
  int64_t selection_samples = 3000;  // samples per candidate fit during model selection
  // Model selection's errors on the photos' display scale (stats.h
  // DisplayScale: per image, pixel value per unit sample value; set from the
  // capture by the pipeline), or linear when empty (`--selection-error linear`).
  std::vector<Rgb> display_scale;
  int refine_iterations = 2;
  // Per-texel weights mix the materials of every cluster within this many
  // texels (Chebyshev distance in the atlas): blends wider than one texel and
  // junctions of three or more regions get all their materials.
  int mix_radius = 2;
  // The final weights (step 4) try every radius here (and scalar or per
  // channel weights) and keep the one with the lowest held-out error: blend
  // zones are as wide as the object makes them, in texels as the atlas
  // makes them (on the default preset the widest radius predicts best; on
  // scans with soft blends 16 texels and more).
  std::vector<int> weight_radii = {2, 4, 8, 16, 32};
  std::vector<double> weight_unit_sum_samples = {0.0, 1.0, 1000.0};
  // Step 4b (basis_refit.h): every basis material refitted on the samples
  // of the texels it dominates, the others' share (weights x predictions)
  // subtracted; kept when the held-out error falls.
  bool refit_basis_on_weights = true;
  // Step 4a (prune.h): after the weight model is chosen, a basis material
  // that the others mixed by the weights explain about as well (it lowers
  // the held-out error by less than `prune_min_drop`) is removed, weakest
  // first (`--prune` / `--no-prune`).
  bool prune_materials = true;
  // The relative drop of the held-out error (TrimmedDrop, display units) a
  // material must bring to stay in pruning; higher than the split search's
  // `min_improvement`, which lets through, one split at a time, halves whose
  // gain the final weights take back. On the generalization benchmark's dev
  // half true materials and extra ones lie far apart on this measure, with
  // this bar between them (docs/measurements.md).                       [0, 1)
  double prune_min_drop = 0.1;
  int min_samples = 3;           // per texel, for confident weights (confidence map)
  // Final materials (model selection and the fits after it) fitted on their
  // clusters' core: the texels whose surface neighbours up to this many
  // rings out all belong to the same cluster, when the core holds half of
  // the cluster's training samples or more (else all its texels). Region
  // borders hold the blends of soft, noisy and sharp-but-sampled material
  // maps, which the mixing weights represent; in a basis fit they pull a
  // sharp material towards a broad lobe, and the blend zone of a material
  // with a sharp highlight can decide another's model (a Beckmann rough
  // plastic beside a sharp principled chose a GGX coat). A cluster whose
  // core fit is at a model bound keeps its model but is refitted on all its
  // texels (estimate.cc). 0 = every texel; 1 ring lost on the dev half's bear and
  // camel (docs/measurements.md, "Core fits").                         [0, 8]
  int core_fit_rings = 2;
  // Per texel, to take part in fits and in the split search's held-out
  // measure. One: cluster fits pool all their texels, and a texel's weights
  // have priors (its cluster's material, its neighbours). With 8 photos most
  // texels have 1-2 training samples (default preset: only a small share
  // have 3 or more, and hardly any of those held-out samples), and a bar of
  // 3 leaves the split search blind: it sees a handful of texels and keeps
  // 2 materials of 3.
  int min_fit_samples = 1;
  // Cauchy loss of cluster fits: < 0 = automatic (3 robust sigmas of the
  // cluster's residuals), 0 = plain least squares, > 0 = this scale.
  double robust_scale = -1.0;
  // Fits of the split search compress residuals by brightness when
  // fit.compression > 0 (`--fit-compression`; model selection and the final
  // fits stay linear, EstimateSvbrdf). Off by default: on the generalization
  // dev half it fixes over-splits, but on the test suite's five-material
  // capture the compressed halves' gain over the control split falls below
  // the threshold and the search keeps 4 (docs/measurements.md).
  FitOptions fit;
  int threads = 0;
  uint64_t seed = 1;
  bool progress = true;
  // Anytime: past this point on the steady clock the split search stops
  // before a split it has no time for (judged by the last split's duration),
  // model selection is skipped when it would not finish (the clustering model
  // is kept), and so is the final refinement; the result is always complete.
  // Default: no deadline.
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();
  // Seconds left before the deadline (+inf without one).
  double SecondsLeft() const;
  void Check() const;
};

// One evaluated clustering state (every state is evaluated at most once).
struct ClusterStep {
  int clusters = 0;
  double train_rmse = 0, heldout_rmse = 0;
  bool accepted = true;     // the state finally chosen
  uint64_t partition = 0;   // canonical key of the texel partition (PartitionKey)
};

struct ModelChoice {
  int cluster = 0;
  std::string label;
  double heldout_rmse = 0;
  int num_params = 0;
  bool chosen = false;
  bool finalist = true;  // fully fitted; false: only screened (heldout_rmse from the screening fit)
};

// How well the final basis materials and weights explain each cluster's
// held-out samples.
struct ClusterQuality {
  int cluster = 0;
  int texels = 0;
  double heldout_rmse = 0;   // per channel, with the final weights mode
  double signal_rms = 0;     // RMS of the held-out samples themselves
  bool poorly_explained = false;  // heldout_rmse > poor_fit * signal_rms
};

struct SvbrdfEstimate {
  std::vector<BasisMaterial> basis;
  int num_texels = 0;
  std::vector<float> weights;     // texel-major: [t][k][c]
  bool per_channel_weights = false;
  int weight_radius = 0;          // materials of clusters this many texels away mix (step 4)
  // The chosen weight model's prior on the sum of a texel's weights towards 1
  // (WeightModel::unit_sum_samples); weights re-solved later (normal
  // refinement) keep it. 0: free brightness.
  double weight_unit_sum = 0;
  // Region-interior smoothing of the weights chosen by held-out error
  // (SmoothInteriorWeights, weights.h); 0 = none. Applied to `weights`, and
  // again by the pipeline to weights re-solved with refined normals.
  double weight_smoothing = 0;
  std::vector<int> label;         // basis index per texel (largest weight)
  std::vector<float> confidence;  // per texel, [0,1]
  std::vector<float> residual;    // per texel RMS residual of its samples
  // Texels that no photo saw, and how many of them got their weights from
  // their surface neighbours (the rest: no neighbour chain to a seen texel).
  int texels_without_samples = 0;
  int texels_filled = 0;
  std::vector<ClusterStep> history;
  int states_revisited = 0;       // splits that led back to an evaluated state (skipped, not re-evaluated)
  int blend_splits = 0;           // splits kept as failed ones: a half the other materials explain (split_search.cc)
  long holes_relabelled = 0;      // texels of region holes the search's chosen state took into their region (region_holes.h)
  std::vector<ModelChoice> model_choices;
  double heldout_rmse = 0;        // final, with the chosen weights mode
  double heldout_rmse_scalar = 0, heldout_rmse_channel = 0;
  std::vector<ClusterQuality> cluster_quality;
  std::vector<std::string> cut_by_deadline;  // stages shortened or skipped by ReconstructOptions::deadline
  // Basis materials the pruning removed after the split search's choice
  // (prune.h), in order: model label, texels, the held-out error drop it brought.
  struct Pruned {
    std::string label;
    int texels = 0;
    double drop = 0, z = 0;
  };
  std::vector<Pruned> pruned;
  // The split search's result that steps 3-6 started from: its basis
  // materials, partition and duration (FinishEstimateOnNewSamples), and
  // from SearchSvbrdf mixing weights of those materials (texel-major
  // [t][k][c], one solve without a choice of the weight model).
  struct SearchState {
    std::vector<BasisMaterial> basis;
    std::vector<int> assign;
    double seconds = 0;
    std::vector<float> weights;
  } search;
};

// `fit_samples` (optional, a subset of `samples` on the same atlas): the
// samples of steps 3-6 (model selection, final fits, weights); the split
// search (steps 1-2) uses all of `samples`. The pipeline passes the samples
// whose pixel footprint is wholly on the lit surface (ReconstructionJob::
// fit_max_unlit_share): the others mix in another surface's or a shadow's
// radiance, which no material explains, yet the split search needs every
// texel's samples to keep its material count (dropping them before it
// gives the Mitsuba bunny too many materials; bench_results/independent.md).
SvbrdfEstimate EstimateSvbrdf(const SampleSet& samples, const Atlas& atlas, const ReconstructOptions& options,
                              const SampleSet* fit_samples = nullptr);

// The partition of `previous` (its labels) kept, every basis material's model
// chosen and fitted again on `samples` (step 3 on), then weights, quality and
// confidence as in EstimateSvbrdf. For samples that changed but not their
// materials' layout, e.g. re-expressed in refined normals' frames
// (normals ↔ materials alternation), at a fraction of a new clustering's cost.
SvbrdfEstimate RefitSvbrdf(const SampleSet& samples, const Atlas& atlas, const ReconstructOptions& options,
                           const SvbrdfEstimate& previous);

// Steps 1-2 of EstimateSvbrdf alone: the split search's result in
// `search` (and `history`), no basis or weights yet; FinishEstimateOnNewSamples
// completes it, on the same samples or on new values of them.
SvbrdfEstimate SearchSvbrdf(const SampleSet& samples, const Atlas& atlas, const ReconstructOptions& options);

// Steps 3-6 of EstimateSvbrdf (model selection, fits, weights, pruning,
// basis refit) from the split search's result that `previous` recorded
// (SvbrdfEstimate::search), on the fit samples or on new values of them
// (the indirect light removed again, interreflection_stage.h).
SvbrdfEstimate FinishEstimateOnNewSamples(const SampleSet& samples, const Atlas& atlas,
                                          const ReconstructOptions& options, const SvbrdfEstimate& previous);

// A material with these basis materials mixed by texel-major [t][k][c]
// weights on the atlas (the rest of the maps empty).
Material MixedMaterial(const std::vector<BasisMaterial>& basis, const std::vector<float>& weights, const Atlas& atlas,
                       const Mesh& mesh);

// Writes the estimate as a material folder (weights, confidence, material-id,
// residual maps) for the given mesh (whose UVs the atlas uses).
Material ToMaterial(const SvbrdfEstimate& est, const Atlas& atlas, const Mesh& mesh);

}  // namespace svbrdf
