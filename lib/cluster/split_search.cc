#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <string>
#include <unordered_set>

#include "cluster/quality.h"
#include "cluster/region_holes.h"
#include "cluster/split.h"
#include "cluster/stats.h"
#include "core/error.h"
#include "core/parallel.h"

namespace svbrdf {

namespace {

// A refined control split whose partition matches the candidate's on this
// share of the texels found the same regions (see the control test below).
constexpr double kControlSamePartition = 0.95;
// A control split that halves the cluster's texels as the candidate does on
// this share of them (0.5: independent halves) is confounded with the
// candidate: where the materials themselves sit at different elevations
// (a metal on top, paint around), the geometric direction halves the
// materials too, and the unrefined control gains nearly all the candidate
// gains. Both are then refined before they are compared, as one split past
// the best (see the control test below).
constexpr double kControlConfounded = 0.7;
// A refined control split that keeps no more of its geometric halves than
// this share of its texels (0.5: as by chance, 1: all) has left its start
// (see the control test below).
constexpr double kControlKeptStart = 0.75;
// A split half switches model after refinement when another's validation
// error is below this share of its own (RechooseHalfModels).
constexpr double kModelSwitch = 0.7;

// Share of the texels where both +-1 splits are set on which they agree, up
// to swapping the halves (0.5 for independent splits, 1 for the same one).
double SideAgreement(const std::vector<int>& a, const std::vector<int>& b) {
  long same = 0, n = 0;
  for (size_t t = 0; t < a.size() && t < b.size(); ++t)
    if (a[t] != 0 && b[t] != 0) same += a[t] == b[t], ++n;
  return n > 0 ? double(std::max(same, n - same)) / n : 0.0;
}

// Moves the side < 0 texels of cluster k to a new cluster and fits both
// halves, each with the split model that suits it (FitSplitModel).
// `stop` (optional) set: returns after the first half, leaving the state
// unusable (a control that turned out not to be needed).
void SplitCluster(Clustering& cl, int k, const std::vector<int>& side, const std::atomic<bool>* stop = nullptr) {
  const int knew = cl.K();
  for (size_t t = 0; t < side.size(); ++t)
    if (side[t] < 0) cl.assign()[t] = knew;
    else if (side[t] == 0 && cl.assign()[t] == k) cl.assign()[t] = -1;  // re-assigned below
  const BasisMaterial parent = cl.basis()[k];
  cl.SetBasis(knew, FitSplitModel(cl, knew, &parent));
  if (stop && *stop) return;
  cl.SetBasis(k, FitSplitModel(cl, k, &parent));
  for (int& a : cl.assign()) if (a < 0) a = k;
}

// Refinement moves texels between the halves after their models were
// chosen (FitSplitModel, on the halves as split), so each half chooses its
// model again on its refined texels (screening fits; the full fit and
// another refinement only when another model is clearly better: below
// kModelSwitch of the current one's validation error, as near-ties between
// screening fits flip with a few texels). Seen on a Mitsuba bunny
// scan (glazed ceramic, copper ears, blue paint): a half of ceramic and
// copper took a conductor (the other models' screening fits failed on the
// mix), kept it for the ceramic once the refinement had moved the copper
// out, and the split lost for the ceramic's worse fit. `knew`: the new
// half's cluster as split (k the other).
void RechooseHalfModels(Clustering& cl, int k, int knew, int iterations, const std::atomic<bool>* stop) {
  if (knew != cl.K() - 1) return;  // the refinement removed a cluster
  bool changed = false;
  for (int c : {k, knew}) {
    if (stop && *stop) return;
    const BasisMaterial current = cl.basis()[c];
    // A fit that fails keeps the current material, as in Refine: the
    // re-choice may only improve on a split that already stands.
    try {
      const SplitModelChoice choice = ChooseSplitModel(cl, c, &current);
      if (choice.spec == current.spec || !(choice.mse < kModelSwitch * choice.parent_mse)) continue;
      cl.SetBasis(c, MakeBasis(choice.spec, cl.Fit(choice.spec, c, choice.start, 0, -1, false), c));
      changed = true;
    } catch (const Error& e) {
      std::fprintf(stderr, "  warning: %s; cluster %d keeps its model\n", e.what(), c);
    }
  }
  if (changed) Refine(cl, iterations, true, stop);
}

}  // namespace

double SplitSearchReserve(double elapsed_seconds) { return 0.35 * std::max(0.0, elapsed_seconds); }

void SearchClusters(Clustering& cl, SvbrdfEstimate* est_out, const StageLog& log, double first_step_seconds,
                    double seconds_before) {
  const ReconstructOptions& o = cl.options();
  const auto search_start = std::chrono::steady_clock::now();
  auto reserve = [&] {
    return SplitSearchReserve(seconds_before +
                              std::chrono::duration<double>(std::chrono::steady_clock::now() - search_start).count());
  };
  SvbrdfEstimate& est = *est_out;
  const double heldout = est.history.back().heldout_rmse;
  struct State {
    std::vector<BasisMaterial> basis;
    std::vector<int> assign;
    double heldout;
    std::vector<double> texel_sse;  // held-out squared error per texel
  };
  std::vector<double> texel_sse;
  cl.HeldoutRmse(false, &texel_sse);
  std::vector<State> states{{cl.basis(), cl.assign(), heldout, texel_sse}};
  size_t best_state = 0;
  // Every state is evaluated once: a split that leads back to a partition
  // already evaluated (two feature sets giving the same halves, a half emptied
  // by refinement) counts as a failed split without a second evaluation, and
  // a split proposal already tried from the same state is not fitted again.
  // Cycles between states (4 <-> 5 clusters) are impossible by construction.
  std::unordered_set<uint64_t> evaluated{est.history.back().partition}, proposed;
  auto restore = [&cl](const State& st) { cl.Restore(st.basis, st.assign); };
  const int target = o.force_clusters > 0 ? o.force_clusters : o.max_clusters;
  constexpr int kSplitVariants = 3;
  std::vector<int> variants_tried;  // per cluster, since the last accepted split
  double best = heldout;
  int fails = 0;
  bool lookahead = false;  // the current state is one unaccepted split past the best
  int root_cluster = 0;    // the cluster of the best state whose split is being looked past
  int lookaheads = 0;       // look-aheads from the best state (o.lookaheads_per_state)
  // Duration of the last split (Anytime: ReconstructOptions::deadline); the
  // caller's estimate before the first.
  double step_seconds = first_step_seconds;
  // Anytime: a split step whose time ran out midway (a slow first step, a
  // loaded machine) is undone at the next check instead of being finished
  // (the best state is restored below).
  auto out_of_time = [&] {
    if (o.SecondsLeft() > 0) return false;
    est.cut_by_deadline.push_back("split search");
    log("time budget: split step stopped midway (undone)");
    return true;
  };
  // Clusters of the best state a split has been tried on since it was kept
  // (o.split_poor_clusters), and the one to try next before stopping.
  std::vector<char> tried(cl.K(), 0);
  int poor_next = -1, announced = -1;
  auto untried_poor_cluster = [&] {
    if (!o.split_poor_clusters || o.force_clusters > 0) return -1;
    // (called with the best state restored)
    const State& st = states[best_state];
    variants_tried.resize(cl.K(), 0);
    const std::vector<ClusterQuality> q = ClusterQualityFromTexelSse(cl, st.texel_sse);
    int pick = -1;
    double worst_sse = -1;
    for (int j = 0; j < cl.K() && j < int(tried.size()); ++j) {
      if (tried[j] || variants_tried[j] >= kSplitVariants || !q[j].poorly_explained) continue;
      const double e = cl.ClusterSse(j);
      if (e > worst_sse) worst_sse = e, pick = j;
    }
    if (pick >= 0 && pick != announced)
      announced = pick, log(Msg("cluster ", pick, " is poorly explained (held-out RMSE ", q[pick].heldout_rmse, ", ",
              100 * q[pick].heldout_rmse / std::max(1e-300, q[pick].signal_rms),
              " % of its signal RMS) and not tried since the best state: split before stopping"));
    return pick;
  };
  // The search stops once `max_failed_splits` splits in a row failed and no
  // poorly explained cluster is left to try (else poor_next is the next).
  auto out_of_tries = [&] {
    return fails >= o.max_failed_splits && (poor_next = untried_poor_cluster()) < 0;
  };
  while (cl.K() < target) {
    if (const double left = o.SecondsLeft(), kept = reserve(); left < step_seconds + kept) {
      est.cut_by_deadline.push_back("split search");
      log(Msg("time budget: no time for another split (", left, " s left: a split takes about ", step_seconds,
              " s, ", kept, " s kept for model selection)"));
      break;
    }
    const auto step_start = std::chrono::steady_clock::now();
    variants_tried.resize(cl.K(), 0);
    int k = -1;
    double worst = -1;
    for (int j = 0; j < cl.K(); ++j) {
      const double e = cl.ClusterSse(j);
      if (variants_tried[j] < kSplitVariants && e > worst) worst = e, k = j;
    }
    if (poor_next >= 0 && !lookahead) k = poor_next;
    poor_next = -1;
    if (k < 0) break;
    const std::vector<int> side = SplitSides(cl, k, variants_tried[k]);
    const long plus = std::count(side.begin(), side.end(), 1), minus = std::count(side.begin(), side.end(), -1);
    // A basis material must own a meaningful part of the surface: smaller
    // groups are usually blends at region borders, which the mixing weights
    // already represent.
    const long usable_texels = std::count(cl.usable().begin(), cl.usable().end(), char(1));
    if (std::min(plus, minus) < std::max<long>(2, long(o.min_cluster_fraction * usable_texels))) {
      log(Msg("split of cluster ", k, " (features ", variants_tried[k], "): a half of ", std::min(plus, minus),
              " texels is too small"));
      variants_tried[k]++;
      if (!lookahead && out_of_tries()) break;
      continue;
    }
    if (!lookahead && k < int(tried.size())) tried[k] = 1;  // a split is made (a half too small is no try)
    auto undo = [&] {
      restore(states[best_state]);
      variants_tried.resize(cl.K(), 0);
      variants_tried[lookahead ? root_cluster : k]++;
      lookahead = false;
      ++fails;
      return out_of_tries();
    };
    std::vector<int> proposal(cl.assign());
    for (size_t t = 0; t < side.size(); ++t)
      if (side[t] < 0) proposal[t] = cl.K();
    if (!proposed.insert(PartitionKey(proposal) ^ (PartitionKey(cl.assign()) * 0x9e3779b97f4a7c15ull)).second) {
      ++est.states_revisited;
      log(Msg("split of cluster ", k, " (features ", variants_tried[k], ") already tried from this state: skipped"));
      if (undo()) break;
      continue;
    }
    const State parent{cl.basis(), cl.assign(), 0.0, {}};
    const std::vector<int> control_side = GeometrySplitSides(cl, k);
    const double confounding = SideAgreement(side, control_side);
    // The control: the same cluster halved along a direction that says
    // nothing about the material (GeometrySplitSides), scored before
    // refinement as the candidate is here. One split past the best
    // (lookahead), both are scored after refinement: there the parent mixes
    // materials, and the candidate's gain appears only when the refinement
    // reassigns its texels (scored before refinement, the mixed preset's
    // right split at standard size barely beat its unrefined control and
    // the search fell back to 1 cluster).
    std::vector<double> candidate_sse, control_sse;
    std::vector<int> control_assign, control_start;
    const bool honest_test = o.force_clusters == 0 && o.control_split;
    const bool confounded = confounding >= kControlConfounded;
    const bool refine_control = lookahead || confounded;
    // Set when the control turns out not to be needed (the candidate fails
    // its own test, or led back to an evaluated state): a control worked
    // out beside the candidate stops at its next step.
    std::atomic<bool> control_unneeded{false};
    // The refined candidate's held-out RMSE, its drop below the best so far
    // without the worst 2 % of texels, the paired z of that drop, and
    // whether both clear their thresholds (the candidate's own test).
    double h = 0, drop = 0, z = 0;
    bool own_test = false;
    auto work_candidate = [&] {
      SplitCluster(cl, k, side);
      if (o.SecondsLeft() <= 0) return (void)(control_unneeded = true);  // undone at the check below
      if (honest_test && !refine_control) cl.HeldoutRmse(false, &candidate_sse);
      const int knew = cl.K() - 1;
      Refine(cl, o.refine_iterations, true);
      RechooseHalfModels(cl, k, knew, o.refine_iterations, nullptr);
      h = cl.HeldoutRmse(false, &texel_sse);
      drop = TrimmedDrop(states[best_state].texel_sse, texel_sse);
      z = ImprovementZ(states[best_state].texel_sse, texel_sse);
      own_test = drop >= o.min_improvement && z >= o.min_z;
      if (evaluated.count(PartitionKey(cl.assign())) || !own_test) control_unneeded = true;
    };
    auto work_control = [&](Clustering& c, bool refine) {
      SplitCluster(c, k, control_side, &control_unneeded);
      if (control_unneeded) return;
      control_start = c.assign();
      if (refine) {
        const int knew = c.K() - 1;
        Refine(c, o.refine_iterations, false, &control_unneeded);
        RechooseHalfModels(c, k, knew, o.refine_iterations, &control_unneeded);
      }
      if (control_unneeded) return;
      control_assign = c.assign();
      c.HeldoutRmse(false, &control_sse);
    };
    // The control does not depend on the candidate: with two threads or
    // more both are worked out side by side from the parent state, the
    // control on a copy with half the threads (a fit's own threads idle
    // through Ceres' serial steps; the halves' fits in turn left the second
    // core half idle). With one thread the control waits for the candidate
    // to pass its own test (below).
    const int threads = ResolveThreads(o.threads);
    // Not one split past the best (lookahead): there the candidate fails
    // more often than not, and its control is refined as well, so the
    // control would mostly take cycles from the candidate for nothing.
    const bool control_aside = honest_test && threads >= 2 && !lookahead;
    if (control_aside) {
      Clustering copy(cl);
      copy.SetThreads(std::max(1, threads / 2));
      copy.SetCancel(&control_unneeded);
      // The candidate is needed, the control only if the candidate passes:
      // the control runs on what the candidate's threads leave idle.
      ParallelFor(2, 2, [&](long j) {
        if (j == 0) return work_candidate();
        LowerThisThreadsPriority();
        // A control that fails (a fit Ceres gives up on) must not end a
        // search that would not have needed it: it is worked out again in
        // turn below if it is needed, and fails there as it always did.
        try {
          work_control(copy, refine_control);
        } catch (const Error&) {
          control_unneeded = true;
        }
      });
    } else {
      work_candidate();
    }
    if (out_of_time()) break;
    const uint64_t key = PartitionKey(cl.assign());
    if (!evaluated.insert(key).second) {
      ++est.states_revisited;
      log(Msg("split of cluster ", k, " led back to an evaluated state (", cl.K(), " clusters): skipped"));
      if (undo()) break;
      continue;
    }
    step_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - step_start).count();
    const double total_drop = 1.0 - (h * h) / std::max(1e-300, best * best);
    bool passes = own_test;
    bool interleaved = false;  // fails the coherence test: no look-ahead past it
    bool blend = false;        // a half the other materials explain (below)
    std::string control_note;
    if (passes && o.force_clusters == 0 && o.min_split_coherence > 0) {
      // Materials form regions (SplitCoherence); halves interleaved texel by
      // texel are one material that both fits explain about equally.
      const double coherence = SplitCoherence(cl, side);
      if (coherence < o.min_split_coherence) {
        passes = false;
        interleaved = true;
        control_note = Msg("; halves interleaved (coherence ", coherence, "): not materials");
      } else {
        control_note = Msg("; coherence ", coherence);
      }
    }
    if (passes && honest_test) {
      // Honest stopping: when the residuals are dominated by model error
      // (no candidate describes the region), any split lets the halves'
      // fits specialise to the directions their texels saw, and lowers the
      // error; a split into materials must beat the control split clearly.
      const State candidate{cl.basis(), cl.assign(), h, texel_sse};
      if (!control_aside || control_unneeded) {  // (the second only if it failed aside)
        control_unneeded = false;
        restore(parent);
        work_control(cl, refine_control);
        restore(candidate);
        if (out_of_time()) break;
      }
      if (refine_control) candidate_sse = texel_sse;
      auto control_test = [&](bool refined, double* agreement, double* gain, double* zc) {
        *agreement = refined ? PartitionAgreement(candidate.assign, control_assign, cl.usable()) : 0.0;
        *gain = TrimmedDrop(control_sse, candidate_sse);
        *zc = ImprovementZ(control_sse, candidate_sse);
        return *agreement >= kControlSamePartition ||
               (*gain >= std::min(o.min_improvement, o.control_min_share * drop) && *zc >= o.min_z);
      };
      // A refined control that lands on the candidate's own partition found
      // the same regions from a start that says nothing about materials:
      // that is no evidence of model error. Seen on the Mitsuba bunny scan:
      // the look-ahead's three materials, far below their parent, failed
      // against a control refined into the same three, and the search kept
      // 1 material.
      double agreement = 0, gain = 0, zc = 0;
      passes = control_test(refine_control, &agreement, &gain, &zc);
      std::string unrefined_note;
      if (!passes && !refine_control && !out_of_time()) {
        // Scored before refinement, a rough first cut of the materials can
        // lose to the control (seen on a Mitsuba bunny scan with
        // interreflection: the material split 66 % below its parent after
        // refinement, yet 38 % worse than the unrefined control before it).
        // Both refined, as one split past the best: a control that model
        // error favours still wins then, or it finds the candidate's regions.
        unrefined_note = Msg(" (unrefined: ", 100 * gain, " % lower, z = ", zc, "; both refined)");
        control_unneeded = false;
        restore(parent);
        work_control(cl, true);
        restore(candidate);
        if (out_of_time()) break;
        candidate_sse = texel_sse;
        passes = control_test(true, &agreement, &gain, &zc);
      }
      const bool same = agreement >= kControlSamePartition;
      // A refined control that left its geometric halves (kept no more of
      // them than kControlKeptStart) is no longer a split along a direction
      // that says nothing about the material: its refinement found regions
      // of its own, which is no evidence of model error either. The
      // candidate then stands on its own test, and pruning removes what it
      // adds beyond the materials. Seen on a Mitsuba scene of five
      // materials: the look-ahead's split, far below its parent, lost to a
      // control whose refinement kept its halves no better than chance, and
      // the search kept 1 material; no refined control in the scenes
      // measured then kept its halves (docs/measurements.md, "Seeds 49-60").
      double kept_start = 1.0;
      if (refine_control || !unrefined_note.empty())
        kept_start = SplitKeptShare(parent.assign, k, control_start, control_assign, cl.usable());
      const bool left_start = !passes && !same && kept_start < kControlKeptStart;
      if (left_start) passes = true;
      control_note += Msg("; vs control split", confounded ? Msg(" (refined: it halves ", 100 * confounding,
                                                                 " % of texels as the candidate)") : std::string(),
                          unrefined_note, ": ", 100 * gain, " % lower, z = ", zc,
                          same ? Msg(" (refined into the same partition: ", 100 * agreement, " % of texels)")
                          : left_start ? Msg(" (refined, it kept ", 100 * kept_start,
                                             " % of its geometric halves: no longer a control)")
                                       : std::string(passes ? "" : ": model error, not materials"));
    }
    if (passes && o.force_clusters == 0 && o.prune_materials && cl.K() == int(parent.basis.size()) + 1) {
      // A part of a material or a blend, not a new one: a split can pass by
      // what one half gains (its refit, a model switch) while the other
      // half's texels are explained about as well by the remaining
      // materials (WeakerSplitHalf; PruneMaterials' test and bar, with the
      // search's weights). Such a state is kept (its fits were made on
      // cleaner texels, and later splits can build on it: on a Mitsuba
      // bunny a half that carved a blend zone out of a diffuse material left
      // that material's fit clean, and the result better after pruning;
      // docs/measurements.md), but counts as a failed split: the search
      // stops sooner instead of looking for splits past an extra material
      // that pruning then removes.
      const SplitHalfTest weak = WeakerSplitHalf(cl, k, cl.K() - 1, texel_sse);
      if (!(weak.drop >= o.prune_min_drop && weak.z >= o.min_z)) {
        blend = true;
        control_note += Msg("; half ", weak.half, " is explained by the other materials (", 100 * weak.drop,
                            " % lower with it, z = ", weak.z, "): kept as a failed split");
      }
    }
    est.history.push_back({cl.K(), cl.TrainRmse(), h, false, key});
    std::string sizes;
    for (int j = 0; j < cl.K(); ++j)
      sizes += Msg(j ? "/" : "", std::count(cl.assign().begin(), cl.assign().end(), j), " ", cl.basis()[j].spec.Label());
    log(Msg(cl.K(), " clusters (split of cluster ", k, ", features ", variants_tried[k], "; ", sizes, " texels): held-out RMSE ", h, " (", 100 * drop,
            " % below the best so far without the worst 2 % of texels, ", 100 * total_drop, " % with them; z = ", z, control_note, ")"));
    if (o.force_clusters > 0 || passes) {
      if (blend) ++est.blend_splits;
      log(blend ? Msg("kept: ", cl.K(), " clusters, but as a failed split (", fails + 1, " in a row)")
                : Msg("kept: ", cl.K(), " clusters (after ", fails, " failed splits in a row)"));
      states.push_back({cl.basis(), cl.assign(), h, texel_sse});
      best = h;
      best_state = states.size() - 1;
      lookahead = false;
      lookaheads = 0;
      std::fill(variants_tried.begin(), variants_tried.end(), 0);
      // A split kept as a failed one (a blend) leaves the clusters tried
      // as they were, its halves tried: the search is winding down, and
      // trying every poorly explained cluster of each such state again
      // chained split after split for the same result (seen on a Mitsuba
      // torus; docs/measurements.md).
      if (blend) {
        tried.resize(cl.K(), 1);
        tried[k] = 1;
        ++fails;
        if (out_of_tries()) break;
      } else {
        tried.assign(cl.K(), 0);
        announced = -1;
        fails = 0;
      }
    } else if (!lookahead && lookaheads < o.lookaheads_per_state && !interleaved && cl.K() < target) {
      // Look one split ahead before giving up: splitting 3 materials into 2
      // clusters can be worse than 1 cluster (a colour mixed into the wrong
      // basis), while the next split separates them.
      lookahead = true;
      ++lookaheads;
      root_cluster = k;
      variants_tried.assign(cl.K(), 0);
    } else {
      // Backtrack: undo the split(s) and try another feature set or the
      // next-worst cluster; stop after `max_failed_splits` failures in a row.
      if (undo()) break;
    }
  }
  // The last state that improved significantly on its predecessor (or the forced count).
  const size_t chosen = best_state;
  restore(states[chosen]);
  const uint64_t chosen_key = PartitionKey(cl.assign());
  for (auto& h : est.history) h.accepted = h.partition == chosen_key;
  est.holes_relabelled = AbsorbRegionHoles(cl, &states[chosen].texel_sse, &states[chosen].heldout, &est, log);
  log(Msg("chosen: ", cl.K(), " basis materials"));
}

}  // namespace svbrdf
