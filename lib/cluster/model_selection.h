// Step 3 of EstimateSvbrdf (reconstruct.h): the model of every basis
// material, chosen among the candidates by held-out error with a preference
// for fewer parameters.
#pragma once
#include "cluster/clustering.h"

namespace svbrdf {

// Fits every candidate to every cluster, sets the chosen models as the basis
// materials and records the choices in `est->model_choices`.
void SelectModels(Clustering& cl, SvbrdfEstimate* est, const StageLog& log);

}  // namespace svbrdf
