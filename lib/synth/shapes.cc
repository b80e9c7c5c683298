#include "synth/shapes.h"

#include <cmath>
#include <array>
#include <functional>
#include <map>

#include "atlas/charts.h"
#include "core/error.h"

namespace svbrdf {

namespace {

// A (rings+1) x (segments+1) grid of vertices with texcoords (j/segments,
// 1 - i/rings); position(u, v) with u, v in [0,1]. Triangles wind
// counter-clockwise seen from outside when position is an outward chart.
Mesh GridMesh(int rings, int segments, const std::function<Vec3(double, double)>& position) {
  Mesh m;
  for (int i = 0; i <= rings; ++i)
    for (int j = 0; j <= segments; ++j) {
      const double u = double(j) / segments, v = double(i) / rings;
      m.positions.push_back(position(u, v));
      m.texcoords.emplace_back(u, 1.0 - v);
    }
  auto id = [&](int i, int j) { return i * (segments + 1) + j; };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const Vec3i a(id(i, j), id(i + 1, j), id(i + 1, j + 1));
      const Vec3i b(id(i, j), id(i + 1, j + 1), id(i, j + 1));
      m.faces.push_back(a);
      m.faces.push_back(b);
    }
  m.face_uvs = m.faces;
  return m;
}

// Lat-long chart: v=0 north pole (+y), u around the y axis.
Vec3 LatLong(double u, double v) {
  const double theta = v * kPi, phi = u * 2 * kPi;
  return Vec3(std::sin(theta) * std::cos(phi), std::cos(theta), -std::sin(theta) * std::sin(phi));
}

// Merges vertices at the same position (seams, poles, cube edges) so smooth
// normals see every adjacent face; texture coordinates stay separate.
void WeldPositions(Mesh* m) {
  std::map<std::array<long long, 3>, int> index;
  std::vector<Vec3> positions;
  std::vector<int> remap(m->positions.size());
  for (size_t i = 0; i < m->positions.size(); ++i) {
    const Vec3& p = m->positions[i];
    const std::array<long long, 3> key{std::llround(p.x() * 1e8), std::llround(p.y() * 1e8), std::llround(p.z() * 1e8)};
    auto it = index.emplace(key, static_cast<int>(positions.size()));
    if (it.second) positions.push_back(p);
    remap[i] = it.first->second;
  }
  for (Vec3i& f : m->faces) f = Vec3i(remap[f[0]], remap[f[1]], remap[f[2]]);
  m->positions = positions;
}

// Drops triangles that collapsed to zero area (at the poles of a lat-long grid).
void DropDegenerate(Mesh* m) {
  std::vector<Vec3i> faces, uvs;
  for (size_t f = 0; f < m->faces.size(); ++f) {
    const Vec3i& t = m->faces[f];
    const Vec3 n = (m->positions[t[1]] - m->positions[t[0]]).cross(m->positions[t[2]] - m->positions[t[0]]);
    if (n.norm() < 1e-14) continue;
    faces.push_back(t);
    uvs.push_back(m->face_uvs[f]);
  }
  m->faces = faces;
  m->face_uvs = uvs;
}

// Orients faces so their normals point away from the origin (all our shapes are star-shaped).
void OrientOutward(Mesh* m) {
  for (size_t f = 0; f < m->faces.size(); ++f) {
    Vec3i& t = m->faces[f];
    const Vec3 a = m->positions[t[0]], b = m->positions[t[1]], c = m->positions[t[2]];
    if ((b - a).cross(c - a).dot(a + b + c) < 0) {
      std::swap(t[1], t[2]);
      std::swap(m->face_uvs[f][1], m->face_uvs[f][2]);
    }
  }
}

Mesh Finish(Mesh m) {
  WeldPositions(&m);
  DropDegenerate(&m);
  OrientOutward(&m);
  m.ComputeNormals(NormalWeighting::kArea);  // see shapes.h
  return m;
}

}  // namespace

Mesh MakeSphere(double radius, int rings, int segments) {
  return Finish(GridMesh(rings, segments, [&](double u, double v) { return Vec3(radius * LatLong(u, v)); }));
}

Mesh MakeTorus(double R, double r, int rings, int segments) {
  // Torus lying in the x-z plane; u around the main axis (y), v around the tube.
  Mesh m = GridMesh(rings, segments, [&](double u, double v) {
    const double phi = u * 2 * kPi, psi = v * 2 * kPi;
    return Vec3((R + r * std::cos(psi)) * std::cos(phi), r * std::sin(psi), -(R + r * std::cos(psi)) * std::sin(phi));
  });
  // A torus is not star-shaped: orient each face away from the tube's centre circle.
  for (size_t f = 0; f < m.faces.size(); ++f) {
    Vec3i& t = m.faces[f];
    const Vec3 a = m.positions[t[0]], b = m.positions[t[1]], c = m.positions[t[2]];
    const Vec3 centroid = (a + b + c) / 3.0;
    const Vec3 ring = Vec3(centroid.x(), 0, centroid.z()).normalized() * R;
    if ((b - a).cross(c - a).dot(centroid - ring) < 0) {
      std::swap(t[1], t[2]);
      std::swap(m.face_uvs[f][1], m.face_uvs[f][2]);
    }
  }
  WeldPositions(&m);
  m.ComputeNormals(NormalWeighting::kArea);  // see shapes.h
  return m;
}

Mesh MakeBlob(double radius, double bump, int rings, int segments) {
  return Finish(GridMesh(rings, segments, [&](double u, double v) {
    const Vec3 d = LatLong(u, v);
    // Smooth low-frequency bumps; vanish at the poles so the seam closes.
    const double s = std::sin(3 * d.x() + 1.0) * std::sin(2 * d.y() + 0.5) * std::sin(3 * d.z() + 2.0);
    return Vec3(radius * (1.0 + bump * s) * d);
  }));
}

Mesh MakeBevelledCube(double half_size, double bevel, int cells) {
  // Each face is a grid on the cube [-1,1]^3, pushed onto a rounded box:
  // p -> q + bevel * (p - q)/|p - q| with q the point clamped to the inner box.
  // Faces are packed into a 3x2 atlas with a small gutter.
  Mesh m;
  const double inner = half_size - bevel;
  const Vec3 axes[6][3] = {
      {Vec3::UnitX(), -Vec3::UnitZ(), Vec3::UnitY()}, {-Vec3::UnitX(), Vec3::UnitZ(), Vec3::UnitY()},
      {Vec3::UnitY(), Vec3::UnitX(), -Vec3::UnitZ()}, {-Vec3::UnitY(), Vec3::UnitX(), Vec3::UnitZ()},
      {Vec3::UnitZ(), Vec3::UnitX(), Vec3::UnitY()},  {-Vec3::UnitZ(), -Vec3::UnitX(), Vec3::UnitY()}};
  const double gutter = 0.02;
  for (int face = 0; face < 6; ++face) {
    const Vec3 n = axes[face][0], s = axes[face][1], t = axes[face][2];
    const int base = static_cast<int>(m.positions.size());
    const double cu = (face % 3) / 3.0, cv = (face / 3) / 2.0;
    for (int i = 0; i <= cells; ++i)
      for (int j = 0; j <= cells; ++j) {
        const double a = 2.0 * j / cells - 1.0, b = 2.0 * i / cells - 1.0;
        const Vec3 p = half_size * (n + a * s + b * t);
        const Vec3 q = p.cwiseMax(Vec3::Constant(-inner)).cwiseMin(Vec3::Constant(inner));
        const Vec3 d = p - q;
        m.positions.push_back(d.norm() > 1e-12 ? Vec3(q + bevel * d.normalized()) : p);
        m.texcoords.emplace_back(cu + gutter + (1.0 / 3 - 2 * gutter) * double(j) / cells,
                                 cv + gutter + (0.5 - 2 * gutter) * double(i) / cells);
      }
    for (int i = 0; i < cells; ++i)
      for (int j = 0; j < cells; ++j) {
        const int v00 = base + i * (cells + 1) + j, v01 = v00 + 1, v10 = v00 + cells + 1, v11 = v10 + 1;
        m.faces.emplace_back(v00, v01, v11);
        m.faces.emplace_back(v00, v11, v10);
      }
  }
  m.face_uvs = m.faces;
  return Finish(m);
}

Mesh MakeShape(const std::string& name, int detail) {
  const int seg = std::max(8, detail);
  if (name == "sphere") return MakeSphere(0.5, seg / 2, seg);
  if (name == "torus") return MakeTorus(0.4, 0.18, seg / 2, seg);
  if (name == "blob") return MakeBlob(0.5, 0.12, seg / 2, seg);
  if (name == "cube") return MakeBevelledCube(0.4, 0.1, std::max(4, seg / 6));
  throw Error(Msg("unknown object '", name, "'; expected sphere, torus, blob or cube"));
}

Mesh LoadShapeFromFile(const std::string& path, int texture_size) {
  Mesh m = LoadMesh(path);
  Vec3 lo = m.positions[0], hi = m.positions[0];
  for (const Vec3& p : m.positions) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const Vec3 centre = 0.5 * (lo + hi);
  double radius = 0;
  for (const Vec3& p : m.positions) radius = std::max(radius, (p - centre).norm());
  if (!(radius > 0)) throw Error(Msg(path, ": the mesh has no extent"));
  for (Vec3& p : m.positions) p = (p - centre) * (0.5 / radius);
  m.ComputeNormals(NormalWeighting::kArea);  // see shapes.h
  if (!m.HasUVs()) {
    double area = 0;
    for (const Vec3i& f : m.faces)
      area += 0.5 * (m.positions[f[1]] - m.positions[f[0]]).cross(m.positions[f[2]] - m.positions[f[0]]).norm();
    ChartAtlasOptions co;
    co.max_resolution = texture_size;
    co.texel_size = std::sqrt(area / (0.5 * texture_size * texture_size));
    // The painted truth depends on the layout (region seeds are drawn from
    // texel positions): no chart merging keeps the captures, and with them
    // the thresholds of e2e_reconstruct_test's scan regression, independent
    // of the chart-merging rule.
    co.min_chart_texels = 0;
    ChartAtlasInfo info;
    m = MakeChartAtlasUVs(m, co, &info);
  }
  return m;
}

}  // namespace svbrdf
