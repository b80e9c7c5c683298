// Chart segmentation (chart_segment.h).
#include "atlas/chart_segment.h"

#include <algorithm>
#include <deque>
#include <map>
#include <numeric>
#include <queue>

namespace svbrdf {

FaceGeometry ComputeFaceGeometry(const Mesh& mesh) {
  const int F = int(mesh.faces.size());
  FaceGeometry g;
  g.normal.resize(F);
  g.area.resize(F);
  for (int f = 0; f < F; ++f) {
    const Vec3i& v = mesh.faces[f];
    const Vec3 n = (mesh.positions[v[1]] - mesh.positions[v[0]]).cross(mesh.positions[v[2]] - mesh.positions[v[0]]);
    g.area[f] = 0.5 * n.norm();
    g.normal[f] = g.area[f] > 0 ? Vec3(n.normalized()) : Vec3::Zero();
  }
  return g;
}

std::vector<std::array<int, 3>> FaceNeighbours(const Mesh& mesh, std::vector<int>* canon_out) {
  std::map<std::array<double, 3>, int> weld;
  std::vector<int>& canon = *canon_out;
  canon.resize(mesh.positions.size());
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    const Vec3& p = mesh.positions[v];
    canon[v] = weld.emplace(std::array<double, 3>{p.x(), p.y(), p.z()}, int(v)).first->second;
  }
  std::vector<std::pair<uint64_t, int>> edges;  // (edge key, face * 3 + corner)
  edges.reserve(mesh.faces.size() * 3);
  for (size_t f = 0; f < mesh.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const uint64_t a = uint32_t(canon[mesh.faces[f][k]]), b = uint32_t(canon[mesh.faces[f][(k + 1) % 3]]);
      if (a == b) continue;
      edges.emplace_back(std::min(a, b) << 32 | std::max(a, b), int(f * 3 + k));
    }
  std::sort(edges.begin(), edges.end());
  std::vector<std::array<int, 3>> nb(mesh.faces.size(), {-1, -1, -1});
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j].first == edges[i].first) ++j;
    if (j - i == 2) {
      const int fa = edges[i].second, fb = edges[i + 1].second;
      if (fa / 3 != fb / 3) nb[fa / 3][fa % 3] = fb / 3, nb[fb / 3][fb % 3] = fa / 3;
    }
    i = j;
  }
  return nb;
}

std::vector<std::vector<int>> GrowCharts(const Mesh& mesh, const FaceGeometry& geo,
                                         const std::vector<std::array<int, 3>>& nb, double cos_cone) {
  const std::vector<Vec3>& normal = geo.normal;
  const std::vector<double>& area = geo.area;
  const int F = int(mesh.faces.size());
  std::vector<int> chart_of(F, -1);
  std::vector<std::vector<int>> charts;
  // Seeds: largest faces first (a stable order), so charts start on solid ground.
  std::vector<int> order(F);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return area[a] > area[b]; });
  for (int seed : order) {
    if (chart_of[seed] >= 0) continue;
    const int id = int(charts.size());
    charts.emplace_back();
    Vec3 sum = normal[seed] * area[seed];
    // Candidates nearest to the chart's mean normal first: compact charts.
    using Item = std::pair<double, int>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
    queue.push({0.0, seed});
    while (!queue.empty()) {
      const int f = queue.top().second;
      queue.pop();
      if (chart_of[f] >= 0) continue;
      const Vec3 mean = sum.norm() > 0 ? Vec3(sum.normalized()) : normal[seed];
      if (f != seed && normal[f].dot(mean) < cos_cone) continue;
      chart_of[f] = id;
      charts[id].push_back(f);
      if (f != seed) sum += normal[f] * area[f];
      for (int g : nb[f])
        if (g >= 0 && chart_of[g] < 0) queue.push({1.0 - normal[g].dot(mean), g});
    }
  }
  return charts;
}

std::vector<std::vector<int>> AbsorbSmallCharts(std::vector<std::vector<int>> charts, const FaceGeometry& geo,
                                                const std::vector<std::array<int, 3>>& nb, double min_area) {
  const int F = int(geo.area.size());
  std::vector<int> chart_of(F, -1);
  std::vector<double> area(charts.size(), 0.0);
  std::vector<Vec3> normal_sum(charts.size(), Vec3::Zero());
  for (size_t c = 0; c < charts.size(); ++c)
    for (int f : charts[c]) {
      chart_of[f] = int(c);
      area[c] += geo.area[f];
      normal_sum[c] += geo.area[f] * geo.normal[f];
    }
  std::vector<int> order(charts.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return area[a] < area[b]; });
  std::map<int, int> shared;  // neighbouring chart -> shared edges
  for (int c : order) {
    if (charts[c].empty() || area[c] >= min_area) continue;
    shared.clear();
    for (int f : charts[c])
      for (int g : nb[f])
        if (g >= 0 && chart_of[g] != c) ++shared[chart_of[g]];
    int target = -1, best = 0;
    for (const auto& [d, n] : shared)  // ascending chart id: ties go to the lower one
      if (n > best && normal_sum[d].dot(normal_sum[c]) > 0) best = n, target = d;
    if (target < 0) continue;
    for (int f : charts[c]) chart_of[f] = target;
    charts[target].insert(charts[target].end(), charts[c].begin(), charts[c].end());
    area[target] += area[c];
    normal_sum[target] += normal_sum[c];
    charts[c].clear();
  }
  charts.erase(std::remove_if(charts.begin(), charts.end(), [](const std::vector<int>& c) { return c.empty(); }),
               charts.end());
  return charts;
}

std::vector<std::vector<int>> Components(const std::vector<int>& faces, const std::vector<std::array<int, 3>>& nb,
                                         std::vector<int>* mark, int stamp) {
  for (int f : faces) (*mark)[f] = stamp;
  std::vector<std::vector<int>> out;
  for (int f : faces) {
    if ((*mark)[f] != stamp) continue;
    out.emplace_back();
    std::deque<int> q{f};
    (*mark)[f] = stamp + 1;
    while (!q.empty()) {
      const int g = q.front();
      q.pop_front();
      out.back().push_back(g);
      for (int h : nb[g])
        if (h >= 0 && (*mark)[h] == stamp) (*mark)[h] = stamp + 1, q.push_back(h);
    }
    std::sort(out.back().begin(), out.back().end());
  }
  return out;
}

std::pair<std::vector<int>, std::vector<int>> Bisect(const Mesh& mesh, const std::vector<int>& faces) {
  std::vector<std::pair<double, int>> key;
  Vec3 lo(1e300, 1e300, 1e300), hi(-1e300, -1e300, -1e300);
  std::vector<Vec3> centre(faces.size());
  for (size_t i = 0; i < faces.size(); ++i) {
    const Vec3i& v = mesh.faces[faces[i]];
    centre[i] = (mesh.positions[v[0]] + mesh.positions[v[1]] + mesh.positions[v[2]]) / 3.0;
    lo = lo.cwiseMin(centre[i]);
    hi = hi.cwiseMax(centre[i]);
  }
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  for (size_t i = 0; i < faces.size(); ++i) key.emplace_back(centre[i][axis], faces[i]);
  std::sort(key.begin(), key.end());
  std::pair<std::vector<int>, std::vector<int>> halves;
  for (size_t i = 0; i < key.size(); ++i) (i < key.size() / 2 ? halves.first : halves.second).push_back(key[i].second);
  return halves;
}

}  // namespace svbrdf
