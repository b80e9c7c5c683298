#include "cluster/quality.h"

#include <cmath>

namespace svbrdf {

std::vector<ClusterQuality> MeasureClusterQuality(const Clustering& cl, const WeightModel& weights) {
  std::vector<double> texel_sse;
  cl.HeldoutRmse(weights, &texel_sse);
  return ClusterQualityFromTexelSse(cl, texel_sse);
}

std::vector<ClusterQuality> ClusterQualityFromTexelSse(const Clustering& cl, const std::vector<double>& texel_sse) {
  const SampleSet& s = cl.samples();
  std::vector<ClusterQuality> q(cl.K());
  std::vector<double> sse(cl.K(), 0.0), signal(cl.K(), 0.0), n(cl.K(), 0.0);
  for (int t = 0; t < cl.num_texels(); ++t) {
    const int k = cl.assign()[t];
    if (!cl.usable()[t] || k < 0 || k >= cl.K()) continue;
    q[k].texels++;
    sse[k] += texel_sse[t];
    for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i)
      if (cl.holdout()[i]) signal[k] += Sq(s.y[0][i]) + Sq(s.y[1][i]) + Sq(s.y[2][i]), n[k] += 3;
  }
  for (int k = 0; k < cl.K(); ++k) {
    q[k].cluster = k;
    q[k].heldout_rmse = n[k] > 0 ? std::sqrt(sse[k] / n[k]) : 0.0;
    q[k].signal_rms = n[k] > 0 ? std::sqrt(signal[k] / n[k]) : 0.0;
    q[k].poorly_explained = q[k].heldout_rmse > cl.options().poor_fit * q[k].signal_rms;
  }
  return q;
}

}  // namespace svbrdf
