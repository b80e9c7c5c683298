#include "atlas/charts.h"

#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_parameterization/LSCM_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/parameterize.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <map>
#include <numeric>
#include <queue>
#include <unordered_map>

#include "core/error.h"
#include "core/parallel.h"

namespace svbrdf {

void ChartAtlasOptions::Check() const {
  if (!(texel_size > 0 && std::isfinite(texel_size))) throw Error(Msg("chart atlas: texel size must be > 0, got ", texel_size));
  if (max_resolution < 16 || max_resolution > 16384)
    throw Error(Msg("chart atlas: max resolution must be in [16, 16384], got ", max_resolution));
  if (!(max_cone_deg > 0 && max_cone_deg <= 90)) throw Error(Msg("chart atlas: cone must be in (0, 90] degrees, got ", max_cone_deg));
  if (!(max_stretch > 1)) throw Error(Msg("chart atlas: max stretch must be > 1, got ", max_stretch));
  if (gutter < 1 || gutter > 64) throw Error(Msg("chart atlas: gutter must be in [1, 64], got ", gutter));
}

namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace SMP = CGAL::Surface_mesh_parameterization;

// A flattened chart: its faces, one UV per face corner in surface units
// (area-preserving scale, principal axes along u), and its UV bounding box.
struct Chart {
  std::vector<int> faces;
  std::vector<std::array<Vec2, 3>> uv;  // per face corner, min corner of the box at (0, 0)
  double width = 0, height = 0;        // box in surface units
  double area = 0;                     // surface area
};

// Edge-adjacent faces (across edges shared by exactly two faces), with
// vertices welded by position so that unwelded scans still connect.
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

// Region growing by normal cone; returns the faces of each chart.
std::vector<std::vector<int>> GrowCharts(const Mesh& mesh, const std::vector<Vec3>& normal,
                                         const std::vector<double>& area, const std::vector<std::array<int, 3>>& nb,
                                         double cos_cone) {
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

// Connected components of `faces` under the adjacency restricted to them.
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

inline double Cross2(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

// One triangle laid flat isometrically (always a valid chart).
Chart FlattenTriangle(const Mesh& mesh, int f) {
  Chart c;
  c.faces = {f};
  const Vec3i& v = mesh.faces[f];
  const Vec3 e1 = mesh.positions[v[1]] - mesh.positions[v[0]], e2 = mesh.positions[v[2]] - mesh.positions[v[0]];
  const double l1 = e1.norm();
  const double x2 = l1 > 0 ? e2.dot(e1) / l1 : 0.0, y2 = l1 > 0 ? e1.cross(e2).norm() / l1 : 0.0;
  const double x0 = std::min(0.0, x2);
  c.uv = {{{Vec2(-x0, 0), Vec2(l1 - x0, 0), Vec2(x2 - x0, y2)}}};
  c.width = std::max(l1, x2) - x0;
  c.height = y2;
  c.area = 0.5 * e1.cross(e2).norm();
  return c;
}

// Flattens a chart with LSCM; false when it is not a manifold disk, the
// solver fails, or a triangle flips or stretches beyond `max_stretch`.
bool FlattenChart(const Mesh& mesh, const std::vector<int>& canon, const std::vector<int>& faces,
                  const std::vector<double>& area, double max_stretch, Chart* out) {
  if (faces.size() == 1) {
    *out = FlattenTriangle(mesh, faces[0]);
    return true;
  }
  SurfaceMesh sm;
  std::unordered_map<int, SurfaceMesh::Vertex_index> local;
  std::vector<std::array<SurfaceMesh::Vertex_index, 3>> corners;
  for (int f : faces) {
    std::array<SurfaceMesh::Vertex_index, 3> vs;
    for (int k = 0; k < 3; ++k) {
      const int g = canon[mesh.faces[f][k]];
      auto it = local.find(g);
      if (it == local.end()) {
        const Vec3& p = mesh.positions[g];
        it = local.emplace(g, sm.add_vertex(Kernel::Point_3(p.x(), p.y(), p.z()))).first;
      }
      vs[k] = it->second;
    }
    if (vs[0] == vs[1] || vs[1] == vs[2] || vs[0] == vs[2]) return false;
    if (sm.add_face(vs[0], vs[1], vs[2]) == SurfaceMesh::null_face()) return false;  // non-manifold
    corners.push_back(vs);
  }
  // A disk: exactly one border loop and Euler characteristic V - E + F = 1.
  int loops = 0;
  SurfaceMesh::Halfedge_index border;
  std::vector<char> seen(sm.number_of_halfedges(), 0);
  for (auto h : sm.halfedges()) {
    if (!sm.is_border(h) || seen[h.idx()]) continue;
    ++loops;
    border = h;
    for (auto g = h; !seen[g.idx()]; g = sm.next(g)) seen[g.idx()] = 1;
  }
  const long euler = long(sm.number_of_vertices()) - long(sm.number_of_edges()) + long(sm.number_of_faces());
  if (loops != 1 || euler != 1) return false;

  auto uvmap = sm.add_property_map<SurfaceMesh::Vertex_index, Kernel::Point_2>("v:uv").first;
  if (SMP::parameterize(sm, SMP::LSCM_parameterizer_3<SurfaceMesh>(), border, uvmap) != SMP::OK) return false;

  out->faces = faces;
  out->uv.resize(faces.size());
  double uv_area = 0, surf_area = 0;
  std::vector<double> signed_area(faces.size());
  for (size_t i = 0; i < faces.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      const Kernel::Point_2& p = uvmap[corners[i][k]];
      out->uv[i][k] = Vec2(p.x(), p.y());
      if (!out->uv[i][k].allFinite()) return false;
    }
    signed_area[i] = 0.5 * Cross2(out->uv[i][1] - out->uv[i][0], out->uv[i][2] - out->uv[i][0]);
    uv_area += signed_area[i];
    surf_area += area[faces[i]];
  }
  if (!(std::abs(uv_area) > 0) || !(surf_area > 0)) return false;
  const double mirror = uv_area < 0 ? -1.0 : 1.0;  // keep the 3D winding counter-clockwise in UV
  uv_area = std::abs(uv_area);
  // No flipped and no badly stretched triangle (slivers below 1e-3 of the
  // mean face area only must not flip).
  const double ratio = uv_area / surf_area, mean_area = surf_area / faces.size();
  for (size_t i = 0; i < faces.size(); ++i) {
    const double a = mirror * signed_area[i], s = area[faces[i]];
    if (s < 1e-3 * mean_area) {
      if (a < -1e-12 * uv_area) return false;
      continue;
    }
    const double r = a / (s * ratio);
    if (!(r > 1.0 / max_stretch && r < max_stretch)) return false;
  }
  // Area-preserving scale, mirror, principal axes along u (a rotation, so
  // the winding is kept), box corner at the origin.
  const double scale = std::sqrt(surf_area / uv_area);
  Vec2 mean = Vec2::Zero();
  for (auto& tri : out->uv)
    for (Vec2& p : tri) p = Vec2(mirror * p.x(), p.y()) * scale, mean += p;
  mean /= 3.0 * faces.size();
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (auto& tri : out->uv)
    for (const Vec2& p : tri) cov += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
  const Vec2 major = eig.eigenvectors().col(1);
  Eigen::Matrix2d rot;
  rot << major.x(), major.y(), -major.y(), major.x();  // rows: major, major rotated by +90 deg
  Vec2 lo(1e300, 1e300), hi(-1e300, -1e300);
  for (auto& tri : out->uv)
    for (Vec2& p : tri) {
      p = rot * (p - mean);
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  for (auto& tri : out->uv)
    for (Vec2& p : tri) p -= lo;
  out->width = hi.x() - lo.x();
  out->height = hi.y() - lo.y();
  out->area = surf_area;
  return true;
}

// Cuts faces in two at the median of their centroids along the longest extent.
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
  std::vector<Vec3> normal(F);
  std::vector<double> area(F);
  for (int f = 0; f < F; ++f) {
    const Vec3i& v = mesh.faces[f];
    const Vec3 n = (mesh.positions[v[1]] - mesh.positions[v[0]]).cross(mesh.positions[v[2]] - mesh.positions[v[0]]);
    area[f] = 0.5 * n.norm();
    normal[f] = area[f] > 0 ? Vec3(n.normalized()) : Vec3::Zero();
  }
  std::vector<int> canon;  // vertex ids welded by position
  const std::vector<std::array<int, 3>> nb = FaceNeighbours(mesh, &canon);
  std::vector<std::vector<int>> pending =
      GrowCharts(mesh, normal, area, nb, std::cos(options.max_cone_deg * kPi / 180.0));

  // Flatten in parallel rounds; failures are bisected into connected pieces
  // for the next round. Results are kept in a deterministic order.
  std::vector<Chart> charts;
  std::vector<int> mark(F, 0);
  int stamp = 1;
  while (!pending.empty()) {
    std::vector<Chart> flat(pending.size());
    std::vector<char> ok(pending.size(), 0);
    ParallelFor(long(pending.size()), 0, [&](long i) {
      ok[i] = FlattenChart(mesh, canon, pending[i], area, options.max_stretch, &flat[i]);
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
