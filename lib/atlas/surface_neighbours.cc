#include "atlas/surface_neighbours.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "core/parallel.h"

namespace svbrdf {

double MedianTexelSpacing(const Atlas& atlas) {
  std::vector<double> d;
  for (const Texel& t : atlas.texels) {
    if (!t.interior || t.x + 1 >= atlas.width) continue;
    const int u = atlas.At(t.x + 1, t.y);
    if (u >= 0 && atlas.texels[u].interior) d.push_back((atlas.texels[u].position - t.position).norm());
  }
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

namespace {

// A subset of the texels (`member`) bucketed in a uniform 3D grid of
// `cell`-sized cells.
class TexelGrid {
 public:
  TexelGrid(const Atlas& atlas, const std::vector<char>& member, double cell) : atlas_(atlas), cell_(cell) {
    for (int u = 0; u < int(atlas.texels.size()); ++u)
      if (member[u]) cells_[Key(Cell(atlas.texels[u].position))].push_back(u);
  }
  // Calls visit(u) for every member in the (2 rings + 1)^3 cells around p's
  // cell (and, rarely, in cells 2^21 cells away that share their keys).
  template <class Visit>
  void ForEachNear(const Vec3& p, int rings, const Visit& visit) const {
    const Eigen::Vector3i c = Cell(p);
    for (int dz = -rings; dz <= rings; ++dz)
      for (int dy = -rings; dy <= rings; ++dy)
        for (int dx = -rings; dx <= rings; ++dx) {
          const auto it = cells_.find(Key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == cells_.end()) continue;
          for (int u : it->second) visit(u);
        }
  }
  // Nearest member within `rings` cells of p's cell (-1: none there).
  int Nearest(const Vec3& p, const Vec3& n, int rings, bool same_side) const {
    int best = -1;
    double best_d2 = 1e300;
    ForEachNear(p, rings, [&](int u) {
      const Texel& tu = atlas_.texels[u];
      if (same_side && !(tu.normal.dot(n) > 0)) return;
      const double d2 = (tu.position - p).squaredNorm();
      if (d2 < best_d2 || (d2 == best_d2 && u < best)) best_d2 = d2, best = u;
    });
    return best;
  }

 private:
  Eigen::Vector3i Cell(const Vec3& p) const {
    return Eigen::Vector3i(int(std::floor(p.x() / cell_)), int(std::floor(p.y() / cell_)), int(std::floor(p.z() / cell_)));
  }
  static uint64_t Key(const Eigen::Vector3i& c) {
    return (uint64_t(uint32_t(c.x()) & 0x1fffff) << 42) | (uint64_t(uint32_t(c.y()) & 0x1fffff) << 21) |
           uint64_t(uint32_t(c.z()) & 0x1fffff);
  }
  const Atlas& atlas_;
  double cell_;
  std::unordered_map<uint64_t, std::vector<int>> cells_;
};

constexpr int kGrid8[8][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {1, -1}, {-1, 1}, {-1, -1}};

bool GridAdjacent(const Texel& a, const Texel& b) { return std::abs(a.x - b.x) <= 1 && std::abs(a.y - b.y) <= 1; }

}  // namespace

std::vector<int> NearestKnownTexels(const Atlas& atlas, const std::vector<char>& known, const std::vector<char>& want,
                                    double max_spacings) {
  const int nt = int(atlas.texels.size());
  std::vector<int> out(nt, -1);
  std::vector<int> known_ids;
  for (int u = 0; u < nt; ++u)
    if (known[u]) known_ids.push_back(u);
  if (known_ids.empty() || !(max_spacings >= 0)) return out;
  double spacing = MedianTexelSpacing(atlas);
  if (!(spacing > 0)) {
    Vec3 lo = atlas.texels[known_ids[0]].position, hi = lo;
    for (int u : known_ids) lo = lo.cwiseMin(atlas.texels[u].position), hi = hi.cwiseMax(atlas.texels[u].position);
    spacing = std::max(1e-9, (hi - lo).maxCoeff() / 64);
  }
  // Cells of a few texels: the nearest known texel across a seam is usually
  // within one or two texels; farther ones are found by the exhaustive pass.
  const double reach = 4 * spacing, limit = max_spacings * spacing;
  const TexelGrid grid(atlas, known, reach);
  ParallelFor(nt, 0, [&](long t) {
    if (!want[t]) return;
    const Texel& tx = atlas.texels[t];
    for (const bool same_side : {true, false}) {
      // The 27 cells around the texel hold every known texel within `reach`.
      const int near = grid.Nearest(tx.position, tx.normal, 1, same_side);
      const double d = near >= 0 ? (atlas.texels[near].position - tx.position).norm() : 1e300;
      if (d <= std::min(reach, limit)) return void(out[t] = near);
      if (limit <= reach) continue;
      double best_d2 = limit * limit;
      int best = -1;
      for (int u : known_ids) {
        const Texel& tu = atlas.texels[u];
        if (same_side && !(tu.normal.dot(tx.normal) > 0)) continue;
        const double d2 = (tu.position - tx.position).squaredNorm();
        if (d2 < best_d2 || (d2 == best_d2 && best < 0)) best_d2 = d2, best = u;
      }
      if (best >= 0) return void(out[t] = best);
    }
  }, 64);
  return out;
}

std::vector<std::vector<int>> SurfaceNeighbours(const Atlas& atlas, double reach) {
  const int nt = static_cast<int>(atlas.texels.size());
  std::vector<std::vector<int>> nb(nt);
  std::vector<double> spacing(nt, 0.0);
  std::vector<char> border(nt, 0);
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
    border[t] = nb[t].size() < 8;
  }
  // Texels with no grid 4-neighbour (single-texel charts) take the median spacing.
  std::vector<double> known;
  for (double s : spacing)
    if (s > 0) known.push_back(s);
  if (known.empty() || std::count(border.begin(), border.end(), char(1)) == 0) return nb;
  std::nth_element(known.begin(), known.begin() + known.size() / 2, known.end());
  const double median = known[known.size() / 2];
  double cell = 0;
  for (int t = 0; t < nt; ++t) {
    if (!border[t]) continue;
    if (spacing[t] <= 0) spacing[t] = median;
    // Degenerate spacings (many texels at one pole) must not hide neighbours
    // one row further: at least a tenth of the typical spacing.
    spacing[t] = std::max(spacing[t], 0.1 * median);
    cell = std::max(cell, reach * spacing[t]);
  }
  // Cells of the largest reach: every pair within reach is in adjacent cells.
  const TexelGrid grid(atlas, border, cell);
  std::vector<std::vector<int>> extra(nt);
  for (int t = 0; t < nt; ++t) {
    if (!border[t]) continue;
    const Texel& a = atlas.texels[t];
    grid.ForEachNear(a.position, 1, [&](int u) {
      if (u <= t) return;  // each pair once
      const Texel& b = atlas.texels[u];
      if (GridAdjacent(a, b)) return;
      const double r = reach * std::max(spacing[t], spacing[u]);
      if ((a.position - b.position).squaredNorm() > r * r || a.normal.dot(b.normal) <= 0.5) return;
      extra[t].push_back(u);
      extra[u].push_back(t);
    });
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
