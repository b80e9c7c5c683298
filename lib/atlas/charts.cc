#include "atlas/charts.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <set>
#include <unordered_map>

#include "atlas/chart_flatten.h"
#include "atlas/chart_segment.h"
#include "core/error.h"
#include "core/parallel.h"

namespace svbrdf {

void ChartAtlasOptions::Check() const {
  if (!(texel_size > 0 && std::isfinite(texel_size))) throw Error(Msg("chart atlas: texel size must be > 0, got ", texel_size));
  if (max_resolution < 16 || max_resolution > 16384)
    throw Error(Msg("chart atlas: max resolution must be in [16, 16384], got ", max_resolution));
  if (!(max_cone_deg > 0 && max_cone_deg <= 90)) throw Error(Msg("chart atlas: cone must be in (0, 90] degrees, got ", max_cone_deg));
  if (!(max_stretch > 1)) throw Error(Msg("chart atlas: max stretch must be > 1, got ", max_stretch));
  if (!(min_chart_texels >= 0 && min_chart_texels <= 1e6))
    throw Error(Msg("chart atlas: min chart texels must be in [0, 1e6], got ", min_chart_texels));
  if (gutter < 1 || gutter > 64) throw Error(Msg("chart atlas: gutter must be in [1, 64], got ", gutter));
}

namespace {

// Charts of less than `min_area` surface join a neighbouring chart when the
// union still flattens (FlattenChart's disk, flip and stretch tests): the
// charts left by the cuts of charts that did not flatten, and crumbs whose
// normal kept them out of their neighbours. In rounds: each small chart
// proposes the neighbour it shares most edges with (among those not tried
// yet), every target takes all its proposers at once or, when that union
// does not flatten, the first alone; a chart that proposes is no target in
// the same round. Targets are flattened in parallel.
void MergeSmallCharts(const Mesh& mesh, const std::vector<int>& canon, const FaceGeometry& geo,
                      const std::vector<std::array<int, 3>>& nb, double min_area, double max_stretch,
                      std::vector<Chart>* charts_io) {
  std::vector<Chart>& charts = *charts_io;
  const int F = int(mesh.faces.size());
  std::vector<std::set<int>> tried(charts.size());  // targets whose union with the chart failed
  std::vector<int> chart_of(F, -1);
  for (int round = 0; round < 8; ++round) {
    for (size_t c = 0; c < charts.size(); ++c)
      for (int f : charts[c].faces) chart_of[f] = int(c);
    std::map<int, std::vector<std::pair<int, int>>> proposals;  // target -> (small chart, shared edges)
    std::vector<char> proposing(charts.size(), 0);
    for (size_t c = 0; c < charts.size(); ++c) {
      if (charts[c].faces.empty() || charts[c].area >= min_area) continue;
      std::map<int, int> shared;
      for (int f : charts[c].faces)
        for (int g : nb[f])
          if (g >= 0 && chart_of[g] != int(c) && !tried[c].count(chart_of[g])) ++shared[chart_of[g]];
      int target = -1, best = 0;
      for (const auto& [d, n] : shared)
        if (n > best) best = n, target = d;
      if (target < 0) continue;
      proposals[target].emplace_back(int(c), best);
      proposing[c] = 1;
    }
    std::vector<std::pair<int, std::vector<std::pair<int, int>>>> jobs;
    for (auto& [t, p] : proposals) {
      if (proposing[t]) continue;
      std::stable_sort(p.begin(), p.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
      jobs.emplace_back(t, p);
    }
    if (jobs.empty()) break;
    std::vector<Chart> merged(jobs.size());
    std::vector<int> taken(jobs.size(), 0);  // proposers merged: all, 1, or 0
    ParallelFor(long(jobs.size()), 0, [&](long j) {
      const int t = jobs[j].first;
      const auto& p = jobs[j].second;
      std::vector<int> faces = charts[t].faces;
      for (const auto& [s, n] : p) faces.insert(faces.end(), charts[s].faces.begin(), charts[s].faces.end());
      if (FlattenChart(mesh, canon, faces, geo.area, max_stretch, &merged[j])) return void(taken[j] = int(p.size()));
      if (p.size() == 1) return;
      faces = charts[t].faces;
      faces.insert(faces.end(), charts[p[0].first].faces.begin(), charts[p[0].first].faces.end());
      if (FlattenChart(mesh, canon, faces, geo.area, max_stretch, &merged[j])) taken[j] = 1;
    });
    for (size_t j = 0; j < jobs.size(); ++j) {
      const int t = jobs[j].first;
      const auto& p = jobs[j].second;
      if (taken[j] == 0) tried[p[0].first].insert(t);
      if (taken[j] == 0) continue;
      charts[t] = std::move(merged[j]);
      for (int i = 0; i < taken[j]; ++i) charts[p[i].first] = Chart{};
    }
  }
  charts.erase(std::remove_if(charts.begin(), charts.end(), [](const Chart& c) { return c.faces.empty(); }),
               charts.end());
}

struct Placement {
  double x = 0, y = 0;  // texel coordinates of the chart box's corner (y down)
};

// Shelf packing at `texel_size`; returns the square side needed.
int Pack(const std::vector<Chart>& charts, double texel_size, int gutter, std::vector<Placement>* place) {
  std::vector<int> order(charts.size());
  std::iota(order.begin(), order.end(), 0);
  auto w = [&](int c) { return std::ceil(charts[c].width / texel_size) + gutter; };
  auto h = [&](int c) { return std::ceil(charts[c].height / texel_size) + gutter; };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return h(a) > h(b); });
  double box_area = 0, widest = 0;
  for (size_t c = 0; c < charts.size(); ++c) box_area += w(c) * h(c), widest = std::max(widest, w(c));
  place->assign(charts.size(), {});
  for (double side = std::max(widest + gutter, std::ceil(std::sqrt(box_area))) ;; side = std::ceil(side * 1.03 + 1)) {
    double x = gutter, y = gutter, shelf = 0;
    for (int c : order) {
      if (x + w(c) > side) x = gutter, y += shelf, shelf = 0;
      (*place)[c] = {x, y};
      x += w(c);
      shelf = std::max(shelf, h(c));
    }
    if (y + shelf <= side) return int(side);
  }
}

}  // namespace

Mesh MakeChartAtlasUVs(const Mesh& mesh, const ChartAtlasOptions& options, ChartAtlasInfo* info) {
  options.Check();
  const int F = int(mesh.faces.size());
  if (F == 0) throw Error("chart atlas: mesh has no faces");
  const FaceGeometry geo = ComputeFaceGeometry(mesh);
  std::vector<int> canon;  // vertex ids welded by position
  const std::vector<std::array<int, 3>> nb = FaceNeighbours(mesh, &canon);
  const double min_area = options.min_chart_texels * options.texel_size * options.texel_size;
  std::vector<std::vector<int>> pending = AbsorbSmallCharts(
      GrowCharts(mesh, geo, nb, std::cos(options.max_cone_deg * kPi / 180.0)), geo, nb, min_area);

  // Flatten in parallel rounds; failures are bisected into connected pieces
  // for the next round. Results are kept in a deterministic order.
  std::vector<Chart> charts;
  std::vector<int> mark(F, 0);
  int stamp = 1;
  while (!pending.empty()) {
    std::vector<Chart> flat(pending.size());
    std::vector<char> ok(pending.size(), 0);
    ParallelFor(long(pending.size()), 0, [&](long i) {
      ok[i] = FlattenChart(mesh, canon, pending[i], geo.area, options.max_stretch, &flat[i]);
    });
    std::vector<std::vector<int>> next;
    for (size_t i = 0; i < pending.size(); ++i) {
      if (ok[i]) {
        charts.push_back(std::move(flat[i]));
        continue;
      }
      const auto halves = Bisect(mesh, pending[i]);
      for (const auto* half : {&halves.first, &halves.second}) {
        for (auto& part : Components(*half, nb, &mark, stamp)) next.push_back(std::move(part));
        stamp += 2;
      }
    }
    pending = std::move(next);
  }

  MergeSmallCharts(mesh, canon, geo, nb, min_area, options.max_stretch, &charts);

  // Pack; grow the texel size until the layout fits the cap.
  double texel_size = options.texel_size;
  std::vector<Placement> place;
  int side = Pack(charts, texel_size, options.gutter, &place);
  for (int it = 0; side > options.max_resolution && it < 60; ++it) {
    texel_size *= std::max(1.01, 0.98 * double(side) / options.max_resolution);
    side = Pack(charts, texel_size, options.gutter, &place);
  }
  if (side > options.max_resolution)
    throw Error(Msg("chart atlas: ", charts.size(), " charts do not fit a ", options.max_resolution,
                    "^2 texture (too many tiny charts; is the mesh very noisy?)"));

  Mesh out = mesh;
  out.texcoords.clear();
  out.face_uvs.assign(F, Vec3i(0, 0, 0));
  double covered = 0;
  // One texture coordinate per (chart, vertex): triangles of a chart share
  // their UV corners, so charts are the connected components of face_uvs.
  std::unordered_map<int, int> uv_of_vertex;
  for (size_t c = 0; c < charts.size(); ++c) {
    const Chart& ch = charts[c];
    covered += ch.area / (texel_size * texel_size);
    uv_of_vertex.clear();
    for (size_t i = 0; i < ch.faces.size(); ++i) {
      Vec3i ids;
      for (int k = 0; k < 3; ++k) {
        const auto [it, is_new] = uv_of_vertex.emplace(canon[mesh.faces[ch.faces[i]][k]], int(out.texcoords.size()));
        ids[k] = it->second;
        if (!is_new) continue;
        // Texel coordinates, y down; uv = (x / side, 1 - y / side).
        const double x = place[c].x + ch.uv[i][k].x() / texel_size;
        const double y = place[c].y + (ch.height - ch.uv[i][k].y()) / texel_size;
        out.texcoords.emplace_back(x / side, 1.0 - y / side);
      }
      out.face_uvs[ch.faces[i]] = ids;
    }
  }
  if (info) {
    info->resolution = side;
    info->texel_size = texel_size;
    info->charts = int(charts.size());
    info->fill = covered / (double(side) * side);
  }
  return out;
}

}  // namespace svbrdf
