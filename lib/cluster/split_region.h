// The texels a split step can change, and the split test's relative drop of
// the held-out error measured on them (split_search.cc).
//
// Why: the test "the held-out squared error drops by min_improvement" was
// taken over all texels. When one region is poorly explained (measured: a
// glossy paint under a bump map that the mesh lacks, whose highlights land
// where no mesh-normal fit puts them, holds 90 % of the held-out error), its
// error dilutes every other split: on the bump-mapped default capture the
// right split of a red/green cluster lowered the error of its own texels by
// half but the total by 1.5 %, and the search stopped at 2 of 3 materials.
// Relative to the error of the texels the split can change (the split
// clusters' and the ones that changed cluster, widened by the mixing radius,
// since their neighbours mix the new materials), the drop says how much the
// split explains of what it touches, whatever the rest of the surface does.
#pragma once
#include <vector>

#include "cluster/clustering.h"

namespace svbrdf {

// Texels whose held-out error a step from partition `before` (K_before =
// `before_clusters` clusters) to `after` can change: every texel of the
// clusters of `before` that were split (for each new cluster, index >=
// before_clusters in `after`, the old cluster that gave it most texels),
// every texel that changed cluster, and the texels within `radius`
// 8-neighbour steps of them. Per texel 1/0.
std::vector<char> SplitRegion(const Clustering& cl, const std::vector<int>& before, int before_clusters,
                              const std::vector<int>& after, int radius);

// The drop of the held-out error over all texels (a split's refits change
// clusters beyond the region too, for better or worse), relative to the
// error of `region` before the step: (sum before - sum after) / sum of
// before over `region` (over all texels when that is 0). At least the
// relative drop over all texels whenever the error drops.
double RegionDrop(const std::vector<double>& before, const std::vector<double>& after, const std::vector<char>& region);

// The typical per-texel drop on `region` (all texels when it selects none):
// the mean of the bounded changes (before - after) / (before + after), in
// [-1, 1], over texels with some error. Not dominated by the few texels with
// the largest errors (highlights that a bump map moves).
double BoundedRegionDrop(const std::vector<double>& before, const std::vector<double>& after,
                         const std::vector<char>& region);

}  // namespace svbrdf
