// Step 4 of EstimateSvbrdf (reconstruct.h): how the per-texel mixing weights
// are estimated (scalar or per channel, how far materials may mix), chosen
// by held-out error.
#pragma once
#include <vector>

#include "cluster/clustering.h"

namespace svbrdf {

// The scalar weight models tried: every radius of options().weight_radii and
// every unit-sum prior, with the per-material prior and the neighbour pass
// (ChooseWeightModel adds one per-channel twin).
std::vector<WeightModel> CandidateWeightModels(const ReconstructOptions& o);

// The order the weight choice scores its candidates in, which matters only
// when a deadline cuts it: the strongest unit-sum prior first, radii from
// the middle of the grid outwards. Those are the choices the randomized
// captures' development scenes made most often (a radius of 8 with the
// prior of 1000 samples, docs/measurements.md); the grid's corner (the
// smallest radius without a prior) was never chosen there, and on a metal
// its weights, free of any prior on their sum, can grow without bound
// where the samples miss the highlights.
std::vector<WeightModel> AnytimeOrder(std::vector<WeightModel> models);

// Evaluates the scalar candidates on the held-out samples, then the
// per-channel twin of the best of them (kept only when clearly better), and
// returns the best;
// records the choice in `est` (per_channel_weights, weight_radius, weight_unit_sum,
// heldout_rmse and the scalar / per-channel errors at the chosen radius).
WeightModel ChooseWeightModel(const Clustering& cl, SvbrdfEstimate* est, const StageLog& log);

// The material of largest weight (summed over the channels) of every texel
// of `weights` (texel-major [t][k][c] for K materials); -1 where all are 0
// (a texel without samples, not filled yet).
std::vector<int> LargestWeightLabels(const std::vector<float>& weights, int K);

// Smoothing inside material regions: a texel whose neighbours all share its
// label (largest weight; every one with weights) moves towards the mean of
// its n neighbours that are interior too (a blend-zone texel shares the
// label at a partial weight): w <- (w + alpha * sum_u w_u) / (1 + alpha * n),
// in one pass from the unsmoothed weights. Texels at a region border or in a
// blend zone, and texels without weights, are left as they are. `weights`
// texel-major [t][k][c] for K materials; alpha >= 0 (0: unchanged).
void SmoothInteriorWeights(const std::vector<std::vector<int>>& neighbours, int K, double alpha,
                           std::vector<float>* weights);

// The smoothing strength of model m's weights with the lowest held-out error
// (weights fitted on the training samples, smoothed, scored on the held-out
// ones), among 0 and a few strengths; sets est->weight_smoothing.
double ChooseWeightSmoothing(const Clustering& cl, const WeightModel& m, SvbrdfEstimate* est, const StageLog& log);

}  // namespace svbrdf
