// Step 5 of EstimateSvbrdf (reconstruct.h): per-texel confidence from the
// count and spread of its samples, and weights of texels without confident
// ones filled in from their neighbours; the label map from the weights.
#pragma once
#include <vector>

#include "atlas/atlas.h"
#include "cluster/reconstruct.h"
#include "gather/samples.h"

namespace svbrdf {

// The label ConfidenceAndFill gives every texel of `weights` (texel-major
// [t][k][c] for K materials): its largest weight (LargestWeightLabels), 0
// where all are 0.
std::vector<int> FilledWeightLabels(const std::vector<float>& weights, int K);

// Needs est->weights (K = est->basis size or `num_basis`); sets num_texels,
// confidence and label, and rewrites the weights of unconfident texels.
// `neighbours`: the texels' surface neighbours (SurfaceNeighbours, as the
// clustering keeps them: one list per texel of `samples`).
void ConfidenceAndFill(const SampleSet& samples, const Atlas& atlas, const ReconstructOptions& o, int num_basis,
                       const std::vector<std::vector<int>>& neighbours, SvbrdfEstimate* est);

}  // namespace svbrdf
