#include "cluster/prune.h"

#include <algorithm>
#include <string>

#include "cluster/stats.h"
#include "core/error.h"

namespace svbrdf {

namespace {

struct Removal : MaterialRemoval {
  int k = -1;
  int texels = 0;  // of material k before its removal
};

// Share of cluster k's samples (all clusters when k < 0) that are held out.
double HeldOutShare(const Clustering& cl, int k) {
  const double held = double(cl.Ids(k, true).size()), train = double(cl.Ids(k, false).size());
  return held + train > 0 ? held / (held + train) : 0.0;
}

}  // namespace

MaterialRemoval ScoreRemoval(const Clustering& cl, int k, const WeightModel& m, const std::vector<double>& with_sse) {
  Clustering trial = cl;
  trial.RemoveBasis(k);
  trial.Assign();
  std::vector<double> without_sse;
  trial.HeldoutRmse(m, &without_sse);
  return {RemovalDrop(without_sse, with_sse), ImprovementZ(without_sse, with_sse), trial.assign()};
}

int PruneMaterials(Clustering& cl, const WeightModel& weight_model, SvbrdfEstimate* est, const StageLog& log) {
  const ReconstructOptions& o = cl.options();
  if (!o.prune_materials || o.force_clusters > 0) return 0;
  // Errors in the units held-out photos are scored in, as model selection's
  // (stats.h DisplayScale), unless too many samples are white there.
  WeightModel m = weight_model;
  // Scored with one weight per material even where the final weights are
  // per channel: per-channel weights recolour one diffuse material into any
  // other, so under them two diffuse materials of different colours always
  // explain each other. A material is a BRDF up to a brightness (as
  // Clustering::ScaledError treats it); another colour is another material.
  // Seen with fits on the regions' cores (Cluster.SoftBordersMixEveryMaterialAround):
  // the orange diffuse, a clean Lambert, was removed as the blue one recoloured.
  m.per_channel = false;
  const std::vector<int64_t> held = cl.Ids(-1, true);
  const bool display = !o.display_scale.empty() && ClippedShare(cl.samples(), held, o.display_scale) <= kMaxClippedShare;
  if (display) m.display = &o.display_scale;
  log(Msg("material pruning: held-out errors ", display ? "in display units" : "linear"));
  int removed = 0;
  // Anytime: past the deadline one round still runs (every material tested
  // once, the weakest that fails removed). It costs one held-out weight
  // solve per material, and a material the data do not support is a wrong
  // answer, not a rougher one: seen under a 10 s budget on a Mitsuba dragon
  // scan, the split search's fourth material (which pruning removes without
  // a budget) stayed in the result.
  for (int round = 0; cl.K() >= 2; ++round) {
    if (round > 0 && o.SecondsLeft() <= 0) {
      est->cut_by_deadline.push_back(Msg("material pruning (", round, " round", round > 1 ? "s" : "", ")"));
      break;
    }
    const double capture_share = HeldOutShare(cl, -1);
    std::vector<double> with_sse;
    cl.HeldoutRmse(m, &with_sse);
    Removal weakest;
    std::string lines;
    for (int k = 0; k < cl.K(); ++k) {
      // With far fewer held-out samples on its texels than the capture has
      // (photos that did not see its region) the test cannot see what a
      // material explains: it stays.
      const double share = HeldOutShare(cl, k);
      if (!(share >= 0.5 * capture_share)) {
        lines += Msg("; m", k, ": ", 100 * share, " % of its samples held out (capture ", 100 * capture_share,
                     " %), kept untested");
        continue;
      }
      // The clustering without material k: its texels join the remaining
      // material that explains them best. The remaining materials stay as
      // fitted: refitted on the removed cluster's texels, a blend zone would
      // pull their colours towards the blend, which the weights' prior on
      // their sum then cannot undo (the basis refit on the weights, step 4b,
      // follows).
      Removal r;
      static_cast<MaterialRemoval&>(r) = ScoreRemoval(cl, k, m, with_sse);
      r.k = k;
      r.texels = int(std::count(cl.assign().begin(), cl.assign().end(), k));
      lines += Msg("; m", k, " (", cl.basis()[k].spec.Label(), ", ", r.texels, " texels) ", 100 * r.drop,
                   " % lower with it, z = ", r.z);
      const bool earns = r.drop >= o.prune_min_drop && r.z >= o.min_z;
      if (!earns && (weakest.k < 0 || r.drop < weakest.drop)) weakest = std::move(r);
      if (round > 0 && o.SecondsLeft() <= 0) break;
    }
    log(Msg("material pruning, ", cl.K(), " materials (held-out error with each one against without it", lines, ")"));
    if (weakest.k < 0) break;
    const int k = weakest.k;
    log(Msg("removed m", k, " (", cl.basis()[k].spec.Label(), "): its texels are explained by the other materials ",
            "(", 100 * weakest.drop, " % lower with it, z = ", weakest.z, ")"));
    est->pruned.push_back({cl.basis()[k].spec.Label(), weakest.texels, weakest.drop, weakest.z});
    cl.RemoveBasis(k);
    cl.assign() = weakest.assign;
    auto& choices = est->model_choices;
    choices.erase(std::remove_if(choices.begin(), choices.end(), [k](const ModelChoice& c) { return c.cluster == k; }),
                  choices.end());
    for (ModelChoice& c : choices)
      if (c.cluster > k) --c.cluster;
    ++removed;
  }
  // The weight model stays (the choice among radii and priors is about the
  // capture's blends, not about the removed materials); its error now.
  if (removed > 0) {
    est->heldout_rmse = cl.HeldoutRmse(weight_model);
    (weight_model.per_channel ? est->heldout_rmse_channel : est->heldout_rmse_scalar) = est->heldout_rmse;
  }
  return removed;
}

}  // namespace svbrdf
