// Chart flattening (chart_flatten.h): CGAL's LSCM, checked for disks,
// flips and stretch.
#include "atlas/chart_flatten.h"

#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_parameterization/LSCM_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/parameterize.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace svbrdf {

namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace SMP = CGAL::Surface_mesh_parameterization;

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

}  // namespace

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

}  // namespace svbrdf
