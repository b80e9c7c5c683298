// Stages 1-2 of the chart atlas (atlas/charts.h), internal to lib/atlas:
// face adjacency, region growing by normal cone, absorption of small
// charts, and the cuts that split a chart which does not flatten.
#pragma once
#include <array>
#include <utility>
#include <vector>

#include "io/mesh.h"

namespace svbrdf {

// Per-face geometry used by the segmentation.
struct FaceGeometry {
  std::vector<Vec3> normal;  // unit (zero for degenerate faces)
  std::vector<double> area;
};
FaceGeometry ComputeFaceGeometry(const Mesh& mesh);

// Edge-adjacent faces (across edges shared by exactly two faces, -1
// otherwise), with vertices welded by position so that unwelded scans still
// connect; `canon` receives the welded id of every vertex.
std::vector<std::array<int, 3>> FaceNeighbours(const Mesh& mesh, std::vector<int>* canon);

// Region growing by normal cone; returns the faces of each chart.
std::vector<std::vector<int>> GrowCharts(const Mesh& mesh, const FaceGeometry& geo,
                                         const std::vector<std::array<int, 3>>& nb, double cos_cone);

// Charts of less than `min_area` surface join the neighbouring chart they
// share most edges with (ties: the lower chart), smallest first, when that
// chart's mean normal faces the same side (dot > 0). Growing leaves such
// crumbs between charts (faces whose neighbours all went to charts whose
// mean normal had turned too far) and as islands inside a chart, which
// make it an annulus instead of a disk. Empty charts are dropped.
std::vector<std::vector<int>> AbsorbSmallCharts(std::vector<std::vector<int>> charts, const FaceGeometry& geo,
                                                const std::vector<std::array<int, 3>>& nb, double min_area);

// Connected components of `faces` under the adjacency restricted to them
// (`mark`: per-face scratch, `stamp` and stamp + 1 are written).
std::vector<std::vector<int>> Components(const std::vector<int>& faces, const std::vector<std::array<int, 3>>& nb,
                                         std::vector<int>* mark, int stamp);

// Cuts faces in two at the median of their centroids along the longest extent.
std::pair<std::vector<int>, std::vector<int>> Bisect(const Mesh& mesh, const std::vector<int>& faces);

}  // namespace svbrdf
