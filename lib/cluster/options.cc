#include "cluster/reconstruct.h"

#include <limits>

#include "core/error.h"

namespace svbrdf {

void ReconstructOptions::Check() const {
  fit.Check();
  if (max_clusters < 1 || max_clusters > 16) throw Error(Msg("reconstruct: --max-clusters must be in [1, 16], got ", max_clusters));
  if (force_clusters < 0 || force_clusters > 16) throw Error(Msg("reconstruct: --clusters must be in [0, 16], got ", force_clusters));
  if (!(holdout_fraction > 0 && holdout_fraction < 0.9)) throw Error("reconstruct: holdout fraction must be in (0, 0.9)");
  if (!(min_improvement >= 0)) throw Error("reconstruct: min improvement must be >= 0");
  if (!(prune_min_drop >= 0 && prune_min_drop < 1))
    throw Error(Msg("reconstruct: prune min drop must be in [0, 1), got ", prune_min_drop));
  if (!(control_min_share >= 0 && control_min_share <= 1))
    throw Error("reconstruct: control min share must be in [0, 1]");
  if (max_failed_splits < 1 || max_failed_splits > 20)
    throw Error(Msg("reconstruct: --max-failed-splits must be in [1, 20], got ", max_failed_splits));
  if (lookaheads_per_state < 0 || lookaheads_per_state > 20)
    throw Error(Msg("reconstruct: --lookaheads-per-state must be in [0, 20], got ", lookaheads_per_state));
  if (!(min_split_coherence >= 0 && min_split_coherence <= 1))
    throw Error(Msg("reconstruct: min split coherence must be in [0, 1], got ", min_split_coherence));
  if (!(poor_fit > 0)) throw Error("reconstruct: poor-fit share must be > 0");
  if (!(parsimony >= 0)) throw Error("reconstruct: parsimony must be >= 0");
  if (mix_radius < 1 || mix_radius > 8) throw Error(Msg("reconstruct: mix radius must be in [1, 8], got ", mix_radius));
  if (weight_radii.empty()) throw Error("reconstruct: no weight radii");
  for (int r : weight_radii)
    if (r < 1 || r > 64) throw Error(Msg("reconstruct: weight radius must be in [1, 64], got ", r));
  if (refine_iterations < 0) throw Error("reconstruct: refine iterations must be >= 0");
  if (core_fit_rings < 0 || core_fit_rings > 8)
    throw Error(Msg("reconstruct: core fit rings must be in [0, 8], got ", core_fit_rings));
  if (min_samples < 1) throw Error("reconstruct: min samples must be >= 1");
  if (min_fit_samples < 1) throw Error("reconstruct: min fit samples must be >= 1");
  if (candidate_models.empty() && force_model.empty()) throw Error("reconstruct: no candidate models");
  for (const auto& m : candidate_models) ModelSpec::FromLabel(m);  // throws for unknown labels
  if (!force_model.empty()) ModelSpec::FromLabel(force_model);
  ModelSpec::FromLabel(cluster_model);
  for (const auto& m : split_models) ModelSpec::FromLabel(m);
}

}  // namespace svbrdf

namespace svbrdf {

double ReconstructOptions::SecondsLeft() const {
  if (deadline == std::chrono::steady_clock::time_point::max()) return std::numeric_limits<double>::infinity();
  return std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
}

}  // namespace svbrdf
