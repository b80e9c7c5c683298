// Step 6 of EstimateSvbrdf (reconstruct.h): which clusters the chosen basis
// materials explain poorly (held-out error per cluster relative to its signal).
#pragma once
#include <vector>

#include "cluster/clustering.h"

namespace svbrdf {

std::vector<ClusterQuality> MeasureClusterQuality(const Clustering& cl, const WeightModel& weights);

}  // namespace svbrdf
