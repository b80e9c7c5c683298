// Texel adjacency on the surface: the 8-neighbours in the atlas grid, plus,
// for texels at a chart border (or a UV seam: the sphere's u = 0 / 1 column,
// its poles), the texels of other borders that lie next to them on the
// surface. Spatial priors (filling texels no photo saw, pooling sparse
// samples) then reach across seams instead of stopping at them.
#pragma once
#include <vector>

#include "atlas/atlas.h"

namespace svbrdf {

// Neighbour lists per texel (texel indices into atlas.texels), symmetric.
// Across borders, u is a neighbour of t when both are border texels (fewer
// than 8 grid neighbours), their surface points are closer than
// `reach` x the larger of their grid spacings (the mean 3D distance to
// their grid 4-neighbours) and their normals agree (cosine > 0.5: not the
// two sides of a thin part).
std::vector<std::vector<int>> SurfaceNeighbours(const Atlas& atlas, double reach = 1.5);

// How many texels have neighbours across a border (for reports and tests).
int CountSeamTexels(const Atlas& atlas, const std::vector<std::vector<int>>& neighbours);

}  // namespace svbrdf
