// Non-linear least-squares fits of one reflectance model to a set of BRDF
// samples (Levenberg–Marquardt in Ceres, automatic differentiation through
// the templated models of lib/brdf, box bounds from ModelSpec::Params()).
// Ceres is used only inside this module.
#pragma once
#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "brdf/model.h"
#include "gather/samples.h"

namespace svbrdf {

struct FitOptions {
  int max_iterations = 60;
  // Relative cost change that ends a solve: 1e-6 of the cost is far below
  // the noise of any photo; a tighter tolerance only adds iterations.
  double function_tolerance = 1e-6;
  // Robust loss: 0 = plain squared error; > 0 = Cauchy loss with this scale
  // (in residual units) against outliers (misregistration, interreflection).
  double robust_scale = 0.0;
  // Brightness compression of the residuals: 0 = linear (r = f geom - y);
  // > 0 = each sample's residual is scaled by 1 / sqrt(1 + Y / (c Y_ref)),
  // Y its measured brightness (mean of the channels), Y_ref the median Y of
  // the fitted samples (or `compression_reference` when > 0). Linear
  // residuals let a few highlight samples, brighter by 100x than the rest,
  // outweigh everything else: the fit explains them and leaves the diffuse
  // and the lobes' flanks, which fill most of every photo, to chance. The
  // scaling weighs a sample's error about as a display (gamma) or photon
  // noise does.
  double compression = 0.0;
  double compression_reference = 0.0;
  // Fits use at most this many samples (a deterministic random subset) —
  // basis materials have few parameters, so more samples add time, not accuracy.
  // Fewer are used when a fit on 4000 already predicts the unseen rest of
  // the subset as well as its own samples (FitModel).
  int64_t max_samples = 10000;
  // Try several shape starts (exponents, roughness) and keep the best; off =
  // refine from the given start only (e.g. a robust refit of a fit).
  bool multi_start = true;
  int threads = 0;  // 0 = all cores
  uint64_t seed = 1;
  // Set (by another thread): the solves end at their next iteration with
  // what they have; for speculative fits whose result is no longer wanted.
  const std::atomic<bool>* cancel = nullptr;
  // Names the fit in errors (e.g. "cluster 2, split"): a fit given a
  // non-finite sample, or whose solve fails or ends at a non-finite cost,
  // throws Error with it instead of returning a meaningless material.
  std::string context = "fit";
  void Check() const;  // throws Error for out-of-range values
};

struct FitResult {
  std::vector<double> params;
  double cost = 0;          // final mean squared residual over the fitted samples (per channel)
  int iterations = 0;
  int64_t samples_used = 0;  // samples of the final solve (<= max_samples; chosen from the statistics)
  bool converged = false;   // Ceres reported CONVERGENCE
  std::string message;      // Ceres's termination message
};

// Fits `spec` to the samples whose indices are `ids` (all samples when empty).
// Starts from `initial` (spec.InitialParams() when empty), clamped into bounds.
// Several starts are tried for models with lobes (the fit is not convex);
// the best is returned.
FitResult FitModel(const ModelSpec& spec, const SampleSet& samples, const std::vector<int64_t>& ids,
                   const FitOptions& options, const std::vector<double>& initial = {});

// Per-channel squared residual of a model over samples, summed (for
// assignment and model selection). Returns the sum and writes the count.
double SumSquaredResidual(const ModelSpec& spec, const std::vector<double>& params, const SampleSet& samples,
                          const std::vector<int64_t>& ids, int64_t* count = nullptr);
// As above on `threads` threads (0 = all cores); the sum is bitwise the same
// for any thread count.
double SumSquaredResidual(const ModelSpec& spec, const std::vector<double>& params, const SampleSet& samples,
                          const std::vector<int64_t>& ids, int threads, int64_t* count);

// The residual weight of `options.compression` for a sample of brightness
// y_mean (1 without compression), and the reference brightness (median over
// `ids`) it is relative to.
double ResidualWeight(const FitOptions& options, double y_mean);
double MedianBrightness(const SampleSet& samples, const std::vector<int64_t>& ids);
// A sample's brightness Y: the mean of its measured channels.
inline double SampleBrightness(const SampleSet& samples, int64_t s) {
  return (double(samples.y[0][s]) + samples.y[1][s] + samples.y[2][s]) / 3.0;
}

// Model prediction for one sample (f * geom per channel).
Rgb PredictSample(const ModelSpec& spec, const double* params, const SampleSet& samples, int64_t s);
// PredictSample for n samples, bitwise the same, several times faster (the
// model is unpacked once per batch): sample ids[i], or first + i when ids is
// null, into out[i].
void PredictSamples(const ModelSpec& spec, const double* params, const SampleSet& samples, const int64_t* ids,
                    int64_t first, int64_t n, Rgb* out);

}  // namespace svbrdf
