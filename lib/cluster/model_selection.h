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

// A fitted candidate model of one cluster, with its errors on the
// validation samples (per sample, summed over channels; the same samples
// for every candidate) and their trimmed RMSE.
struct ModelCandidate {
  ModelSpec spec;
  std::vector<double> params;
  double rmse = 0;
  std::vector<double> errors;
};

// Whether a fit leans on its model's bounds: a shape parameter within 0.1 %
// of its range from either bound (an ior at 3, a roughness at its minimum),
// or an amplitude at its upper bound. An amplitude at 0 is a term switched
// off, not a bound the data push against. `metallic_ends` false: a metallic
// of 0 or 1 (a dielectric, a metal) does not count either.
bool FitAtBound(const ModelSpec& spec, const std::vector<double>& params, bool metallic_ends = true);
// The first parameter FitAtBound finds at a bound, as "name value" for the
// log; empty when none is.
std::string BoundParam(const ModelSpec& spec, const std::vector<double>& params, bool metallic_ends = true);

// The choice among fully fitted candidates. A candidate is "clearly worse"
// than the one with the lowest RMSE when its RMSE is higher by `margin` and
// by `min_z` standard errors (paired over samples, the best's worst 2 %
// left out); among the others (ties within the noise of the held-out
// estimate) the choice prefers, in this order: a fit not at its bounds (a
// model that needs a bound to reach the data extrapolates where the data
// end: seen on the standard capture, a Cook-Torrance with ior pinned at 3
// tied with the clustering's Lafortune lobe and relit the worst held-out
// view far worse), fewer parameters, the `incumbent` model (the clustering's:
// its clusters were made with it), the lower RMSE.
size_t ChooseModel(const std::vector<ModelCandidate>& candidates, const ModelSpec& incumbent, double margin,
                   double min_z);

// The choice when the candidates are validated twice, on photo folds
// (`folds`) and on held-out photos (`held`, the same candidates in the same
// order; empty when there are too few held-out samples): ChooseModel on the
// folds, then among the candidates that tie with its choice (not clearly
// worse out of fold, and equal in ChooseModel's preferences: bounds,
// parameter count, incumbent) the lowest sum of the two mean squared errors.
size_t ChooseModelOnBoth(const std::vector<ModelCandidate>& folds, const std::vector<ModelCandidate>& held,
                         const ModelSpec& incumbent, double folds_margin, double min_z);

// When some fully fitted candidates (finalists) failed (a fit Ceres gave
// up on, one that reflects more light than it receives): the candidates to
// fit fully next, by screening error, neither fitted nor failed, until
// `wanted` finalists stand (counting the new ones); none when no finalist
// failed. Per candidate: its screening RMSE, whether it was fitted fully,
// and whether its screening or full fit failed.
std::vector<size_t> ReplacementFinalists(const std::vector<double>& screening_rmse, const std::vector<char>& fitted,
                                         const std::vector<char>& failed, size_t wanted);

// Anytime (ReconstructOptions::deadline): all clusters are selected fully
// when the time left covers that (`first_cluster_seconds` per cluster, a
// prediction, then the longest measured); otherwise quick selections of
// all clusters together (the screening fits choose, only the chosen model
// is fitted fully) when the time left covers one; otherwise the clusters
// keep the clustering's model. Both cuts are recorded in
// `est->cut_by_deadline` (quick ones as "screening only").
void SelectModels(Clustering& cl, SvbrdfEstimate* est, const StageLog& log, double first_cluster_seconds = 0);

}  // namespace svbrdf
