#include "cluster/region_holes.h"

#include <algorithm>
#include <map>
#include <set>
#include <string>

#include "cluster/split.h"
#include "cluster/stats.h"
#include "core/error.h"

namespace svbrdf {

std::vector<RegionHole> FindRegionHoles(const std::vector<std::vector<int>>& neighbours, const std::vector<int>& label,
                                        const std::vector<char>& usable, long max_texels) {
  const int nt = int(label.size());
  int K = 0;
  for (int t = 0; t < nt; ++t)
    if (usable[t]) K = std::max(K, label[t] + 1);
  std::vector<RegionHole> holes;
  std::vector<int> group, stack;
  std::vector<char> seen(nt);
  for (int b = 0; b < K; ++b) {
    std::fill(seen.begin(), seen.end(), 0);
    for (int t0 = 0; t0 < nt; ++t0) {
      if (seen[t0] || !usable[t0] || label[t0] < 0 || label[t0] == b) continue;
      // The connected group of texels without label b around t0 (flood fill;
      // the whole group is marked even when it is too large to be a hole).
      group.clear();
      stack.assign(1, t0);
      seen[t0] = 1;
      bool touches = false;
      while (!stack.empty()) {
        const int t = stack.back();
        stack.pop_back();
        group.push_back(t);
        for (int u : neighbours[t]) {
          if (u >= nt || !usable[u] || label[u] < 0) continue;
          if (label[u] == b) touches = true;
          else if (!seen[u]) seen[u] = 1, stack.push_back(u);
        }
      }
      if (!touches || long(group.size()) > max_texels) continue;
      std::sort(group.begin(), group.end());
      holes.push_back({b, group});
    }
  }
  return holes;
}

long AbsorbRegionHoles(Clustering& cl, std::vector<double>* texel_sse, double* heldout, SvbrdfEstimate* est,
                       const StageLog& log) {
  const ReconstructOptions& o = cl.options();
  if (!o.absorb_region_holes || o.force_clusters > 0 || cl.K() < 2) return 0;
  const long usable = std::count(cl.usable().begin(), cl.usable().end(), char(1));
  // Smaller than a split may make a cluster (min_cluster_fraction): no
  // material of its own by the search's rule.
  const long max_texels = std::max<long>(1, long(o.min_cluster_fraction * usable));
  std::map<int, std::vector<int>> by_region;
  for (const RegionHole& h : FindRegionHoles(cl.neighbours(), cl.assign(), cl.usable(), max_texels)) {
    std::vector<int>& t = by_region[h.surround];
    t.insert(t.end(), h.texels.begin(), h.texels.end());
  }
  if (by_region.empty()) return 0;
  // One region is tried, the one with the most hole texels (the lowest label
  // on ties): each try costs a cluster fit per cluster it touches and a
  // held-out measure, and on the generalization benchmark's dev and extra
  // halves no second try was kept (docs/measurements.md).
  auto most = by_region.begin();
  for (auto it = by_region.begin(); it != by_region.end(); ++it)
    if (it->second.size() > most->second.size()) most = it;
  const int b = most->first;
  const std::vector<int>& texels = most->second;
  if (o.SecondsLeft() <= 0) {
    est->cut_by_deadline.push_back("region holes");
    return 0;
  }
  const std::vector<BasisMaterial> basis = cl.basis();
  const std::vector<int> assign = cl.assign();
  std::set<int> losers;
  for (int t : texels) losers.insert(assign[t]), cl.assign()[t] = b;
  cl.SetBasis(b, FitSplitModel(cl, b, &basis[b]));
  std::vector<int> emptied;
  for (int a : losers) {
    if (std::find(cl.assign().begin(), cl.assign().end(), a) == cl.assign().end()) emptied.push_back(a);
    else cl.SetBasis(a, MakeBasis(basis[a].spec, cl.Fit(basis[a].spec, a, basis[a].params, 0, -1, false), a));
  }
  for (auto it = emptied.rbegin(); it != emptied.rend(); ++it) cl.RemoveBasis(*it);
  std::vector<double> sse;
  const double h = cl.HeldoutRmse(false, &sse);
  // A clear gain, as a split must bring (min_improvement, min_z), with and
  // without the worst texels: in a noisy blend the specks are material, and
  // relabelling them trades small gains for losses.
  const double drop = TrimmedDrop(*texel_sse, sse), z = ImprovementZ(*texel_sse, sse);
  const bool keep = drop >= o.min_improvement && z >= o.min_z && h * h < (1 - o.min_improvement) * Sq(*heldout);
  std::string changes;
  for (int a : losers) changes += Msg(changes.empty() ? "" : ", ", a);
  log(Msg("holes in cluster ", b, "'s region (", texels.size(), " texels of clusters ", changes,
          emptied.empty() ? std::string() : Msg("; ", emptied.size(), " emptied"), "): held-out RMSE ", h,
          " against ", *heldout, " (", 100 * drop, " % lower without the worst 2 % of texels, z = ", z, "): ",
          keep ? "relabelled" : "kept apart"));
  if (!keep) {
    cl.Restore(basis, assign);
    return 0;
  }
  *texel_sse = std::move(sse);
  *heldout = h;
  return long(texels.size());
}

}  // namespace svbrdf
