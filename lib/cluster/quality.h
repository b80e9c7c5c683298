// Step 6 of EstimateSvbrdf (reconstruct.h): which clusters the chosen basis
// materials explain poorly (held-out error per cluster relative to its signal).
#pragma once
#include <vector>

#include "cluster/clustering.h"

namespace svbrdf {

std::vector<ClusterQuality> MeasureClusterQuality(const Clustering& cl, const WeightModel& weights);
// The same from held-out squared errors per texel already measured (as
// Clustering::HeldoutRmse returns them) with the current assignment.
std::vector<ClusterQuality> ClusterQualityFromTexelSse(const Clustering& cl, const std::vector<double>& texel_sse);

}  // namespace svbrdf
