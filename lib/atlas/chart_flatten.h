// Stage 3 of the chart atlas (atlas/charts.h), internal to lib/atlas: one
// chart flattened by least-squares conformal maps (CGAL), or rejected.
#pragma once
#include <array>
#include <vector>

#include "io/mesh.h"

namespace svbrdf {

// A flattened chart: its faces, one UV per face corner in surface units
// (area-preserving scale, principal axes along u), and its UV bounding box.
struct Chart {
  std::vector<int> faces;
  std::vector<std::array<Vec2, 3>> uv;  // per face corner, min corner of the box at (0, 0)
  double width = 0, height = 0;        // box in surface units
  double area = 0;                     // surface area
};

// Flattens the chart `faces` (vertex ids welded: `canon`) with LSCM; false
// when it is not a manifold disk, the solver fails, or a triangle flips or
// stretches beyond `max_stretch` (UV/surface area ratio against the
// chart's, either way). One face is always flattened (isometrically).
bool FlattenChart(const Mesh& mesh, const std::vector<int>& canon, const std::vector<int>& faces,
                  const std::vector<double>& area, double max_stretch, Chart* out);

}  // namespace svbrdf
