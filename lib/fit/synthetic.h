// Synthetic BRDF samples of a known model, for the fit tests and benchmarks
// (ground truth for recovery checks without a renderer in the loop).
#pragma once
#include <cstdint>
#include <vector>

#include "brdf/model.h"
#include "gather/samples.h"

namespace svbrdf {

struct SynthOptions {
  int count = 20000;
  double noise = 0;             // relative Gaussian noise on y
  uint64_t seed = 7;
  double outlier_fraction = 0;  // samples replaced by gross errors (3y + 0.3)
};

// Samples of one texel of `spec` with parameters `params`: wi uniform on the
// hemisphere, wo half uniform and half near the mirror direction (so specular
// lobes are observed, as in a capture of a glossy surface), geom = cos(theta_i),
// y = f * geom computed from the float-rounded directions that are stored.
SampleSet SynthesizeSamples(const ModelSpec& spec, const std::vector<double>& params, const SynthOptions& options);

}  // namespace svbrdf
