#include "fit/fit.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "core/error.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "fit/batch_cost.h"
#include "fit/starts.h"

namespace svbrdf {
namespace {

// Samples per residual block: large enough that Ceres' per-block overhead is
// negligible, small enough for ~600 blocks at 40k samples to spread over threads.
constexpr int kBatch = 64;
// Starts are compared on this many samples with few iterations; only the best
// is refined on all samples (the screening costs a fraction of one full fit).
constexpr int64_t kScreenSamples = 1000;
constexpr int kScreenIterations = 15;
// Samples of the first full solve; later stages grow 4x (see FitModel).
constexpr int64_t kStageSamples = 4000;

// The samples to fit in seeded-hash order: a deterministic random subset of at
// most max_samples that does not depend on the order of `ids`, and whose
// prefixes are random subsets too (used for screening starts).
std::vector<int64_t> SelectSamples(const SampleSet& samples, const std::vector<int64_t>& ids,
                                   const FitOptions& options) {
  const int64_t n = ids.empty() ? samples.size() : static_cast<int64_t>(ids.size());
  std::vector<std::pair<uint64_t, int64_t>> keyed(n);
  for (int64_t i = 0; i < n; ++i) {
    const int64_t s = ids.empty() ? i : ids[i];
    keyed[i] = {StreamSeed(options.seed, static_cast<uint64_t>(s)), s};
  }
  const int64_t m = std::min(n, options.max_samples);
  std::nth_element(keyed.begin(), keyed.begin() + m, keyed.end());
  keyed.resize(m);
  std::sort(keyed.begin(), keyed.end());
  std::vector<int64_t> out(m);
  for (int64_t i = 0; i < m; ++i) out[i] = keyed[i].second;
  return out;
}

struct Solution {
  std::vector<double> params;
  ceres::Solver::Summary summary;
  // Ceres did not fail and left finite parameters and cost.
  bool usable() const {
    return summary.termination_type != ceres::FAILURE && summary.termination_type != ceres::USER_FAILURE &&
           std::isfinite(summary.final_cost) &&
           std::all_of(params.begin(), params.end(), [](double v) { return std::isfinite(v); });
  }
};

// Ends a solve, as converged, once `cancel` is set (FitOptions::cancel).
class CancelCallback : public ceres::IterationCallback {
 public:
  explicit CancelCallback(const std::atomic<bool>* cancel) : cancel_(cancel) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return cancel_ && *cancel_ ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::atomic<bool>* cancel_;
};

// Levenberg–Marquardt on the first `count` packed samples from `start`.
Solution Solve(const ModelSpec& spec, const std::vector<ParamInfo>& info, const PackedSamples& packed,
               int64_t count, std::vector<double> start, const FitOptions& options, int max_iterations) {
  Solution solution{std::move(start), {}};
  double* p = solution.params.data();
  ceres::Problem problem;  // owns the cost functions
  // No ceres::LossFunction: it would act per block of kBatch samples; the
  // robust loss is applied per residual inside the cost function instead.
  for (int64_t b = 0; b < count; b += kBatch) {
    const int size = static_cast<int>(std::min<int64_t>(kBatch, count - b));
    problem.AddResidualBlock(MakeBatchCost(spec, packed, b, size, options.robust_scale), nullptr, p);
  }
  for (int i = 0; i < static_cast<int>(info.size()); ++i) {
    if (std::isfinite(info[i].lower)) problem.SetParameterLowerBound(p, i, info[i].lower);
    if (std::isfinite(info[i].upper)) problem.SetParameterUpperBound(p, i, info[i].upper);
  }
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;  // <= 24 parameters: J^T J is tiny
  so.max_num_iterations = max_iterations;
  // A trial step into a region where the model overflows (a Lafortune
  // exponent or a near-zero roughness) is an invalid step; Ceres then
  // shrinks the trust region and tries again, but by default fails the
  // whole solve after 5 in a row. From a start far from the data it can
  // take more shrinks to get back to finite costs (seen: a split's
  // lafortune-1 fit on the generalization bunny, --seed 3, which aborted
  // the reconstruction).
  so.max_num_consecutive_invalid_steps = 30;
  so.function_tolerance = options.function_tolerance;
  so.num_threads = ResolveThreads(options.threads);
  so.logging_type = ceres::SILENT;
  // With bounds, Ceres follows every trust-region step by a projected Armijo
  // line search; its default cubic interpolation evaluates the gradient (a
  // whole Jacobian) at the trial point, which the minimizer then evaluates
  // again. Quadratic interpolation needs the cost alone there (the line
  // search was a large share of all fit time); the trial point's second
  // evaluation is remembered (batch_cost.cc).
  // Capping the line search at one step would save a little more but moves
  // fits, and the forced 2-cluster e2e capture then relights worse
  // (bench_results/per_stage.md).
  so.line_search_interpolation_type = ceres::QUADRATIC;
  CancelCallback cancel(options.cancel);
  if (options.cancel) so.callbacks.push_back(&cancel);
  ceres::Solve(so, &problem, &solution.summary);
  return solution;
}

// Mean loss per residual over packed samples [begin, end) (the Cauchy loss
// when robust_scale > 0, as in the fit) and the standard error of that mean.
std::pair<double, double> MeanLoss(const ModelSpec& spec, const std::vector<double>& params,
                                   const PackedSamples& packed, int64_t begin, int64_t end, double robust_scale) {
  double sum = 0, sum2 = 0;
  for (int64_t i = begin; i < end; ++i) {
    const double* row = packed.row(i);
    Rgb f = Rgb::Zero();
    if (packed.HasFootprint()) {
      const double* q = packed.pairs_of(i);
      for (int j = 0; j < SampleSet::kFootprintSubsamples; ++j, q += PackedSamples::kPairStride)
        if (q[6] != 0) f += q[6] * EvalModelD(spec, params.data(), Vec3(q[0], q[1], q[2]), Vec3(q[3], q[4], q[5]));
    } else {
      f = EvalModelD(spec, params.data(), Vec3(row[0], row[1], row[2]), Vec3(row[3], row[4], row[5]));
    }
    for (int c = 0; c < 3; ++c) {
      const double r = f[c] * row[6] - row[7 + c];
      const double l = robust_scale > 0 ? robust_scale * robust_scale * std::log1p(r * r / (robust_scale * robust_scale))
                                        : r * r;
      sum += l;
      sum2 += l * l;
    }
  }
  const double count = 3.0 * std::max<int64_t>(1, end - begin), mean = sum / count;
  return {mean, std::sqrt(std::max(0.0, sum2 / count - mean * mean) / count)};
}

}  // namespace

double MedianBrightness(const SampleSet& samples, const std::vector<int64_t>& ids) {
  std::vector<double> y;
  const int64_t n = ids.empty() ? samples.size() : int64_t(ids.size());
  y.reserve(n);
  for (int64_t i = 0; i < n; ++i) {
    const int64_t s = ids.empty() ? i : ids[i];
    y.push_back(std::max(0.0, SampleBrightness(samples, s)));
  }
  if (y.empty()) return 0.0;
  std::nth_element(y.begin(), y.begin() + y.size() / 2, y.end());
  return y[y.size() / 2];
}

double ResidualWeight(const FitOptions& options, double y_mean) {
  if (!(options.compression > 0)) return 1.0;
  // A reference of 0 (mostly black samples) would weigh every lit sample
  // towards 0: the floor keeps the weights finite and ordered.
  const double ref = std::max(options.compression_reference, 1e-6);
  return 1.0 / std::sqrt(1.0 + std::max(0.0, y_mean) / (options.compression * ref));
}

void FitOptions::Check() const {
  auto fail = [](const char* name, auto value, const char* rule) {
    throw Error(Msg("FitOptions.", name, " = ", value, ": must be ", rule));
  };
  if (max_iterations < 1) fail("max_iterations", max_iterations, ">= 1");
  if (!(function_tolerance >= 0 && function_tolerance < 1)) fail("function_tolerance", function_tolerance, "in [0, 1)");
  if (!(robust_scale >= 0 && std::isfinite(robust_scale))) fail("robust_scale", robust_scale, "finite and >= 0");
  if (!(compression >= 0 && std::isfinite(compression))) fail("compression", compression, "finite and >= 0");
  if (!(compression_reference >= 0 && std::isfinite(compression_reference)))
    fail("compression_reference", compression_reference, "finite and >= 0");
  if (max_samples < 1) fail("max_samples", max_samples, ">= 1");
  if (threads < 0) fail("threads", threads, ">= 0 (0 = all cores)");
}

FitResult FitModel(const ModelSpec& spec, const SampleSet& samples, const std::vector<int64_t>& ids,
                   const FitOptions& options, const std::vector<double>& initial) {
  options.Check();
  const int num_params = spec.NumParams();
  if (!initial.empty() && static_cast<int>(initial.size()) != num_params)
    throw Error(Msg("FitModel: ", initial.size(), " initial parameters given for model ", spec.Label(),
                    ", which has ", num_params));
  const std::vector<ParamInfo> info = spec.Params();
  const std::vector<int64_t> selected = SelectSamples(samples, ids, options);
  std::function<double(double)> weight;  // none: linear residuals
  FitOptions weighted = options;
  if (options.compression > 0) {
    if (!(options.compression_reference > 0)) weighted.compression_reference = MedianBrightness(samples, selected);
    weight = [&weighted](double y_mean) { return ResidualWeight(weighted, y_mean); };
  }
  const PackedSamples packed = PackedSamples::FromIds(samples, selected, weight);
  const int64_t n = packed.size();
  // Gathering rejects non-finite pixels; this keeps any other source (a
  // caller's samples, a broken light) from reaching Ceres as NaN residuals.
  for (int64_t i = 0; i < n; ++i)
    for (int k = 0; k < PackedSamples::kStride; ++k)
      if (!std::isfinite(packed.row(i)[k]))
        throw Error(Msg(options.context, ": ", spec.Label(), " fit: sample ", selected[i],
                        " has a non-finite value (direction, geometry factor or measurement)"));
  const int64_t screen = std::min(n, kScreenSamples);

  std::vector<double> base = initial.empty() ? spec.InitialParams() : initial;
  ClampToBounds(spec, &base);
  FitResult result;
  result.params = base;
  if (n == 0) {
    result.message = "no samples to fit";
    return result;
  }
  // A caller's start is kept as given; the default one gets least-squares amplitudes.
  if (initial.empty()) FitAmplitudes(spec, packed, screen, &base);
  std::vector<std::vector<double>> starts =
      options.multi_start ? ShapeStarts(spec, base) : std::vector<std::vector<double>>{base};
  for (size_t k = 1; k < starts.size(); ++k) FitAmplitudes(spec, packed, screen, &starts[k]);
  // One start of the exact conductor's second index family (starts.h), at
  // the base start's roughness: one more screen, not one per roughness.
  if (options.multi_start) {
    std::vector<double> metal = MetalLikeStart(spec, starts[0]);
    if (!metal.empty()) starts.push_back(std::move(metal));
  }

  std::vector<double> best = starts[0];
  if (starts.size() > 1) {
    double best_cost = std::numeric_limits<double>::infinity();
    for (const auto& start : starts) {
      Solution s = Solve(spec, info, packed, screen, start, options, std::min(options.max_iterations, kScreenIterations));
      if (s.usable() && s.summary.final_cost < best_cost) {
        best_cost = s.summary.final_cost;
        best = std::move(s.params);
      }
    }
  }
  // Samples from the statistics: solve on a prefix (a random subset), then
  // check it on the next, unseen samples. When their mean loss is within 3
  // standard errors (or 1 %) of the fitted one, the fit generalises and more
  // samples would not change it; otherwise continue from it on 4x as many.
  int64_t m = std::min(n, kStageSamples);
  Solution final = Solve(spec, info, packed, m, best, options, options.max_iterations);
  while (m < n && final.usable()) {
    const int64_t next = std::min(n, 4 * m);
    const double fitted = MeanLoss(spec, final.params, packed, 0, m, options.robust_scale).first;
    const auto [unseen, se] = MeanLoss(spec, final.params, packed, m, next, options.robust_scale);
    if (unseen <= fitted + std::max(3.0 * se, 0.01 * fitted)) break;
    Solution more = Solve(spec, info, packed, next, final.params, options, options.max_iterations);
    if (!more.usable()) break;  // keep the last good stage
    m = next;
    final = std::move(more);
  }
  result.samples_used = m;
  const ceres::Solver::Summary& summary = final.summary;
  result.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  result.message = summary.message;
  if (!final.usable())
    throw Error(Msg(options.context, ": ", spec.Label(), " fit on ", n, " samples failed (",
                    ceres::TerminationTypeToString(summary.termination_type), ": ", summary.message, ")"));
  result.params = final.params;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.cost = SumSquaredResidual(spec, result.params, samples, selected, options.threads, nullptr) / (3.0 * n);
  if (!std::isfinite(result.cost))
    throw Error(Msg(options.context, ": ", spec.Label(), " fit on ", n, " samples ended at a non-finite cost"));
  return result;
}

}  // namespace svbrdf
