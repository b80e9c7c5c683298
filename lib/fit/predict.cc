// Model predictions and residual sums in double, outside Ceres (model
// selection, cluster assignment, reported fit cost).
#include <algorithm>

#include "brdf/model_eval.h"
#include "core/parallel.h"
#include "fit/fit.h"

namespace svbrdf {

Rgb PredictSample(const ModelSpec& spec, const double* params, const SampleSet& samples, int64_t s) {
  const Vec3 wi(samples.wi[0][s], samples.wi[1][s], samples.wi[2][s]);
  const Vec3 wo(samples.wo[0][s], samples.wo[1][s], samples.wo[2][s]);
  if (!samples.HasFootprint()) return EvalModelD(spec, params, wi, wo) * static_cast<double>(samples.geom[s]);
  // The weighted mean over its footprint's normals (SampleSet::footprint).
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

void PredictSamples(const ModelSpec& spec, const double* params, const SampleSet& samples, const int64_t* ids,
                    int64_t first, int64_t n, Rgb* out) {
  // Batches of direction pairs, each sample's footprint pairs in order, so
  // that the sums below add the same terms in the same order as
  // PredictSample (the results are bitwise the same).
  constexpr int kBatch = 256;
  constexpr int kSub = SampleSet::kFootprintSubsamples;
  const bool footprint = samples.HasFootprint();
  std::vector<Vec3> wi(kBatch * kSub), wo(kBatch * kSub);
  std::vector<double> weight(kBatch * kSub), f(3 * kBatch * kSub);
  std::vector<int> pairs_of(kBatch);
  for (int64_t b0 = 0; b0 < n; b0 += kBatch) {
    const int m = int(std::min<int64_t>(kBatch, n - b0));
    int pairs = 0;
    for (int j = 0; j < m; ++j) {
      const int64_t s = ids ? ids[b0 + j] : first + b0 + j;
      const Vec3 i(samples.wi[0][s], samples.wi[1][s], samples.wi[2][s]);
      const Vec3 o(samples.wo[0][s], samples.wo[1][s], samples.wo[2][s]);
      const int start = pairs;
      if (!footprint) {
        wi[pairs] = i, wo[pairs] = o, weight[pairs] = 1.0, ++pairs;
      } else {
        const float* fp = &samples.footprint[size_t(s) * 3 * kSub];
        for (int k = 0; k < kSub; ++k, fp += 3) {
          double ratio;
          if (fp[2] > 0 && TiltedSampleDirections(i, o, double(fp[0]), double(fp[1]), &wi[pairs], &wo[pairs], &ratio))
            weight[pairs] = fp[2] * ratio, ++pairs;
        }
      }
      pairs_of[j] = pairs - start;
    }
    EvalModelBatch<double>(spec, params, pairs, [&](int k, Vec3* a, Vec3* b) { *a = wi[k], *b = wo[k]; }, f.data());
    int k = 0;
    for (int j = 0; j < m; ++j) {
      const int64_t s = ids ? ids[b0 + j] : first + b0 + j;
      Rgb v;
      if (!footprint) {
        v = Rgb(f[3 * k], f[3 * k + 1], f[3 * k + 2]), ++k;
      } else {
        v = Rgb::Zero();
        for (int e = 0; e < pairs_of[j]; ++e, ++k) v += weight[k] * Rgb(f[3 * k], f[3 * k + 1], f[3 * k + 2]);
      }
      out[b0 + j] = v * static_cast<double>(samples.geom[s]);
    }
  }
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
    const int64_t begin = k * kChunk, m = std::min(n - begin, kChunk);
    std::vector<Rgb> predicted(m);
    PredictSamples(spec, params.data(), samples, ids.empty() ? nullptr : ids.data() + begin, begin, m, predicted.data());
    for (int64_t i = begin; i < begin + m; ++i) {
      const int64_t s = ids.empty() ? i : ids[i];
      for (int c = 0; c < 3; ++c) {
        const double r = predicted[i - begin][c] - samples.y[c][s];
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
