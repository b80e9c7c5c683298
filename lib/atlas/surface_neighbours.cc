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

// Known texels bucketed in a uniform 3D grid.
class TexelGrid {
 public:
  TexelGrid(const Atlas& atlas, const std::vector<char>& known, double cell) : atlas_(atlas), cell_(cell) {
    for (int u = 0; u < int(atlas.texels.size()); ++u)
      if (known[u]) cells_[Key(Cell(atlas.texels[u].position))].push_back(u);
  }
  // Nearest known texel within `rings` cells of p's cell (-1: none there).
  int Nearest(const Vec3& p, const Vec3& n, int rings, bool same_side) const {
    const Eigen::Vector3i c = Cell(p);
    int best = -1;
    double best_d2 = 1e300;
    for (int dz = -rings; dz <= rings; ++dz)
      for (int dy = -rings; dy <= rings; ++dy)
        for (int dx = -rings; dx <= rings; ++dx) {
          const auto it = cells_.find(Key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == cells_.end()) continue;
          for (int u : it->second) {
            const Texel& tu = atlas_.texels[u];
            if (same_side && !(tu.normal.dot(n) > 0)) continue;
            const double d2 = (tu.position - p).squaredNorm();
            if (d2 < best_d2 || (d2 == best_d2 && u < best)) best_d2 = d2, best = u;
          }
        }
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

}  // namespace svbrdf
