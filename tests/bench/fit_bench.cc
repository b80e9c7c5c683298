// FitModel on one cluster-sized sample set (40k samples x 3 channels), one
// thread: the per-cluster cost of the material fitting stage.
#include <benchmark/benchmark.h>

#include "fit/fit.h"
#include "fit/synthetic.h"

namespace svbrdf {
namespace {

constexpr int kSamples = 40000;

void BM_Fit(benchmark::State& state, const char* label, std::vector<double> truth) {
  const ModelSpec spec = ModelSpec::FromLabel(label);
  SynthOptions synth;
  synth.count = kSamples;
  synth.noise = 0.01;
  const SampleSet samples = SynthesizeSamples(spec, truth, synth);
  FitOptions options;
  options.threads = 1;
  FitResult result;
  for (auto _ : state) {
    result = FitModel(spec, samples, {}, options);
    benchmark::DoNotOptimize(result.params.data());
  }
  state.SetItemsProcessed(state.iterations() * kSamples);
  state.counters["iterations"] = result.iterations;
  state.counters["converged"] = result.converged;
}

BENCHMARK_CAPTURE(BM_Fit, lambert, "lambert", {0.6, 0.4, 0.2})->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Fit, lafortune_1, "lafortune-1", {0.3, 0.2, 0.1, 0.8, 0.7, 0.6, -0.9, 0.95, 25})
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Fit, lafortune_2, "lafortune-2",
                  {0.3, 0.2, 0.1, 0.5, 0.5, 0.4, -1, 1, 8, 2.0, 1.8, 1.5, -1, 1, 120})
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Fit, cook_torrance_beckmann, "cook_torrance-beckmann", {0.4, 0.3, 0.2, 0.5, 0.4, 0.3, 0.2, 1.6})
    ->Unit(benchmark::kMillisecond);
// The split models (every cluster of the split search fits them).
BENCHMARK_CAPTURE(BM_Fit, coated_ggx, "coated-ggx", {0.5, 0.1, 0.08, 0.15, 1.5})->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Fit, conductor_ggx_schlick, "conductor-ggx-schlick", {0.95, 0.64, 0.54, 0.2})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace svbrdf

BENCHMARK_MAIN();
