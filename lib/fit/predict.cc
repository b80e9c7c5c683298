// Model predictions and residual sums in double, outside Ceres (model
// selection, cluster assignment, reported fit cost).
#include <algorithm>

#include "core/parallel.h"
#include "fit/fit.h"

namespace svbrdf {

Rgb PredictSample(const ModelSpec& spec, const double* params, const SampleSet& samples, int64_t s) {
  const Vec3 wi(samples.wi[0][s], samples.wi[1][s], samples.wi[2][s]);
  const Vec3 wo(samples.wo[0][s], samples.wo[1][s], samples.wo[2][s]);
  if (!samples.HasFootprint()) return EvalModelD(spec, params, wi, wo) * static_cast<double>(samples.geom[s]);
  // The lookup-weighted mean over its pixels' normals (SampleSet::footprint).
  Rgb sum = Rgb::Zero();
  const float* fp = &samples.footprint[size_t(s) * 3 * SampleSet::kFootprintSubsamples];
  for (int j = 0; j < SampleSet::kFootprintSubsamples; ++j, fp += 3) {
    if (!(fp[2] > 0)) continue;
    Vec3 wi_t, wo_t;
    double ratio;
    if (TiltedSampleDirections(wi, wo, double(fp[0]), double(fp[1]), &wi_t, &wo_t, &ratio))
      sum += (fp[2] * ratio) * EvalModelD(spec, params, wi_t, wo_t);
  }
  return sum * static_cast<double>(samples.geom[s]);
}

double SumSquaredResidual(const ModelSpec& spec, const std::vector<double>& params, const SampleSet& samples,
                          const std::vector<int64_t>& ids, int64_t* count) {
  return SumSquaredResidual(spec, params, samples, ids, 0, count);
}

double SumSquaredResidual(const ModelSpec& spec, const std::vector<double>& params, const SampleSet& samples,
                          const std::vector<int64_t>& ids, int threads, int64_t* count) {
  const int64_t n = ids.empty() ? samples.size() : static_cast<int64_t>(ids.size());
  if (count) *count = n;
  // Fixed chunks summed in chunk order: the result is bitwise independent of
  // the thread count and of scheduling.
  constexpr int64_t kChunk = 4096;
  const int64_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<double> partial(chunks, 0.0);
  ParallelFor(chunks, threads, [&](long k) {
    double sum = 0;
    for (int64_t i = k * kChunk, end = std::min(n, i + kChunk); i < end; ++i) {
      const int64_t s = ids.empty() ? i : ids[i];
      const Rgb predicted = PredictSample(spec, params.data(), samples, s);
      for (int c = 0; c < 3; ++c) {
        const double r = predicted[c] - samples.y[c][s];
        sum += r * r;
      }
    }
    partial[k] = sum;
  });
  double total = 0;
  for (const double p : partial) total += p;
  return total;
}

}  // namespace svbrdf
