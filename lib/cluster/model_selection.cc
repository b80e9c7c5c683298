#include "cluster/model_selection.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <tuple>

#include "cluster/photo_folds.h"
#include "cluster/stats.h"
#include "core/error.h"
#include "core/parallel.h"
#include "core/rng.h"

namespace svbrdf {

namespace {

// Fewer held-out samples than this in a cluster (few photos: the held-out
// photos may not see it at all) and the model is chosen on photos taken
// from its training samples instead.
constexpr size_t kMinValidationSamples = 300;

// Screening fits: least squares on this many random training samples of the
// cluster, at most this many iterations per start. Models of <= 24
// parameters are determined well by 600 samples (1800 residuals); the ranking they give
// agrees with full fits except for near-ties, which the finalists settle.
constexpr int64_t kScreenSamples = 600;
constexpr int kScreenIterations = 12;
constexpr size_t kFinalists = 3;
// Photo folds of the finalists' cross-validation (5: each fit sees 80 % of
// the photos, as the clustering's own hold-out leaves).
constexpr int kPhotoFolds = 5;
// A quick selection's cost (screening, one full fit) as a share of a full
// one's, predicted before the first is measured (in waves of several
// clusters about half, measured on randomized captures).
constexpr double kQuickShare = 0.5;

}  // namespace

void ValidationFromTraining(const Clustering& cl, std::vector<int64_t>* train, std::vector<int64_t>* hold) {
  const SampleSet& s = cl.samples();
  std::map<int, size_t> per_image;
  for (int64_t i : *train) per_image[s.image[i]]++;
  if (per_image.size() < 2) return;
  std::vector<std::pair<double, int>> order;
  for (const auto& [im, n] : per_image) order.emplace_back(HashUniform(cl.options().seed, uint64_t(im), 0x5e1ec7), im);
  std::sort(order.begin(), order.end());
  std::set<int> held;
  size_t moved = 0;
  for (const auto& [h, im] : order) {
    if (held.size() + 1 >= per_image.size() || 4 * moved >= train->size()) break;
    held.insert(im);
    moved += per_image[im];
  }
  std::vector<int64_t> keep;
  for (int64_t i : *train) (held.count(s.image[i]) ? *hold : keep).push_back(i);
  *train = std::move(keep);
}

FitOptions ScreeningFitOptions(const ReconstructOptions& o, const std::string& context) {
  FitOptions fo = o.fit;
  fo.max_samples = std::min<int64_t>(fo.max_samples, kScreenSamples);
  fo.max_iterations = std::min(fo.max_iterations, kScreenIterations);
  fo.function_tolerance = std::max(fo.function_tolerance, 1e-5);
  fo.robust_scale = 0;
  fo.threads = 1;
  fo.context = context;
  return fo;
}

void ValidationSamples(const Clustering& cl, int k, std::vector<int64_t>* train, std::vector<int64_t>* hold) {
  *hold = cl.Ids(k, true);
  *train = cl.Ids(k, false);
  if (hold->size() < kMinValidationSamples) ValidationFromTraining(cl, train, hold);
}

namespace {

struct Tried {
  ModelSpec spec;
  FitResult fit;
  double rmse = 0;
  std::vector<double> errors;  // per validation sample (out of fold, for finalists)
  bool final = false;          // fully fitted (a finalist), not only screened
  std::string failed;          // why its fit failed (then it is out of the choice)
  std::vector<double> held_errors = {};  // finalists: per held-out sample, fit on the training samples
  double held_rmse = 0;
};

constexpr double kFailed = std::numeric_limits<double>::infinity();


// The candidates fitted fully: the kFinalists best screened ones, and the one
// with the fewest parameters among those screened within 10 % (+ `margin`)
// of the best, which the parsimony rule may prefer.
std::vector<size_t> Finalists(const std::vector<Tried>& tried, double margin) {
  std::vector<size_t> order(tried.size());
  for (size_t j = 0; j < order.size(); ++j) order[j] = j;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return tried[a].rmse < tried[b].rmse; });
  while (!order.empty() && !tried[order.back()].failed.empty()) order.pop_back();  // failed fits (rmse +inf) are out
  std::vector<size_t> out(order.begin(), order.begin() + std::min(kFinalists, order.size()));
  if (order.empty()) return out;
  size_t lean = order[0];
  for (size_t j : order)
    if (tried[j].rmse <= 1.1 * tried[order[0]].rmse + margin && tried[j].spec.NumParams() < tried[lean].spec.NumParams())
      lean = j;
  if (std::find(out.begin(), out.end(), lean) == out.end()) out.push_back(lean);
  return out;
}

// A quick selection's one finalist: the model ChooseModel takes on the
// screening fits' validation errors (failed screenings left out).
std::vector<size_t> ScreenedChoice(const std::vector<Tried>& tried, const ModelSpec& incumbent, double margin,
                                   double min_z) {
  std::vector<size_t> ok;
  std::vector<ModelCandidate> screened;
  for (size_t j = 0; j < tried.size(); ++j)
    if (tried[j].failed.empty()) {
      ok.push_back(j);
      screened.push_back({tried[j].spec, tried[j].fit.params, tried[j].rmse, tried[j].errors});
    }
  if (ok.empty()) return {};
  return {ok[ChooseModel(screened, incumbent, margin, min_z)]};
}

}  // namespace

std::string BoundParam(const ModelSpec& spec, const std::vector<double>& params, bool metallic_ends) {
  const std::vector<ParamInfo> info = spec.Params();
  for (size_t i = 0; i < info.size() && i < params.size(); ++i) {
    if (!metallic_ends && info[i].name == "metallic") continue;
    const double tol = 1e-3 * (info[i].upper - info[i].lower);
    if (params[i] >= info[i].upper - tol || (!info[i].linear && params[i] <= info[i].lower + tol))
      return Msg(info[i].name, " ", params[i]);
  }
  return "";
}

bool FitAtBound(const ModelSpec& spec, const std::vector<double>& params, bool metallic_ends) {
  return !BoundParam(spec, params, metallic_ends).empty();
}

std::vector<size_t> ReplacementFinalists(const std::vector<double>& screening_rmse, const std::vector<char>& fitted,
                                         const std::vector<char>& failed, size_t wanted) {
  size_t usable = 0;
  bool any_failed = false;
  for (size_t j = 0; j < fitted.size(); ++j)
    if (fitted[j]) failed[j] ? void(any_failed = true) : void(++usable);
  std::vector<size_t> out;
  if (!any_failed) return out;
  std::vector<size_t> order(screening_rmse.size());
  for (size_t j = 0; j < order.size(); ++j) order[j] = j;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return screening_rmse[a] < screening_rmse[b]; });
  for (size_t j : order) {
    if (usable + out.size() >= wanted) break;
    if (!fitted[j] && !failed[j]) out.push_back(j);
  }
  return out;
}

namespace {

// " at a bound (name value)" for the log, or nothing.
std::string AtBoundNote(const ModelSpec& spec, const std::vector<double>& params) {
  const std::string p = BoundParam(spec, params);
  return p.empty() ? "" : " at a bound (" + p + ")";
}

// ChooseModel's order of preference among candidates that are not clearly
// worse: not at a bound, fewer parameters, the incumbent, lower RMSE.
std::tuple<bool, int, bool, double> PreferenceKey(const ModelCandidate& c, const ModelSpec& incumbent) {
  return std::make_tuple(FitAtBound(c.spec, c.params), c.spec.NumParams(), !(c.spec == incumbent), c.rmse);
}

}  // namespace

size_t ChooseModel(const std::vector<ModelCandidate>& c, const ModelSpec& incumbent, double margin, double min_z) {
  if (c.empty()) throw Error("ChooseModel: no candidates");
  size_t best = 0;
  for (size_t j = 0; j < c.size(); ++j)
    if (c[j].rmse < c[best].rmse) best = j;
  // The same trimming as TrimmedRmse for the paired test: samples among the
  // worst 2 % under the best model (misassigned texels) are left out.
  const std::vector<double>& eb = c[best].errors;
  std::vector<char> keep(eb.size(), 1);
  if (!eb.empty()) {
    std::vector<double> sorted = eb;
    const size_t cut = sorted.size() - 1 - sorted.size() / 50;
    std::nth_element(sorted.begin(), sorted.begin() + cut, sorted.end());
    for (size_t i = 0; i < eb.size(); ++i) keep[i] = eb[i] <= sorted[cut];
  }
  auto trimmed = [&](const std::vector<double>& e) {
    std::vector<double> out;
    for (size_t i = 0; i < e.size() && i < keep.size(); ++i)
      if (keep[i]) out.push_back(e[i]);
    return out;
  };
  const std::vector<double> trimmed_best = trimmed(eb);
  auto key = [&](size_t j) { return PreferenceKey(c[j], incumbent); };
  size_t chosen = best;
  for (size_t j = 0; j < c.size(); ++j) {
    const bool clearly_worse = c[j].rmse - c[best].rmse > margin && PairedZ(trimmed(c[j].errors), trimmed_best) >= min_z;
    if (!clearly_worse && key(j) < key(chosen)) chosen = j;
  }
  return chosen;
}

size_t ChooseModelOnBoth(const std::vector<ModelCandidate>& folds, const std::vector<ModelCandidate>& held,
                         const ModelSpec& incumbent, double folds_margin, double min_z) {
  const size_t by_folds = ChooseModel(folds, incumbent, folds_margin, min_z);
  if (held.empty()) return by_folds;
  if (held.size() != folds.size()) throw Error("ChooseModelOnBoth: the two validations hold different candidates");
  // Between the models the folds' choice ties with (not clearly worse out
  // of fold, as preferred: not at a bound, as many parameters, as much the
  // incumbent), the sum of the two mean squared errors decides: the folds'
  // errors come from screening fits, the held-out ones from the full fits
  // that are kept. The held-out photos do not veto a model the folds found
  // clearly better: with few photos they may not see what tells the models
  // apart (the default preset at 8 photos: a Cook-Torrance clearly below
  // lambert out of fold ties with it on the held-out photos).
  auto preference = [&](size_t j) {
    auto k = PreferenceKey(folds[j], incumbent);
    std::get<3>(k) = 0;
    return k;
  };
  size_t chosen = by_folds;
  auto both = [&](size_t j) { return Sq(folds[j].rmse) + Sq(held[j].rmse); };
  for (size_t j = 0; j < folds.size(); ++j) {
    if (preference(j) != preference(by_folds)) continue;
    const bool clearly_worse = folds[j].rmse - folds[by_folds].rmse > folds_margin &&
                               PairedZ(folds[j].errors, folds[by_folds].errors) >= min_z;
    if (!clearly_worse && both(j) < both(chosen)) chosen = j;
  }
  return chosen;
}

namespace {

// One cluster's model choice in progress (SelectModels).
struct Selection {
  int k = 0;
  std::vector<int64_t> hold, train, all;
  DisplayScale display;
  double signal = 0, cv_signal = 0;
  std::vector<int> fold;
  std::vector<Tried> tried;
  std::vector<size_t> finalists;
};

}  // namespace

void SelectModels(Clustering& cl, SvbrdfEstimate* est_out, const StageLog& log, double first_cluster_seconds) {
  const ReconstructOptions& o = cl.options();
  const SampleSet& samples = cl.samples();
  SvbrdfEstimate& est = *est_out;
  // 3. Model economy per cluster.
  std::vector<std::string> candidates = o.force_model.empty() ? o.candidate_models : std::vector<std::string>{o.force_model};
  std::vector<int> order(cl.K()), texels(cl.K(), 0);
  for (int k = 0; k < cl.K(); ++k) order[k] = k;
  for (int a : cl.assign())
    if (a >= 0 && a < cl.K()) texels[a]++;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return texels[a] > texels[b]; });
  double longest = -1;  // the longest selection measured so far (per cluster)
  double longest_quick = -1;  // the same for quick selections (below)
  const size_t choices_before = est.model_choices.size();
  // Clusters are chosen independently (each reads only its own samples and
  // basis), so all of them are fitted together when the time allows: their
  // fits are one pool of independent tasks, which keeps both threads busy
  // where one cluster's three finalists would leave one idle. Under a time
  // budget that does not cover them all: quick selections (below).
  for (size_t next = 0; next < order.size();) {
    const double predicted = longest >= 0 ? longest : first_cluster_seconds;
    const size_t remaining = order.size() - next;
    // Quick selections when full ones do not fit: the screening alone ranks
    // the candidates, and only the one it chooses is fitted fully (no photo
    // folds, one start). The clustering's model, fitted for the split
    // search, relights a cluster it does not suit far worse than any
    // screened choice (a glossy coat kept as lafortune-1), so once one quick
    // selection fits, all the clusters get one, together: a wave of several
    // costs little more than one on two threads (its fits pack), and a
    // cluster left with its clustering model is a worse answer than a
    // result a fraction of a second late.
    const double predicted_quick = longest_quick >= 0 ? longest_quick : kQuickShare * predicted;
    const double left = o.SecondsLeft();
    const bool quick = !(left > predicted * double(remaining));
    const size_t wave = !quick || left > predicted_quick ? remaining : 0;
    if (wave == 0) {
      const int k = order[next++];
      est.cut_by_deadline.push_back(Msg("model selection of cluster ", k));
      log(Msg("time budget: cluster ", k, " keeps its clustering model ", cl.basis()[k].spec.Label(), " (", left,
              " s left, a quick selection takes about ", predicted_quick, " s)"));
      continue;
    }
    for (size_t w = 0; quick && w < wave; ++w)
      est.cut_by_deadline.push_back(Msg("model selection of cluster ", order[next + w], " (screening only)"));
    const auto wave_start = std::chrono::steady_clock::now();
    std::vector<Selection> sel(wave);
    for (size_t w = 0; w < wave; ++w) {
      Selection& c = sel[w];
      const int k = c.k = order[next + w];
      c.hold = cl.Ids(k, true), c.train = cl.Ids(k, false);
      c.all = c.train;
      c.all.insert(c.all.end(), c.hold.begin(), c.hold.end());
      if (candidates.size() > 1) ValidationSamples(cl, k, &c.train, &c.hold);
      const double clipped = ClippedShare(samples, c.all, o.display_scale);
      const bool linear = clipped > kMaxClippedShare;
      if (linear)
        log(Msg("cluster ", k, ": ", 100 * clipped, " % of its samples are white in the photos; model errors in linear units"));
      c.display = linear ? DisplayScale() : o.display_scale;
      c.signal = SignalRms(samples, c.hold, c.display);
      c.tried.resize(candidates.size());
    }
    next += wave;
    // Candidates are independent small fits: one per thread pays better than
    // threads inside each Ceres solve. Two rounds: every candidate is screened
    // by a least-squares fit on a small random subset (its held-out error
    // ranks it within a few percent); only the finalists get the full robust
    // fit, warm-started from their screening fit, and decide.
    ParallelFor(long(wave * candidates.size()), o.threads, [&](long task) {
      Selection& c = sel[size_t(task) / candidates.size()];
      const size_t j = size_t(task) % candidates.size();
      const int k = c.k;
      const ModelSpec spec = ModelSpec::FromLabel(candidates[j]);
      const FitOptions fo = ScreeningFitOptions(o, Msg("reconstruct: cluster ", k, " (model screening)"));
      // A candidate whose fit fails (Ceres: too many invalid steps, a
      // non-finite cost) is out of this cluster's choice, not the end of
      // the reconstruction: the other candidates can still explain it.
      try {
        const FitResult r = FitModel(spec, samples, c.train, fo,
                                     spec == cl.basis()[k].spec ? cl.basis()[k].params : std::vector<double>{});
        Tried& t = c.tried[j];
        t = Tried{};
        t.spec = spec;
        t.fit = r;
        t.errors = SampleErrors(spec, r.params, samples, c.hold, c.display);
        t.rmse = TrimmedRmse(t.errors);
      } catch (const Error& e) {
        Tried& t = c.tried[j];
        t = Tried{};
        t.spec = spec;
        t.rmse = kFailed;
        t.failed = e.what();
      }
    });
    // The finalists are compared on out-of-fold errors over all the
    // cluster's samples (photo folds, photo_folds.h): every photo is
    // validation once, so the choice does not hang on what the held-out
    // photos happened to see. The fold fits are screening fits (600
    // samples, warm-started from the finalist's fit): larger subsets give
    // the same choices at more CPU, and only near-ties move with the count.
    // Without the cross-validation the held-out photos alone choose worse
    // models with few photos (default preset at 8 photos, mixed_tiny).
    // The basis itself is the fit on the training samples.
    std::vector<std::pair<size_t, size_t>> final_tasks;  // (selection, finalist)
    for (size_t w = 0; w < wave; ++w) {
      Selection& c = sel[w];
      c.finalists = quick ? ScreenedChoice(c.tried, cl.basis()[c.k].spec, o.parsimony * c.signal, o.model_min_z)
                          : Finalists(c.tried, o.parsimony * c.signal);
      if (!quick) c.fold = PhotoFolds(samples, c.all, kPhotoFolds, o.seed);  // a quick selection has no folds
      c.cv_signal = SignalRms(samples, c.all, c.display);
      for (size_t f : c.finalists) final_tasks.emplace_back(w, f);
    }
    auto fit_finalist = [&](Selection& c, Tried& t) {
      const int k = c.k;
      const FitOptions cv = ScreeningFitOptions(o, Msg("reconstruct: cluster ", k, " (model cross-validation)"));
      // The cluster's own model was screened from its split-stage material
      // (fitted on every texel, sparse ones included): multi-start around
      // that screening fit (which is among the starts, so the training cost
      // can only improve). From the warm start alone a conductor (mixed_tiny's
      // copper) can stay in a local optimum with its F0 too low.
      // The other finalists were screened from the models' own starts.
      const bool warm = t.spec == cl.basis()[k].spec;
      try {
        t.fit = cl.FitIds(t.spec, c.train, t.fit.params, o.selection_samples, quick && wave == 1 ? -1 : 1, k, warm && !quick, !warm);
        double albedo = 0;
        if (ReflectsMoreThanItReceives(t.spec, t.fit.params, &albedo))
          throw Error(Msg("reflects more light than it receives (directional albedo up to ", albedo, ")"));
        t.held_errors = SampleErrors(t.spec, t.fit.params, samples, c.hold, c.display);
        t.held_rmse = TrimmedRmse(t.held_errors);
        t.errors = quick ? t.held_errors : OutOfFoldErrors(t.spec, samples, c.all, c.fold, cv, t.fit.params, c.display);
        t.rmse = quick ? t.held_rmse : TrimmedRmse(t.errors);
      } catch (const Error& e) {
        t.rmse = kFailed, t.errors.clear(), t.failed = e.what();
      }
      t.final = true;
    };
    // A finalist whose full fit fails (most often: it reflects more light
    // than it receives) leaves its place to the next screened candidate, so
    // that the choice is still made among several models (seen on a sphere
    // whose diffuse paint bordered a near-mirror gold: both Lafortune
    // finalists failed, and the Cook-Torrance left alone took the gold's
    // highlights as a lobe of its own).
    while (!final_tasks.empty()) {
      ParallelFor(long(final_tasks.size()), o.threads, [&](long task) {
        Selection& c = sel[final_tasks[task].first];
        fit_finalist(c, c.tried[final_tasks[task].second]);
      });
      final_tasks.clear();
      for (size_t w = 0; w < wave; ++w) {
        Selection& c = sel[w];
        std::vector<double> screening(c.tried.size());
        std::vector<char> fitted(c.tried.size()), failed(c.tried.size());
        for (size_t j = 0; j < c.tried.size(); ++j)
          screening[j] = c.tried[j].rmse, fitted[j] = c.tried[j].final, failed[j] = !c.tried[j].failed.empty();
        for (size_t j : ReplacementFinalists(screening, fitted, failed, quick ? 1 : kFinalists)) {
          c.finalists.push_back(j);
          final_tasks.emplace_back(w, j);
        }
      }
    }
    for (Selection& c : sel) {
      const int k = c.k;
      const std::vector<Tried>& tried = c.tried;
      for (const Tried& t : tried)
        if (!t.failed.empty()) log(Msg("cluster ", k, ": candidate ", t.spec.Label(), " left out: ", t.failed));
      std::vector<size_t> usable;
      for (size_t j : c.finalists)
        if (tried[j].failed.empty()) usable.push_back(j);
      if (usable.empty()) {  // every fit failed: the clustering's material stays
        log(Msg("cluster ", k, ": every candidate's fit failed; keeps its clustering model ", cl.basis()[k].spec.Label()));
        continue;
      }
      // The fewest parameters unless the best model is better by `parsimony`
      // of the signal's RMS (a difference that shows in a picture) and by
      // `model_min_z` standard errors (paired over held-out samples); fits at
      // their bounds only when clearly better (ChooseModel).
      // Ties out of fold are broken with the held-out photos too
      // (ChooseModelOnBoth): on the torus the folds narrowly preferred
      // coated-beckmann, the held-out photos clearly coated-ggx (the truth:
      // GGX).
      std::vector<ModelCandidate> fold_candidates, held_candidates;
      for (size_t j : usable) {
        fold_candidates.push_back({tried[j].spec, tried[j].fit.params, tried[j].rmse, tried[j].errors});
        if (c.hold.size() >= kMinValidationSamples)
          held_candidates.push_back({tried[j].spec, tried[j].fit.params, tried[j].held_rmse, tried[j].held_errors});
      }
      const int chosen = int(usable[ChooseModelOnBoth(fold_candidates, held_candidates, cl.basis()[k].spec,
                                                      o.parsimony * c.cv_signal, o.model_min_z)]);

      for (size_t j = 0; j < tried.size(); ++j)
        est.model_choices.push_back({k, tried[j].spec.Label(), tried[j].rmse, tried[j].spec.NumParams(),
                                     int(j) == chosen, tried[j].final});
      if (quick) {
        log(Msg("cluster ", k, ": model ", tried[chosen].spec.Label(), " (time budget: chosen by its screening fit; held-out RMSE ",
                tried[chosen].held_rmse, AtBoundNote(tried[chosen].spec, tried[chosen].fit.params), ")"));
      } else {
        std::string others;
        for (size_t j : usable)
          if (int(j) != chosen)
            others += Msg(", ", tried[j].spec.Label(), " ", tried[j].rmse, " / ", tried[j].held_rmse,
                          AtBoundNote(tried[j].spec, tried[j].fit.params));
        log(Msg("cluster ", k, ": model ", tried[chosen].spec.Label(), " (out-of-fold RMSE ", tried[chosen].rmse,
                ", held-out ", tried[chosen].held_rmse, AtBoundNote(tried[chosen].spec, tried[chosen].fit.params),
                "; finalists", others, ")"));
      }
      cl.SetBasis(k, MakeBasis(tried[chosen].spec, tried[chosen].fit, k));
    }
    const double per_cluster =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wave_start).count() / double(wave);
    double& measured = quick ? longest_quick : longest;
    measured = std::max(measured, per_cluster);
  }
  // Reported in cluster order, whatever order they were chosen in.
  std::stable_sort(est.model_choices.begin() + choices_before, est.model_choices.end(),
                   [](const auto& a, const auto& b) { return a.cluster < b.cluster; });
}

}  // namespace svbrdf
