// Split step of the progressive clustering: which texels of a cluster go to
// which half (split.cc), and the search over splits with backtracking and the
// held-out stopping rule (split_search.cc).
#pragma once
#include <limits>
#include <vector>

#include "cluster/clustering.h"

namespace svbrdf {

// Lensch's split of cluster k along the direction of largest parameter
// variance (see reconstruct.h, step 2b). Per texel, the parameters that the
// texel's own few samples do determine are estimated linearly: diffuse
// albedo per channel and the amplitudes of two fixed normalised cosine
// lobes (Lewis, exponents 8 and 64: a broad and a sharp highlight probe),
// by NNLS. The probes do not depend on the cluster's current fit, which may
// be poor while the cluster still mixes materials. The features are
// whitened, split at the mean along their principal component, and the
// split is refined by 2-means. With all five features (variant 0), when one
// half is smaller than a split may make (min_cluster_fraction), that half is
// peeled off and the rest split
// again; the rest's split is taken when both its halves hold at least twice
// that share (extreme texels had hidden two materials), else the small half
// is returned (one material: the search stops there).
// Returns +1/-1 for the texels of cluster k, 0 for the others.
// `variant` selects the features: 0 = all five, 1 = diffuse colour only,
// 2 = gloss amplitudes only (tried in turn when a split does not help).
std::vector<int> SplitSides(const Clustering& cl, int k, int variant);

// The control split for the honest stopping rule: cluster k's texels halved
// by where in the BRDF's domain they were seen (mean elevations of their
// light, view and half vectors), a direction that says nothing about the
// material. Within one material such a split gains only what model error
// lets fits specialised to part of the domain gain; a split into materials
// must gain clearly more. Returns +1/-1 for the texels of cluster k, 0 else.
std::vector<int> GeometrySplitSides(const Clustering& cl, int k);

// The models tried for every cluster while splitting: `force_model` alone
// when set, else `cluster_model` and those `split_models` that are also
// candidates of the model selection.
std::vector<ModelSpec> SplitModels(const ReconstructOptions& o);

// The split-stage basis material of cluster k: every SplitModels() model
// fitted to the cluster's training samples (a screening fit, as in model
// selection: least squares on a small random subset),
// the one with the lowest mean squared error on its validation samples
// (ValidationSamples), then fitted fully from there. `parent` (may be null):
// warm start for the fit of its own model. The choice depends on the
// data alone, not on one model: a metal half gets a conductor, a glossy
// dielectric half a coat, whatever the parent was.
BasisMaterial FitSplitModel(const Clustering& cl, int k, const BasisMaterial* parent);
// FitSplitModel's choice alone: the model and its screening fit (or
// `parent`'s parameters when there is no choice to make), without the full fit.
struct SplitModelChoice {
  ModelSpec spec;
  std::vector<double> start;
  bool screened = false;  // chosen among several by screening fits (`start` is the winner's)
  // Screened: the winner's validation mean squared error, and that of
  // `parent`'s model (infinite when it is not among SplitModels()).
  double mse = 0, parent_mse = std::numeric_limits<double>::infinity();
};
SplitModelChoice ChooseSplitModel(const Clustering& cl, int k, const BasisMaterial* parent);

// The weaker half of a split into clusters k and knew: each half removed in
// turn as pruning removes a material (ScoreRemoval, prune.h), under the
// search's weights (`with_sse`: the per-texel held-out squared errors of
// `cl` as it is); the half with the smaller drop. A half the other
// materials explain about as well is a blend or a part of a material, not a
// material (split_search.cc).
struct SplitHalfTest {
  int half = -1;
  double drop = 0, z = 0;
};
SplitHalfTest WeakerSplitHalf(const Clustering& cl, int k, int knew, const std::vector<double>& with_sse);

// Spatial coherence of the current labels on the texels where `side` != 0
// (a split cluster's texels): 1 - (share of their 8-neighbour pairs with
// different labels) / (that share under random labels of the same
// proportions). ~1: regions with short borders; ~0: labels interleaved
// texel by texel. 1 when the texels carry a single label.
double SplitCoherence(const Clustering& cl, const std::vector<int>& side);

// Share of the `usable` texels whose labels in `a` and `b` agree once the
// labels of b are matched to those of a (greedily, largest overlap first):
// 1 = the same partition under another numbering.
double PartitionAgreement(const std::vector<int>& a, const std::vector<int>& b, const std::vector<char>& usable);

// How much of its start a refined split kept: PartitionAgreement of
// `start` (the partition right after the split) and `refined` over the
// usable texels that were in cluster k of `parent`. 1: the refinement kept
// the split's halves; ~0.5 for a two-way split: it left them (as by chance);
// texels the refinement moved to other clusters count as not kept.
double SplitKeptShare(const std::vector<int>& parent, int k, const std::vector<int>& start,
                      const std::vector<int>& refined, const std::vector<char>& usable);

// Step 2 of EstimateSvbrdf (reconstruct.h): progressive splitting from the
// current state until the stopping rule or the target count; leaves `cl` in
// the chosen state and appends to `est->history`. `first_step_seconds`:
// the expected duration of the first split step; `seconds_before`: how long
// the estimate ran before the search (ReconstructOptions::deadline: a step
// is started only while the time left covers it and the steps after the
// search, SplitSearchReserve).
void SearchClusters(Clustering& cl, SvbrdfEstimate* est, const StageLog& log, double first_step_seconds = 0,
                    double seconds_before = 0);

// Anytime: the time kept for model selection after the split search when
// the estimate has run `elapsed_seconds` so far. Selection costs about a
// third of the search's time (docs/measurements.md), and a short budget
// must not lose it: skipped, a cluster keeps its clustering model, which
// can cost far more held-out accuracy than the search's last splits gain.
// The later steps (weights, fine atlas, normals) cut themselves. A larger
// reserve, one for all of them, stops the search early while its splits
// still matter most: under a 10 s budget a dragon scan then stopped at 2
// clusters of 3 in one run of two.
double SplitSearchReserve(double elapsed_seconds);

}  // namespace svbrdf
