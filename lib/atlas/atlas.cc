// Texel atlas construction: rasterise UV triangles at texel centres, dilate
// into the gutter, then attach surface geometry to every covered texel.
#include "atlas/atlas.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"

namespace svbrdf {
namespace {

// A texel's claim before geometry is attached.
struct Claim {
  int prim = -1;
  double b1 = 0, b2 = 0;
  bool interior = true;
};

inline double Cross2(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

// A UV triangle in continuous texel coordinates (texel centres at +0.5).
struct UvTriangle {
  Vec2 p0, e1, e2;
  double area2 = 0;  // signed, twice the area; the sign is the UV winding

  UvTriangle(const Mesh& mesh, int prim, int width, int height) {
    const Vec3i& f = mesh.face_uvs[prim];
    p0 = UvToTexel(mesh.texcoords[f[0]], width, height);
    e1 = UvToTexel(mesh.texcoords[f[1]], width, height) - p0;
    e2 = UvToTexel(mesh.texcoords[f[2]], width, height) - p0;
    area2 = Cross2(e1, e2);
  }
  bool Degenerate() const { return !(std::abs(area2) > 1e-12); }
  // (b1, b2) with p = p0 + b1 e1 + b2 e2; valid for either winding.
  Vec2 Barycentric(const Vec2& p) const {
    const Vec2 d = p - p0;
    return Vec2(Cross2(d, e2), Cross2(e1, d)) / area2;
  }
  Vec2 Point(const Vec2& b) const { return p0 + b.x() * e1 + b.y() * e2; }
};

// Barycentrics of the point of segment [a, b] nearest to p (all as barycentrics).
Vec2 NearestOnSegment(const UvTriangle& tri, const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 pa = tri.Point(a), ab = tri.Point(b) - pa;
  const double len2 = ab.squaredNorm();
  const double s = len2 > 0 ? std::clamp((p - pa).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return a + s * (b - a);
}

// Barycentrics of the point of the triangle nearest to p: the clamping used
// for dilation texels, so their geometry is that of the chart border.
Vec2 ClampedBarycentric(const UvTriangle& tri, const Vec2& p) {
  const Vec2 b = tri.Barycentric(p);
  if (b.x() >= 0 && b.y() >= 0 && b.x() + b.y() <= 1) return b;
  const Vec2 corners[3] = {Vec2(0, 0), Vec2(1, 0), Vec2(0, 1)};
  Vec2 best = corners[0];
  double best_d2 = 1e300;
  for (int k = 0; k < 3; ++k) {
    const Vec2 c = NearestOnSegment(tri, p, corners[k], corners[(k + 1) % 3]);
    const double d2 = (tri.Point(c) - p).squaredNorm();
    if (d2 < best_d2) best_d2 = d2, best = c;
  }
  return best;
}

Vec2 TexelCentre(int x, int y) { return Vec2(x + 0.5, y + 0.5); }

// Rows are processed in bands, each band by one task, so texel writes never
// race; within a band triangles are visited in index order and the first
// claim wins, which makes overlapping UVs resolve deterministically.
constexpr int kBandRows = 16;

std::vector<Claim> Rasterise(const Mesh& mesh, int width, int height) {
  const int bands = (height + kBandRows - 1) / kBandRows;
  std::vector<std::vector<int>> band_prims(bands);
  for (int f = 0; f < int(mesh.face_uvs.size()); ++f) {
    const UvTriangle tri(mesh, f, width, height);
    if (tri.Degenerate()) continue;  // covers no texel centre
    const double ymin = std::min({tri.p0.y(), tri.p0.y() + tri.e1.y(), tri.p0.y() + tri.e2.y()});
    const double ymax = std::max({tri.p0.y(), tri.p0.y() + tri.e1.y(), tri.p0.y() + tri.e2.y()});
    const int y0 = std::max(0, int(std::floor(ymin))), y1 = std::min(height - 1, int(std::floor(ymax)));
    for (int b = y0 / kBandRows; b <= y1 / kBandRows && y0 <= y1; ++b) band_prims[b].push_back(f);
  }

  std::vector<Claim> grid(size_t(width) * height);
  // Inclusive edges (small negative tolerance) so texel centres exactly on a
  // shared edge are not lost to rounding; the first-claim rule breaks ties.
  constexpr double kEps = 1e-9;
  ParallelFor(bands, 0, [&](long band) {
    for (int f : band_prims[band]) {
      const UvTriangle tri(mesh, f, width, height);
      const Vec2 a = tri.p0, b = tri.p0 + tri.e1, c = tri.p0 + tri.e2;
      const int x0 = std::max(0, int(std::floor(std::min({a.x(), b.x(), c.x()}))));
      const int x1 = std::min(width - 1, int(std::floor(std::max({a.x(), b.x(), c.x()}))));
      const int y0 = std::max(int(band) * kBandRows, int(std::floor(std::min({a.y(), b.y(), c.y()}))));
      const int y1 = std::min({height - 1, int(band + 1) * kBandRows - 1,
                               int(std::floor(std::max({a.y(), b.y(), c.y()})))});
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
          Claim& claim = grid[size_t(y) * width + x];
          if (claim.prim >= 0) continue;
          const Vec2 bc = tri.Barycentric(TexelCentre(x, y));
          if (bc.x() < -kEps || bc.y() < -kEps || bc.x() + bc.y() > 1 + kEps) continue;
          const double b1 = std::clamp(bc.x(), 0.0, 1.0);
          claim = {f, b1, std::clamp(bc.y(), 0.0, 1.0 - b1), true};
        }
    }
  });
  return grid;
}

// One dilation ring: every empty texel next to a claimed one takes the nearest
// claimed neighbour's triangle (edge neighbours before diagonal ones, then a
// fixed scan order), with barycentrics clamped into that triangle.
std::vector<Claim> DilateOnce(const Mesh& mesh, const std::vector<Claim>& in, int width, int height) {
  static const int kOffsets[8][2] = {{-1, 0}, {1, 0}, {0, -1}, {0, 1}, {-1, -1}, {1, -1}, {-1, 1}, {1, 1}};
  std::vector<Claim> out = in;
  ParallelFor(height, 0, [&](long y) {
    for (int x = 0; x < width; ++x) {
      if (in[size_t(y) * width + x].prim >= 0) continue;
      for (const auto& o : kOffsets) {
        const int nx = x + o[0], ny = int(y) + o[1];
        if (nx < 0 || ny < 0 || nx >= width || ny >= height) continue;
        const Claim& neighbour = in[size_t(ny) * width + nx];
        if (neighbour.prim < 0) continue;
        const Vec2 b = ClampedBarycentric(UvTriangle(mesh, neighbour.prim, width, height), TexelCentre(x, int(y)));
        out[size_t(y) * width + x] = {neighbour.prim, b.x(), b.y(), false};
        break;
      }
    }
  }, 8);
  return out;
}

// Position, smooth normal and UV tangent of a claimed texel.
Texel MakeTexel(const Mesh& mesh, int x, int y, const Claim& c) {
  Texel t;
  t.x = x;
  t.y = y;
  t.prim = c.prim;
  t.b1 = c.b1;
  t.b2 = c.b2;
  t.interior = c.interior;
  const Vec3i& f = mesh.faces[c.prim];
  const double b0 = 1 - c.b1 - c.b2;
  const Vec3& p0 = mesh.positions[f[0]];
  const Vec3 e1 = mesh.positions[f[1]] - p0, e2 = mesh.positions[f[2]] - p0;
  t.position = p0 + c.b1 * e1 + c.b2 * e2;

  const Vec3 face_n = e1.cross(e2).normalized();
  Vec3 n = face_n;
  if (mesh.normals.size() == mesh.positions.size())
    n = b0 * mesh.normals[f[0]] + c.b1 * mesh.normals[f[1]] + c.b2 * mesh.normals[f[2]];
  t.normal = n.squaredNorm() > 1e-24 ? Vec3(n.normalized()) : face_n;

  t.tangent = Frame::FromNormalTangent(t.normal, mesh.FaceDpDu(c.prim)).t;  // projects; falls back when degenerate
  return t;
}

// Claims the texels under the corners, edge midpoints and centroid of every
// UV triangle that are still free (in face order: deterministic).
void CoverSmallTriangles(const Mesh& mesh, int width, int height, std::vector<Claim>* grid) {
  for (int f = 0; f < int(mesh.face_uvs.size()); ++f) {
    const UvTriangle tri(mesh, f, width, height);
    if (tri.Degenerate()) continue;
    const Vec2 bary[7] = {Vec2(0, 0), Vec2(1, 0), Vec2(0, 1), Vec2(0.5, 0), Vec2(0.5, 0.5), Vec2(0, 0.5),
                          Vec2(1.0 / 3, 1.0 / 3)};
    for (const Vec2& b : bary) {
      const Vec2 p = tri.Point(b);
      const int x = std::clamp(int(std::floor(p.x())), 0, width - 1), y = std::clamp(int(std::floor(p.y())), 0, height - 1);
      Claim& claim = (*grid)[size_t(y) * width + x];
      if (claim.prim >= 0) continue;
      const Vec2 c = ClampedBarycentric(tri, TexelCentre(x, y));
      claim = {f, c.x(), c.y(), false};
    }
  }
}

}  // namespace

Atlas BuildAtlas(const Mesh& mesh, int width, int height, int dilate, bool cover_small) {
  if (!mesh.HasUVs()) throw Error("BuildAtlas: mesh has no texture coordinates");
  if (width <= 0 || height <= 0) throw Error(Msg("BuildAtlas: invalid atlas size ", width, "x", height));
  mesh.Validate("BuildAtlas");  // UV face count and index ranges

  std::vector<Claim> grid = Rasterise(mesh, width, height);
  if (cover_small) CoverSmallTriangles(mesh, width, height, &grid);
  for (int i = 0; i < dilate; ++i) grid = DilateOnce(mesh, grid, width, height);

  Atlas atlas;
  atlas.width = width;
  atlas.height = height;
  atlas.index.assign(grid.size(), -1);
  std::vector<size_t> claimed;  // row-major order, so texel order is deterministic
  for (size_t i = 0; i < grid.size(); ++i)
    if (grid[i].prim >= 0) {
      atlas.index[i] = int(claimed.size());
      claimed.push_back(i);
    }
  atlas.texels.resize(claimed.size());
  ParallelFor(long(claimed.size()), 0, [&](long k) {
    const size_t i = claimed[k];
    atlas.texels[k] = MakeTexel(mesh, int(i % width), int(i / width), grid[i]);
  }, 1024);
  return atlas;
}

// Layout: a g x g grid of square cells of c texels (g = ceil(sqrt(faces))).
// Each triangle lives in the (c-2) x (c-2) interior of its cell; the one-texel
// ring around it is gutter, so two charts are at least two texels apart and a
// dilation of 1 never reaches another chart's texels. The triangle is scaled
// isometrically (its shape is kept): longest edge along +u at the bottom of the
// interior, apex above it, which keeps the 3D winding counter-clockwise in UV.
// The only distortion: slivers are thickened to at least one texel of height
// so that every triangle covers at least one texel centre.
Mesh MakeTrivialAtlasUVs(const Mesh& mesh, int resolution) {
  const int n = int(mesh.faces.size());
  if (n == 0) throw Error("MakeTrivialAtlasUVs: mesh has no faces");
  const int g = int(std::ceil(std::sqrt(double(n))));
  const int cell = resolution / g;
  if (cell < 3)
    throw Error(Msg("MakeTrivialAtlasUVs: resolution ", resolution, " too small for ", n,
                    " triangles (need at least ", 3 * g, ")"));
  const double inner = cell - 2;

  Mesh out = mesh;
  out.texcoords.resize(size_t(3) * n);
  out.face_uvs.resize(n);
  const auto to_uv = [&](double tx, double ty) { return Vec2(tx / resolution, 1.0 - ty / resolution); };
  for (int f = 0; f < n; ++f) {
    const Vec3i& face = mesh.faces[f];
    // Base edge k -> k+1 is the longest one, so the apex projects inside it.
    int k = 0;
    double len[3];
    for (int j = 0; j < 3; ++j) len[j] = (mesh.positions[face[(j + 1) % 3]] - mesh.positions[face[j]]).norm();
    for (int j = 1; j < 3; ++j)
      if (len[j] > len[k]) k = j;
    const Vec3& a = mesh.positions[face[k]];
    const Vec3 base = mesh.positions[face[(k + 1) % 3]] - a, apex = mesh.positions[face[(k + 2) % 3]] - a;
    const double L = len[k];
    const double scale = L > 0 ? inner / L : 0.0;
    const double along = L > 0 ? apex.dot(base) / L : 0.0;
    const double height = std::max(L > 0 ? base.cross(apex).norm() / L * scale : 0.0, std::min(1.0, inner));

    const double x0 = (f % g) * cell + 1.0, y_base = (f / g) * cell + 1.0 + inner;  // texel coords, y down
    const Vec2 corners[3] = {to_uv(x0, y_base), to_uv(x0 + L * scale, y_base),
                             to_uv(x0 + along * scale, y_base - height)};
    for (int j = 0; j < 3; ++j) out.texcoords[3 * f + (k + j) % 3] = corners[j];
    out.face_uvs[f] = Vec3i(3 * f, 3 * f + 1, 3 * f + 2);
  }
  return out;
}

Vec2 TexelUv(const Mesh& mesh, const Texel& t) {
  const Vec3i& f = mesh.face_uvs[size_t(t.prim)];
  return (1 - t.b1 - t.b2) * mesh.texcoords[f[0]] + t.b1 * mesh.texcoords[f[1]] + t.b2 * mesh.texcoords[f[2]];
}

}  // namespace svbrdf
