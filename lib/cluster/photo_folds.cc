#include "cluster/photo_folds.h"

#include <algorithm>
#include <map>

#include "cluster/stats.h"
#include "core/rng.h"

namespace svbrdf {

std::vector<int> PhotoFolds(const SampleSet& s, const std::vector<int64_t>& ids, int folds, uint64_t seed) {
  std::map<int, size_t> per_image;
  for (int64_t i : ids) per_image[s.image[i]]++;
  std::vector<std::pair<double, int>> order;
  for (const auto& [im, n] : per_image) order.emplace_back(HashUniform(seed, uint64_t(im), 0xf01d), im);
  std::sort(order.begin(), order.end());
  const int F = std::max(1, std::min<int>(folds, int(order.size())));
  // Greedy: each photo (in the seeded order) to the fold with the fewest samples so far.
  std::vector<size_t> load(F, 0);
  std::map<int, int> fold_of;
  for (const auto& [h, im] : order) {
    const int f = int(std::min_element(load.begin(), load.end()) - load.begin());
    fold_of[im] = f;
    load[f] += per_image[im];
  }
  std::vector<int> out(ids.size());
  for (size_t j = 0; j < ids.size(); ++j) out[j] = fold_of[s.image[ids[j]]];
  return out;
}

std::vector<double> OutOfFoldErrors(const ModelSpec& spec, const SampleSet& s, const std::vector<int64_t>& ids,
                                    const std::vector<int>& fold, const FitOptions& fo,
                                    const std::vector<double>& init, const DisplayScale& display) {
  const int F = fold.empty() ? 0 : *std::max_element(fold.begin(), fold.end()) + 1;
  std::vector<double> err(ids.size(), 0.0);
  for (int f = 0; f < F; ++f) {
    std::vector<int64_t> train, test;
    std::vector<size_t> where;
    for (size_t j = 0; j < ids.size(); ++j) {
      if (fold[j] == f) test.push_back(ids[j]), where.push_back(j);
      else train.push_back(ids[j]);
    }
    if (test.empty()) continue;
    const FitResult r = FitModel(spec, s, train.empty() ? ids : train, fo, init);
    const std::vector<double> e = SampleErrors(spec, r.params, s, test, display);
    for (size_t j = 0; j < e.size(); ++j) err[where[j]] = e[j];
  }
  return err;
}

}  // namespace svbrdf
