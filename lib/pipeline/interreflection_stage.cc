#include "pipeline/interreflection_stage.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace svbrdf {

std::string InterreflectionPass2Report::Summary() const {
  return Msg("interreflection, 2nd pass with the search's materials: samples changed by ", 100 * changed_share,
             " % of their signal (up to ", 100 * max_change, " % in one cluster)");
}

InterreflectionPass2Report RemoveInterreflectionWithSearchMaterials(const Scene& scene,
                                                                    const std::array<std::vector<float>, 3>& raw,
                                                                    const InterreflectionOptions& io,
                                                                    const InterreflectionReport& first, GatherResult* g,
                                                                    const SvbrdfEstimate& search) {
  SampleSet& s = g->samples;
  for (int c = 0; c < 3; ++c)
    if (int64_t(raw[c].size()) != s.size()) throw Error("internal: interreflection 2nd pass: raw samples do not match");
  const int K = int(search.search.basis.size());
  if (K == 0 || search.search.assign.size() != g->atlas.texels.size())
    throw Error("internal: interreflection 2nd pass: no split search result on this atlas");
  // The search's materials mixed by its weights (a texel in a soft blend
  // of a metal receives as the blend does, not as the metal).
  if (search.search.weights.size() != g->atlas.texels.size() * size_t(K) * 3)
    throw Error("internal: interreflection 2nd pass: the split search's weights do not match");
  const Material m = MixedMaterial(search.search.basis, search.search.weights, g->atlas, g->mesh);
  const std::vector<Rgb> indirect = TraceIndirectWithMaterial(scene, *g, m, io, &first.sees_object);
  InterreflectionPass2Report rep;
  std::vector<double> change(K, 0.0), signal(K, 0.0);
  for (int64_t i = 0; i < s.size(); ++i) {
    const int k = std::clamp(search.search.assign[s.texel[i]], 0, K - 1);
    for (int c = 0; c < 3; ++c) {
      const float v = float(std::max(0.0, double(raw[c][i]) - indirect[i][c]));
      change[k] += std::abs(v - s.y[c][i]);
      signal[k] += s.y[c][i];
      s.y[c][i] = v;
    }
  }
  double all_change = 0, all_signal = 0;
  for (int k = 0; k < K; ++k) {
    all_change += change[k], all_signal += signal[k];
    if (signal[k] > 0) rep.max_change = std::max(rep.max_change, change[k] / signal[k]);
  }
  rep.changed_share = all_signal > 0 ? all_change / all_signal : 0.0;
  return rep;
}

}  // namespace svbrdf
