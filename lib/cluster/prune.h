// Backward elimination of basis materials (step 4a of EstimateSvbrdf, after
// the weight model is chosen): every basis material must still earn its
// place once the final weights mix neighbouring materials.
//
// Why: the split search accepts a split by its own held-out measure (one
// weight pass, a fixed mixing radius), one split at a time. A blend zone
// between two materials, or a part of one material whose fit specialises to
// the directions its texels saw, can pass that test early and stay a basis
// material after the weights (wider radius, a prior on their sum) would
// represent it as a mixture of the others. On the generalization benchmark
// every wrong material count was one too many or more, with extra materials
// along region borders (bench_results/generalization.md).
//
// The test is the split search's run backwards: material k is removed (its
// texels go to the remaining material that explains them best, the others
// keep their fits) and kept only if the held-out error of the chosen weight
// model is lower with it by `prune_min_drop` (RemovalDrop) and by `min_z`
// standard errors (paired over texels), in display units as model selection
// measures (linear when too many samples are white there). The bar is above
// the split search's `min_improvement`: a split is judged before the final
// weights exist, a material after. The weakest material goes first; the test
// repeats while one fails. A material with far fewer held-out samples than
// the capture (its region unseen by the held-out photos) stays untested.
// Past ReconstructOptions::deadline one round still runs (the cut is
// recorded in est->cut_by_deadline when a second round would be needed).
#pragma once
#include "cluster/clustering.h"

namespace svbrdf {

// Material k removed from `cl` (its texels join the remaining material that
// explains them best, the others keep their fits): how much lower the
// held-out error under `m` is with it (RemovalDrop against `with_sse`, the
// per-texel held-out squared errors of `cl` under `m`), the paired z of that
// drop, and the labels without it. Pruning's test; the split search asks it
// of a split's halves (WeakerSplitHalf).
struct MaterialRemoval {
  double drop = 0, z = 0;
  std::vector<int> assign;
};
MaterialRemoval ScoreRemoval(const Clustering& cl, int k, const WeightModel& m, const std::vector<double>& with_sse);

// Returns how many materials were removed (est->model_choices renumbered,
// est->heldout_rmse measured again with `m`, which stays the weight model).
int PruneMaterials(Clustering& cl, const WeightModel& m, SvbrdfEstimate* est, const StageLog& log);

}  // namespace svbrdf
