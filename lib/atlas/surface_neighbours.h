// Texel neighbours on the surface rather than in the texture: a generated
// chart atlas cuts the surface into charts that lie apart in the texture, so
// texture neighbours never cross a chart seam. Texels that must take their
// values from elsewhere (no samples of their own) and whose chart has no
// texel with a value (tiny charts: one sliver or folded triangle of a scan)
// look across the seams instead, at the texels nearest on the surface.
#pragma once
#include <limits>
#include <vector>

#include "atlas/atlas.h"

namespace svbrdf {

// Median surface distance between texture-adjacent texels of one triangle
// strip (the texel size in mesh units); 0 when no two texels are adjacent.
double MedianTexelSpacing(const Atlas& atlas);

// For every texel t with want[t] != 0: the texel u with known[u] != 0 whose
// surface point is nearest to t's (3D distance), preferring texels whose
// normal faces the same side (n_t . n_u > 0, so the two sides of a thin part
// never mix), at most `max_spacings` texel spacings (MedianTexelSpacing)
// away; -1 for other texels or when there is none. Deterministic (ties:
// lower index).
std::vector<int> NearestKnownTexels(const Atlas& atlas, const std::vector<char>& known, const std::vector<char>& want,
                                    double max_spacings = std::numeric_limits<double>::infinity());

}  // namespace svbrdf
