// Cross-validation over photos for the model choice of one cluster. With few
// photos, the held-out photos may miss what tells two models apart (seen on
// the default preset at 8 photos: the two held-out photos saw no highlight
// of the glossy red material, Lambert tied with Cook-Torrance and won by
// parsimony, and the relit views lost much of their accuracy; another
// hold-out seed kept Cook-Torrance). Every photo is validation once: each
// sample gets a prediction from a fit on the other photos only.
#pragma once
#include <cstdint>
#include <vector>

#include "cluster/clustering.h"
#include "cluster/stats.h"

namespace svbrdf {

// The photos of `ids` in `folds` groups (seeded order, about equal sample
// counts); fold index per sample of `ids`. Fewer photos than folds: one
// fold per photo.
std::vector<int> PhotoFolds(const SampleSet& s, const std::vector<int64_t>& ids, int folds, uint64_t seed);

// Out-of-fold squared errors (summed over channels) of `spec` on every
// sample of `ids`: per fold, a least-squares fit (`fo`, from `init`) to the
// samples of the other folds. A fold whose complement is empty keeps the
// in-sample error of a fit on all of `ids`. Errors on `display`'s scale
// when it is non-empty (SampleErrors).
std::vector<double> OutOfFoldErrors(const ModelSpec& spec, const SampleSet& s, const std::vector<int64_t>& ids,
                                    const std::vector<int>& fold, const FitOptions& fo,
                                    const std::vector<double>& init, const DisplayScale& display = {});

}  // namespace svbrdf
