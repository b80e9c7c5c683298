// The interreflection removal's second pass (indirect/interreflection.h
// TraceIndirectWithMaterial) between the split search and the final fits:
// the indirect light traced again with the search's basis materials (mixed
// by the search's weights), and subtracted from the raw samples in place of the
// first pass's Lambertian estimate. The first pass's receivers are
// Lambertian; a glossy texel (a metal inside a torus' ring) reflects a
// blurred image of the object about its mirror direction, which the first
// pass leaves in its samples and which the fits then take for a material
// of its own or a different model.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "cluster/reconstruct.h"
#include "indirect/interreflection.h"

namespace svbrdf {

struct InterreflectionPass2Report {
  double changed_share = 0;  // sum |new - first pass| over the first pass's sum, all samples and channels
  double max_change = 0;     // the same within one cluster, the largest
  std::string Summary() const;
};

// `raw`: g->samples' values before the first pass (same samples, same
// order); `first`: the first pass's report (its texels that see the object);
// `search`: a SearchSvbrdf result on g's atlas. Sets g->samples' values.
InterreflectionPass2Report RemoveInterreflectionWithSearchMaterials(const Scene& scene,
                                                                    const std::array<std::vector<float>, 3>& raw,
                                                                    const InterreflectionOptions& io,
                                                                    const InterreflectionReport& first, GatherResult* g,
                                                                    const SvbrdfEstimate& search);

}  // namespace svbrdf
