#include "cluster/adjacency.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace svbrdf {

namespace {

constexpr int kGrid8[8][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {1, -1}, {-1, 1}, {-1, -1}};

bool GridAdjacent(const Texel& a, const Texel& b) { return std::abs(a.x - b.x) <= 1 && std::abs(a.y - b.y) <= 1; }

}  // namespace

std::vector<std::vector<int>> SurfaceNeighbours(const Atlas& atlas, double reach) {
  const int nt = static_cast<int>(atlas.texels.size());
  std::vector<std::vector<int>> nb(nt);
  std::vector<double> spacing(nt, 0.0);
  std::vector<int> border;
  for (int t = 0; t < nt; ++t) {
    const Texel& tx = atlas.texels[t];
    double sum = 0;
    int n4 = 0;
    for (int d = 0; d < 8; ++d) {
      const int x = tx.x + kGrid8[d][0], y = tx.y + kGrid8[d][1];
      if (x < 0 || y < 0 || x >= atlas.width || y >= atlas.height) continue;
      const int u = atlas.At(x, y);
      if (u < 0) continue;
      nb[t].push_back(u);
      if (d < 4) sum += (atlas.texels[u].position - tx.position).norm(), ++n4;
    }
    spacing[t] = n4 ? sum / n4 : 0.0;
    if (nb[t].size() < 8) border.push_back(t);
  }
  // Texels with no grid 4-neighbour (single-texel charts) take the median spacing.
  std::vector<double> known;
  for (double s : spacing)
    if (s > 0) known.push_back(s);
  if (known.empty() || border.empty()) return nb;
  std::nth_element(known.begin(), known.begin() + known.size() / 2, known.end());
  const double median = known[known.size() / 2];
  double cell = 0;
  for (int t : border) {
    if (spacing[t] <= 0) spacing[t] = median;
    // Degenerate spacings (many texels at one pole) must not hide neighbours
    // one row further: at least a tenth of the typical spacing.
    spacing[t] = std::max(spacing[t], 0.1 * median);
    cell = std::max(cell, reach * spacing[t]);
  }
  // Hash grid over the border texels' positions, cells of the largest reach.
  auto key = [cell](const Vec3& p, int dx, int dy, int dz) {
    const int64_t x = int64_t(std::floor(p.x() / cell)) + dx, y = int64_t(std::floor(p.y() / cell)) + dy,
                  z = int64_t(std::floor(p.z() / cell)) + dz;
    return uint64_t(x * 73856093) ^ uint64_t(y * 19349663) ^ uint64_t(z * 83492791);
  };
  std::unordered_map<uint64_t, std::vector<int>> grid;
  for (int t : border) grid[key(atlas.texels[t].position, 0, 0, 0)].push_back(t);
  std::vector<std::vector<int>> extra(nt);
  for (int t : border) {
    const Texel& a = atlas.texels[t];
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = grid.find(key(a.position, dx, dy, dz));
          if (it == grid.end()) continue;
          for (int u : it->second) {
            if (u <= t) continue;  // each pair once
            const Texel& b = atlas.texels[u];
            if (GridAdjacent(a, b)) continue;
            const double r = reach * std::max(spacing[t], spacing[u]);
            if ((a.position - b.position).squaredNorm() > r * r || a.normal.dot(b.normal) <= 0.5) continue;
            extra[t].push_back(u);
            extra[u].push_back(t);
          }
        }
  }
  for (int t = 0; t < nt; ++t) {
    std::sort(extra[t].begin(), extra[t].end());
    extra[t].erase(std::unique(extra[t].begin(), extra[t].end()), extra[t].end());
    nb[t].insert(nb[t].end(), extra[t].begin(), extra[t].end());
  }
  return nb;
}

int CountSeamTexels(const Atlas& atlas, const std::vector<std::vector<int>>& neighbours) {
  int n = 0;
  for (size_t t = 0; t < neighbours.size() && t < atlas.texels.size(); ++t)
    for (int u : neighbours[t])
      if (!GridAdjacent(atlas.texels[t], atlas.texels[u])) {
        ++n;
        break;
      }
  return n;
}

}  // namespace svbrdf
