// Batched residual blocks for the Ceres fits. One block evaluates many
// samples, so Ceres' per-block overhead (jet set-up, bookkeeping, thread
// hand-off) is paid once per batch instead of once per sample, and the
// parameter count is a compile-time constant so jets live on the stack.
// Internal to lib/fit (and its tests); Ceres does not leak out of the module.
#pragma once
#include <ceres/cost_function.h>

#include <cstdint>
#include <functional>
#include <vector>

#include "brdf/model.h"
#include "gather/samples.h"

namespace svbrdf {

// Samples converted once to contiguous doubles, kStride values each:
// wi xyz, wo xyz, geom, y rgb. Converting up front keeps the inner loop free of
// index indirection and float->double conversions (done once, not per iteration).
struct PackedSamples {
  static constexpr int kStride = 10;
  std::vector<double> values;
  // With footprint sub-samples (SampleSet::footprint): per sample
  // kFootprintSubsamples x (wi xyz, wo xyz, weight x cos ratio) in the
  // frames of its footprint's normals, fixed by the geometry (computed once);
  // the sample's prediction is the weighted sum of f over them, times geom.
  static constexpr int kPairStride = 7;
  std::vector<double> pairs;
  bool HasFootprint() const { return !pairs.empty(); }
  const double* pairs_of(int64_t i) const {
    return pairs.data() + i * kPairStride * SampleSet::kFootprintSubsamples;
  }

  int64_t size() const { return static_cast<int64_t>(values.size()) / kStride; }
  const double* row(int64_t i) const { return values.data() + i * kStride; }
  // Packs samples `ids` of `set` in the given order.
  // `weight` (of the sample's SampleBrightness) scales its residual: it
  // multiplies the geometry factor and the measurement of the row.
  static PackedSamples FromIds(const SampleSet& set, const std::vector<int64_t>& ids,
                               const std::function<double(double)>& weight = nullptr);
};

// Cost function with 3*count residuals r = f_c(wi,wo)*geom - y_c for samples
// [begin, begin+count) of `packed`, one parameter block of spec.NumParams(),
// Jacobian by automatic differentiation through EvalModel. robust_scale > 0
// applies the Cauchy loss to each residual (r^2 becomes c^2 log(1 + r^2/c^2)).
// It keeps a pointer to `packed`, which must outlive it. The caller owns it.
ceres::CostFunction* MakeBatchCost(const ModelSpec& spec, const PackedSamples& packed, int64_t begin, int count,
                                   double robust_scale = 0);

// True when spec-sized parameter blocks of this count get a compile-time-sized
// cost function; other counts still work through DynamicAutoDiffCostFunction,
// only slower.
bool HasFixedSizeCost(int num_params);

}  // namespace svbrdf
