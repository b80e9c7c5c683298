// Step 4 of EstimateSvbrdf (reconstruct.h): how the per-texel mixing weights
// are estimated (scalar or per channel, how far materials may mix), chosen
// by held-out error.
#pragma once
#include <vector>

#include "cluster/clustering.h"

namespace svbrdf {

// The weight models tried: scalar and per channel at every radius of
// options().weight_radii, with the per-material prior and the neighbour pass.
std::vector<WeightModel> CandidateWeightModels(const ReconstructOptions& o);

// Evaluates every candidate on the held-out samples and returns the best;
// records the choice in `est` (per_channel_weights, weight_radius,
// heldout_rmse and the scalar / per-channel errors at the chosen radius).
WeightModel ChooseWeightModel(const Clustering& cl, SvbrdfEstimate* est, const StageLog& log);

}  // namespace svbrdf
