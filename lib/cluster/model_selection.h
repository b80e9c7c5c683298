// Step 3 of EstimateSvbrdf (reconstruct.h): the model of every basis
// material, chosen among the candidates by held-out error with a preference
// for fewer parameters.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "cluster/clustering.h"

namespace svbrdf {

// Fits every candidate to every cluster, sets the chosen models as the basis
// materials and records the choices in `est->model_choices`.
// Training and validation samples of cluster k for choosing its model: the
// clustering's held-out samples; with too few of them (few photos: the
// held-out photos may not see the cluster) whole training photos (in a
// seeded order, about a quarter of the cluster's samples) are moved to
// validation instead.
void ValidationSamples(const Clustering& cl, int k, std::vector<int64_t>* train, std::vector<int64_t>* hold);
// Options of a screening fit (a quick least-squares fit on a small random
// subset, one thread): ranks models by held-out error within a few percent.
FitOptions ScreeningFitOptions(const ReconstructOptions& o, const std::string& context);
// The fallback above: moves whole training photos from `train` to `hold`.
void ValidationFromTraining(const Clustering& cl, std::vector<int64_t>* train, std::vector<int64_t>* hold);

void SelectModels(Clustering& cl, SvbrdfEstimate* est, const StageLog& log);

}  // namespace svbrdf
