// Step 4b of EstimateSvbrdf (reconstruct.h): the basis materials refitted
// given the mixing weights, the alternation step that Lensch et al. 2001
// take and the clustering stops short of.
//
// Why: each cluster's material is fitted to its texels' samples as if every
// texel were made of it alone, but texels in a blend zone (a scan painted
// with soft borders: a large share of the Mitsuba bunny's sampled texels)
// mix in their neighbours' materials, and the fit absorbs them: the matte
// paint of the Mitsuba sphere came out off in colour while its coated
// plastic matched, and the reconstruction relit better with only the true
// paint swapped in (bench_results/independent.md).
#pragma once
#include <vector>

#include "cluster/clustering.h"

namespace svbrdf {

// Per material k: the training samples of the usable texels whose weight of
// k is at least `min_own_weight` in every channel, with the other
// materials' share subtracted and divided by the texel's weight of k,
//     y'_c = (y_c - sum_{j != k} w_tjc f_j,c) / w_tkc,
// refitted robustly (RobustFit) from k's current parameters. The weights are
// model m's from the training samples.
//
// Judged on interior texels (own and neighbours' weights of k all >= 0.99):
// material k's refit is kept when the held-out error of k's interior texels
// falls, and the round when that of all interior texels together falls.
// Not on all texels: the held-out samples are lookups of pixels that
// integrate the surface around the texel, so near a material border they
// carry some of the neighbour's colour, in the held-out samples as in the
// training ones, and reward a basis that absorbed it. On the Mitsuba bunny
// the plastic's refit raised the held-out error of the texels it dominates
// and lowered its interior texels'; with all three materials refitted the
// paint came closer to the truth and the held-out photos relit better,
// while the held-out samples' error over all texels rose
// (bench_results/independent.md).
//
// Rounds alternate: weights from the current basis, basis from those
// weights; they stop at the first round not kept (undone), at one that
// lowers the interior error by less than `min_round_gain`, or after
// `max_rounds`. Returns whether any round was kept (cl's basis set).
struct BasisRefitOptions {
  double min_own_weight = 0.5;
  double min_round_gain = 0.01;  // a smaller drop ends the rounds (kept)
  int max_rounds = 4;
};
bool RefitBasisOnWeights(Clustering& cl, const WeightModel& m, const BasisRefitOptions& ro, SvbrdfEstimate* est,
                         const StageLog& log);

}  // namespace svbrdf
