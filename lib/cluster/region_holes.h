// Holes in the clustering's regions: connected groups of usable texels
// (over the atlas' surface neighbours) without a region's label, small
// against the surface, whose usable neighbours outside the group all hold
// that label. A hole may hold several labels (a speck of one cluster with a
// rim of the cluster of the blends around it).
//
// The split search assigns a texel to the material that explains its own
// samples best, and a sharp material seen in few highlights leaves its
// texels divided: those whose photos caught a highlight join whichever
// cluster has a lobe (a diffuse material's, which then gains one), the
// others a cluster without one. The first show up as specks inside the
// second's region; relabelled to it and refitted, the highlights they saw
// give the enclosing material its lobe and the other material loses the
// one it borrowed (`AbsorbRegionHoles`, kept only when the held-out error
// drops).
#pragma once
#include <string>
#include <vector>

#include "cluster/clustering.h"

namespace svbrdf {

struct RegionHole {
  int surround = -1;  // the label of the region around it
  std::vector<int> texels;
};

// Holes of at most `max_texels` texels. `label` < 0 and texels that are not
// `usable` belong to no hole and do not count as neighbours. A group that
// touches no texel of the region (a whole connected surface) is no hole.
// Sorted by surrounding label, then by first texel.
std::vector<RegionHole> FindRegionHoles(const std::vector<std::vector<int>>& neighbours, const std::vector<int>& label,
                                        const std::vector<char>& usable, long max_texels);

// The split search's chosen state (`texel_sse`: its held-out squared error
// per texel, `heldout`: its held-out RMSE, both updated): its regions'
// holes, grouped by region; the group of the region with the most hole
// texels relabelled to that region, its cluster refitted
// (FitSplitModel: it may change model, gaining a lobe from the holes'
// highlights) and those that lost texels refitted from their fits (their
// models kept; a cluster left empty is removed), kept when the held-out
// error drops as a split's must (min_improvement and min_z, with and
// without the worst 2 % of texels). Returns the texels relabelled.
long AbsorbRegionHoles(Clustering& cl, std::vector<double>* texel_sse, double* heldout, SvbrdfEstimate* est,
                       const StageLog& log);

}  // namespace svbrdf
