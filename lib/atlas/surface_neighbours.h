// Texel neighbours on the surface rather than in the texture: a generated
// chart atlas cuts the surface into charts that lie apart in the texture, so
// texture neighbours never cross a chart seam (nor does a UV seam, such as
// the sphere's u = 0 / 1 column or its poles). Spatial priors (pooling
// sparse samples, mixing, filling texels no photo saw) reach across seams
// through SurfaceNeighbours; texels whose chart has no texel with a value
// (tiny charts: one sliver or folded triangle of a scan) take the texel
// nearest on the surface (NearestKnownTexels).
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

// Neighbour lists per texel (texel indices into atlas.texels), symmetric:
// the 8-neighbours in the atlas grid and, across borders, u is a neighbour
// of t when both are border texels (fewer than 8 grid neighbours), their
// surface points are closer than `reach` x the larger of their grid
// spacings (the mean 3D distance to their grid 4-neighbours) and their
// normals agree (cosine > 0.5: not the two sides of a thin part).
std::vector<std::vector<int>> SurfaceNeighbours(const Atlas& atlas, double reach = 1.5);

// How many texels have neighbours across a border (for reports and tests).
int CountSeamTexels(const Atlas& atlas, const std::vector<std::vector<int>>& neighbours);

}  // namespace svbrdf
