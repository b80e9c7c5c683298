#include "cluster/split_region.h"

#include <algorithm>

namespace svbrdf {

std::vector<char> SplitRegion(const Clustering& cl, const std::vector<int>& before, int before_clusters,
                              const std::vector<int>& after, int radius) {
  const int nt = cl.num_texels();
  std::vector<char> split_cluster(std::max(0, before_clusters), 0), region(nt, 0);
  // Each new cluster descends from the old one that gave it most texels (the
  // refinement also hands it a few border texels of other clusters: those
  // count as moved texels, not as splits of their clusters).
  const int after_clusters = nt ? 1 + *std::max_element(after.begin(), after.end()) : 0;
  std::vector<std::vector<long>> given(std::max(0, after_clusters - before_clusters),
                                       std::vector<long>(std::max(0, before_clusters), 0));
  for (int t = 0; t < nt; ++t)
    if (after[t] >= before_clusters && before[t] >= 0 && before[t] < before_clusters)
      given[after[t] - before_clusters][before[t]]++;
  for (const std::vector<long>& g : given) {
    const auto most = std::max_element(g.begin(), g.end());
    if (most != g.end() && *most > 0) split_cluster[most - g.begin()] = 1;
  }
  for (int t = 0; t < nt; ++t) {
    const bool of_split = before[t] >= 0 && before[t] < before_clusters && split_cluster[before[t]];
    region[t] = of_split || after[t] != before[t];
  }
  // Widened by the mixing radius: the neighbours' weights mix the new materials.
  for (int step = 0; step < radius; ++step) {
    std::vector<char> next(region);
    for (int t = 0; t < nt; ++t)
      if (region[t])
        for (int u : cl.neighbours()[t]) next[u] = 1;
    region.swap(next);
  }
  return region;
}

double RegionDrop(const std::vector<double>& before, const std::vector<double>& after, const std::vector<char>& region) {
  double b_region = 0, b_all = 0, a_all = 0;
  for (size_t t = 0; t < before.size(); ++t) {
    b_all += before[t], a_all += after[t];
    if (t < region.size() && region[t]) b_region += before[t];
  }
  const double denominator = b_region > 0 ? b_region : b_all;
  return denominator > 0 ? (b_all - a_all) / denominator : 0.0;
}

double BoundedRegionDrop(const std::vector<double>& before, const std::vector<double>& after,
                         const std::vector<char>& region) {
  double sum = 0;
  long n = 0;
  const bool all = std::find(region.begin(), region.end(), char(1)) == region.end();
  for (size_t t = 0; t < before.size(); ++t)
    if ((all || (t < region.size() && region[t])) && before[t] + after[t] > 0)
      sum += (before[t] - after[t]) / (before[t] + after[t]), ++n;
  return n ? sum / n : 0.0;
}

}  // namespace svbrdf
