// Texel atlas: coverage, geometry at texel centres, dilation and trivial UVs.
#include "atlas/atlas.h"
#include "atlas/charts.h"
#include "atlas/surface_neighbours.h"

#include <gtest/gtest.h>

#include "test_meshes.h"

#include <functional>
#include <map>
#include <numeric>
#include <random>
#include <set>

#include "core/error.h"

namespace svbrdf {
namespace {

Vec2 TexelUv(int x, int y, int w, int h) { return Vec2((x + 0.5) / w, 1 - (y + 0.5) / h); }

// Planar patch P(u, v) = origin + u * du + v * dv, UVs spanning [0,1]^2.
Mesh Patch(const Vec3& origin, const Vec3& du, const Vec3& dv) {
  Mesh m;
  m.positions = {origin, origin + du, origin + du + dv, origin + dv};
  m.faces = {Vec3i(0, 1, 2), Vec3i(0, 2, 3)};
  m.texcoords = {Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(0, 1)};
  m.face_uvs = m.faces;
  return m;
}

// A bumpy n x n height field: many triangles of varied shape, no UVs.
Mesh HeightField(int n) {
  Mesh m;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> z(-0.3, 0.3), jitter(-0.3, 0.3);
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) m.positions.emplace_back(j + jitter(rng), i + jitter(rng), z(rng));
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const int a = i * (n + 1) + j, b = a + 1, c = a + n + 1, d = c + 1;
      m.faces.emplace_back(a, b, d);
      m.faces.emplace_back(a, d, c);
    }
  return m;
}

TEST(Atlas, FullQuadCoversAllTexelsAtBilinearPositions) {
  const Vec3 origin(1, 2, 3), du(2, 0, 0), dv(0, 1, 0.5);
  const int w = 40, h = 30;
  const Atlas atlas = BuildAtlas(Patch(origin, du, dv), w, h, 1);
  ASSERT_EQ(int(atlas.texels.size()), w * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      ASSERT_GE(atlas.At(x, y), 0);
      const Texel& t = atlas.texels[atlas.At(x, y)];
      EXPECT_EQ(t.x, x);
      EXPECT_EQ(t.y, y);
      EXPECT_TRUE(t.interior);
      const Vec2 uv = TexelUv(x, y, w, h);
      EXPECT_NEAR((t.position - (origin + uv.x() * du + uv.y() * dv)).norm(), 0, 1e-12);
      EXPECT_NEAR((t.normal - du.cross(dv).normalized()).norm(), 0, 1e-12);  // no normals: face normal
    }
}

TEST(Atlas, HalfSquareTriangleCoversHalfTheTexels) {
  Mesh m;
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  m.faces = {Vec3i(0, 1, 2)};
  m.texcoords = {Vec2(0, 0), Vec2(1, 0), Vec2(0, 1)};
  m.face_uvs = m.faces;
  const int n = 64;
  const Atlas atlas = BuildAtlas(m, n, n, 0);
  EXPECT_NEAR(double(atlas.texels.size()) / (n * n), 0.5, 1.0 / n);
  for (const Texel& t : atlas.texels) {
    const Vec2 uv = TexelUv(t.x, t.y, n, n);
    EXPECT_LE(uv.x() + uv.y(), 1 + 1e-9);  // only centres inside the triangle
    EXPECT_TRUE(t.interior);
  }
}

TEST(Atlas, DilationAddsBorderTexelsClampedIntoTheTriangle) {
  Mesh m;
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  m.faces = {Vec3i(0, 1, 2)};
  m.texcoords = {Vec2(0.25, 0.25), Vec2(0.75, 0.25), Vec2(0.25, 0.75)};
  m.face_uvs = m.faces;
  const int n = 32, dilate = 2;
  const Atlas plain = BuildAtlas(m, n, n, 0);
  const Atlas atlas = BuildAtlas(m, n, n, dilate);
  ASSERT_GT(atlas.texels.size(), plain.texels.size());
  int border = 0;
  for (const Texel& t : atlas.texels) {
    ASSERT_TRUE(t.x >= 0 && t.x < n && t.y >= 0 && t.y < n);
    EXPECT_EQ(&t, &atlas.texels[atlas.At(t.x, t.y)]);
    EXPECT_EQ(t.interior, plain.At(t.x, t.y) >= 0);
    // Clamped barycentrics keep the surface point on the triangle.
    EXPECT_TRUE(t.b1 >= 0 && t.b2 >= 0 && t.b1 + t.b2 <= 1 + 1e-12);
    EXPECT_NEAR(t.position.z(), 0, 1e-12);
    if (t.interior) continue;
    ++border;
    // A border texel is at most `dilate` texels (Chebyshev) from a covered one.
    bool near_interior = false;
    for (const Texel& s : plain.texels)
      near_interior |= std::max(std::abs(s.x - t.x), std::abs(s.y - t.y)) <= dilate;
    EXPECT_TRUE(near_interior) << t.x << "," << t.y;
  }
  EXPECT_EQ(border, int(atlas.texels.size() - plain.texels.size()));
}

TEST(Atlas, TangentIsDpDu) {
  // Skewed, tilted patch: dP/du = du, which is not orthogonal to dv.
  const Vec3 du(1, 0.5, 0.2), dv(0.3, 1, -0.4);
  const Mesh m = Patch(Vec3::Zero(), du, dv);
  const Atlas atlas = BuildAtlas(m, 8, 8);
  for (const Texel& t : atlas.texels) {
    EXPECT_NEAR((t.tangent - du.normalized()).norm(), 0, 1e-12);
    EXPECT_NEAR(t.tangent.dot(t.normal), 0, 1e-12);
  }
  // With smooth normals tilted off the face, the tangent is dP/du projected.
  Mesh tilted = m;
  const Vec3 n = (du.cross(dv).normalized() + Vec3(0.3, 0, 0)).normalized();
  tilted.normals.assign(4, n);
  for (const Texel& t : BuildAtlas(tilted, 8, 8).texels) {
    EXPECT_NEAR((t.normal - n).norm(), 0, 1e-12);
    EXPECT_NEAR((t.tangent - (du - n * n.dot(du)).normalized()).norm(), 0, 1e-12);
  }
}

TEST(Atlas, RequiresUvs) {
  Mesh m = Patch(Vec3::Zero(), Vec3(1, 0, 0), Vec3(0, 1, 0));
  m.face_uvs.clear();
  EXPECT_THROW(BuildAtlas(m, 8, 8), Error);
}

TEST(Atlas, TrivialUvsGiveEveryTriangleItsOwnTexels) {
  const Mesh mesh = HeightField(12);  // 288 triangles
  const int res = 512;
  const Mesh uv = MakeTrivialAtlasUVs(mesh, res);
  ASSERT_EQ(uv.face_uvs.size(), mesh.faces.size());
  for (const Vec2& t : uv.texcoords) EXPECT_TRUE(t.minCoeff() >= 0 && t.maxCoeff() <= 1);

  // Interior texels: every triangle has some; with dilation 1, no texel
  // (interior or gutter) touches another triangle's interior texels.
  const Atlas atlas = BuildAtlas(uv, res, res, 1);
  std::set<int> covered;
  for (const Texel& t : atlas.texels) {
    if (t.interior) covered.insert(t.prim);
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int x = t.x + dx, y = t.y + dy;
        if (x < 0 || y < 0 || x >= res || y >= res || atlas.At(x, y) < 0) continue;
        const Texel& s = atlas.texels[atlas.At(x, y)];
        if (s.interior) {
          ASSERT_EQ(s.prim, t.prim) << "texel " << t.x << "," << t.y;
        }
      }
  }
  EXPECT_EQ(covered.size(), mesh.faces.size());
}

TEST(Atlas, TrivialUvsPreserveTriangleShape) {
  const Mesh mesh = HeightField(3);
  const Mesh uv = MakeTrivialAtlasUVs(mesh, 256);
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    double ratio[3];
    for (int k = 0; k < 3; ++k) {
      const int k1 = (k + 1) % 3;
      ratio[k] = (uv.texcoords[uv.face_uvs[f][k1]] - uv.texcoords[uv.face_uvs[f][k]]).norm() /
                 (mesh.positions[mesh.faces[f][k1]] - mesh.positions[mesh.faces[f][k]]).norm();
    }
    EXPECT_NEAR(ratio[1] / ratio[0], 1, 1e-9);  // similarity: one scale for all edges
    EXPECT_NEAR(ratio[2] / ratio[0], 1, 1e-9);
    // Counter-clockwise in UV, like the 3D winding seen from the normal side.
    const Vec2 a = uv.texcoords[uv.face_uvs[f][0]];
    const Vec2 e1 = uv.texcoords[uv.face_uvs[f][1]] - a, e2 = uv.texcoords[uv.face_uvs[f][2]] - a;
    EXPECT_GT(e1.x() * e2.y() - e1.y() * e2.x(), 0);
  }
}

TEST(Atlas, TrivialUvsRejectTooSmallResolution) {
  EXPECT_THROW(MakeTrivialAtlasUVs(HeightField(12), 40), Error);
}

// ---- Chart atlas (atlas/charts.h) on a real scan: the Stanford bunny from
// CGAL's data (Debian libcgal-demo), decimated to 2.7 k triangles by
// scripts/scan_mesh.py bunny00 --faces 3000.

Mesh BunnyScan() { return LoadMesh(std::string(SVBRDF_SOURCE_DIR) + "/tests/data/bunny_3k.obj"); }

double Area3(const Mesh& m, int f) {
  const Vec3i& v = m.faces[f];
  return 0.5 * (m.positions[v[1]] - m.positions[v[0]]).cross(m.positions[v[2]] - m.positions[v[0]]).norm();
}

// Signed UV area of face f in texels^2 (positive: counter-clockwise in uv).
double UvArea(const Mesh& m, int f, int side) {
  const Vec3i& t = m.face_uvs[f];
  const Vec2 a = m.texcoords[t[0]] * side, b = m.texcoords[t[1]] * side, c = m.texcoords[t[2]] * side;
  return 0.5 * ((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
}

// Chart id per face: connected components of shared texture coordinates.
std::vector<int> ChartIds(const Mesh& m) {
  std::vector<int> parent(m.texcoords.size());
  std::iota(parent.begin(), parent.end(), 0);
  std::function<int(int)> find = [&](int i) { return parent[i] == i ? i : parent[i] = find(parent[i]); };
  for (const Vec3i& t : m.face_uvs)
    for (int k = 1; k < 3; ++k) parent[find(t[k])] = find(t[0]);
  std::vector<int> id(m.faces.size());
  for (size_t f = 0; f < m.faces.size(); ++f) id[f] = find(m.face_uvs[f][0]);
  return id;
}

struct ChartAtlasCase {
  Mesh mesh;
  ChartAtlasInfo info;
  ChartAtlasOptions options;
};

ChartAtlasCase MakeBunnyAtlas() {
  ChartAtlasCase c;
  const Mesh scan = BunnyScan();
  double area = 0;
  for (int f = 0; f < int(scan.faces.size()); ++f) area += Area3(scan, f);
  c.options.texel_size = std::sqrt(area / (200.0 * 200.0));  // ~40 k texels of surface
  c.mesh = MakeChartAtlasUVs(scan, c.options, &c.info);
  return c;
}

TEST(ChartAtlas, ScanGetsValidUvsAndEveryTriangleIsCovered) {
  const ChartAtlasCase c = MakeBunnyAtlas();
  ASSERT_TRUE(c.mesh.HasUVs());
  EXPECT_NO_THROW(c.mesh.Validate("chart atlas"));
  EXPECT_GT(c.info.charts, 1);
  EXPECT_LT(c.info.charts, int(c.mesh.faces.size()) / 4) << "charts should merge many triangles";
  EXPECT_LE(c.info.resolution, c.options.max_resolution);
  EXPECT_GT(c.info.fill, 0.3) << "packing wastes most of the texture";
  const int side = c.info.resolution;
  const Atlas atlas = BuildAtlas(c.mesh, side, side, 1, true);
  // Every triangle: inside [0,1]^2, counter-clockwise (3D winding kept),
  // and the bilinear footprint of its UV centroid reads only covered texels.
  for (int f = 0; f < int(c.mesh.faces.size()); ++f) {
    const Vec3i& t = c.mesh.face_uvs[f];
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(c.mesh.texcoords[t[k]].minCoeff(), 0.0);
      EXPECT_LE(c.mesh.texcoords[t[k]].maxCoeff(), 1.0);
    }
    if (Area3(c.mesh, f) > 0) {
      EXPECT_GE(UvArea(c.mesh, f, side), -1e-9) << "face " << f << " flipped";
    }
    const Vec2 uv = (c.mesh.texcoords[t[0]] + c.mesh.texcoords[t[1]] + c.mesh.texcoords[t[2]]) / 3.0;
    const Vec2 p = UvToTexel(uv, side, side);
    const int x0 = int(std::floor(p.x() - 0.5)), y0 = int(std::floor(p.y() - 0.5));
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx)
        ASSERT_GE(atlas.At(x0 + dx, y0 + dy), 0) << "face " << f << " reads an uncovered texel";
  }
}

TEST(ChartAtlas, ChartsDoNotOverlapInTexelSpace) {
  const ChartAtlasCase c = MakeBunnyAtlas();
  const int side = c.info.resolution;
  const std::vector<int> chart = ChartIds(c.mesh);
  // Each chart on its own through BuildAtlas (as gather uses it: small
  // triangles covered, one ring of dilation): no texel may belong to two.
  std::map<int, Mesh> parts;
  for (int f = 0; f < int(c.mesh.faces.size()); ++f) {
    Mesh& p = parts[chart[f]];
    if (p.positions.empty()) p.positions = c.mesh.positions, p.texcoords = c.mesh.texcoords;
    p.faces.push_back(c.mesh.faces[f]);
    p.face_uvs.push_back(c.mesh.face_uvs[f]);
  }
  std::vector<int> owner(size_t(side) * side, -1);
  long conflicts = 0;
  for (const auto& [id, part] : parts)
    for (const Texel& t : BuildAtlas(part, side, side, 1, true).texels) {
      int& o = owner[size_t(t.y) * side + t.x];
      if (o >= 0) ++conflicts;
      o = id;
    }
  EXPECT_EQ(conflicts, 0) << "texels claimed by two charts";
}

TEST(ChartAtlas, TexelDensityIsWithinBand) {
  const ChartAtlasCase c = MakeBunnyAtlas();
  const int side = c.info.resolution;
  // Target: one texel per texel_size^2 of surface. Stated band: the whole
  // atlas within 1 % of it, and 90 % of the surface within [0.5, 2] x.
  double surface = 0, texels = 0, inside = 0;
  for (int f = 0; f < int(c.mesh.faces.size()); ++f) {
    const double s = Area3(c.mesh, f) / (c.info.texel_size * c.info.texel_size), u = UvArea(c.mesh, f, side);
    surface += s;
    texels += u;
    if (u > 0.5 * s && u < 2.0 * s) inside += s;
  }
  EXPECT_NEAR(texels / surface, 1.0, 0.01);
  EXPECT_GT(inside / surface, 0.9);
  EXPECT_GE(c.info.texel_size, c.options.texel_size);
}

TEST(ChartAtlas, TexelSizeGrowsToFitTheCap) {
  ChartAtlasOptions o;
  o.texel_size = 1e-4;  // far too fine for 64^2
  o.max_resolution = 200;
  ChartAtlasInfo info;
  const Mesh m = MakeChartAtlasUVs(BunnyScan(), o, &info);
  EXPECT_LE(info.resolution, 200);
  EXPECT_GT(info.texel_size, o.texel_size);
  EXPECT_TRUE(m.HasUVs());
  o.texel_size = -1;
  EXPECT_THROW(MakeChartAtlasUVs(BunnyScan(), o, &info), Error);
}


TEST(ChartAtlas, SmallChartsJoinTheirNeighbours) {
  // Growing by normal cone leaves crumbs (one or a few triangles whose
  // neighbours went to charts whose mean normal had turned away) and the
  // cuts of charts that are not disks leave small pieces; each chart adds a
  // ring of border texels. Merged, the same scan needs far fewer charts,
  // and no more of them stay below the size limit than without merging.
  ChartAtlasCase merged = MakeBunnyAtlas();
  ChartAtlasOptions o = merged.options;
  o.min_chart_texels = 0;
  ChartAtlasInfo plain;
  const Mesh m = MakeChartAtlasUVs(BunnyScan(), o, &plain);
  EXPECT_LT(merged.info.charts, plain.charts * 3 / 4) << plain.charts << " charts without merging";
  const auto small_charts = [&](const Mesh& mesh, double texel) {
    std::map<int, double> area;
    const std::vector<int> id = ChartIds(mesh);
    for (int f = 0; f < int(mesh.faces.size()); ++f) area[id[f]] += Area3(mesh, f) / (texel * texel);
    return std::count_if(area.begin(), area.end(), [&](const auto& a) { return a.second < merged.options.min_chart_texels; });
  };
  EXPECT_LT(small_charts(merged.mesh, merged.info.texel_size), small_charts(m, plain.texel_size));
  o.min_chart_texels = -1;
  EXPECT_THROW(MakeChartAtlasUVs(BunnyScan(), o, &plain), Error);
}

// ---- Texel neighbours on the surface (atlas/surface_neighbours.h).

using test_meshes::TwoChartStrip;  // tests/test_meshes.h

TEST(SurfaceNeighbours, NearestKnownTexelCrossesChartSeams) {
  const Atlas atlas = BuildAtlas(TwoChartStrip(), 40, 40, 1);
  EXPECT_NEAR(MedianTexelSpacing(atlas), 1.0 / 16, 1e-9);  // 0.4 of 40 texels per unit
  const int nt = int(atlas.texels.size());
  std::vector<char> known(nt), want(nt);
  for (int t = 0; t < nt; ++t) {
    known[t] = atlas.texels[t].interior && atlas.texels[t].x < 20;  // chart A's own texels
    want[t] = atlas.texels[t].x >= 20;                              // every texel of chart B
  }
  const std::vector<int> from = NearestKnownTexels(atlas, known, want);
  const std::vector<int> near = NearestKnownTexels(atlas, known, want, 2.0);
  int checked = 0;
  for (int t = 0; t < nt; ++t) {
    if (!want[t]) {
      EXPECT_EQ(from[t], -1);
      continue;
    }
    ASSERT_GE(from[t], 0);
    const Texel& tx = atlas.texels[t];
    const Texel& u = atlas.texels[from[t]];
    EXPECT_TRUE(known[from[t]]);
    // The nearest known texel on the surface is A's texel at the seam (x
    // near 1, same height), however far B's texel lies from the seam.
    EXPECT_NEAR(u.position.x(), 1.0 - 0.5 / 16, 1e-6) << "texel " << tx.x << "," << tx.y;
    EXPECT_NEAR(u.position.y(), tx.position.y(), 0.5 / 16 + 1e-9);
    const double d = (u.position - tx.position).norm();
    EXPECT_EQ(near[t] >= 0, d <= 2.0 / 16 + 1e-9) << "distance " << d * 16 << " texels";
    ++checked;
  }
  EXPECT_GT(checked, 200);
}

TEST(SurfaceNeighbours, PrefersTexelsFacingTheSameSide) {
  // A thin plate: two parallel squares 0.01 apart facing away from each
  // other. The back's texels are nearer in 3D than the front's neighbours,
  // but face the other way.
  Mesh m;
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0),
                 Vec3(0, 0, -0.01), Vec3(1, 0, -0.01), Vec3(1, 1, -0.01), Vec3(0, 1, -0.01)};
  m.faces = {Vec3i(0, 1, 2), Vec3i(0, 2, 3), Vec3i(4, 6, 5), Vec3i(4, 7, 6)};
  m.texcoords = {Vec2(0.05, 0.05), Vec2(0.45, 0.05), Vec2(0.45, 0.45), Vec2(0.05, 0.45),
                 Vec2(0.55, 0.05), Vec2(0.95, 0.05), Vec2(0.95, 0.45), Vec2(0.55, 0.45)};
  m.face_uvs = m.faces;
  m.face_uvs[2] = Vec3i(4, 5, 6), m.face_uvs[3] = Vec3i(4, 6, 7);  // back: counter-clockwise in uv too
  m.ComputeNormals();
  const Atlas atlas = BuildAtlas(m, 40, 40, 1);
  const int nt = int(atlas.texels.size());
  std::vector<char> known(nt), want(nt);
  for (int t = 0; t < nt; ++t) {
    const Texel& tx = atlas.texels[t];
    const bool front = tx.normal.z() > 0;
    known[t] = front ? tx.interior && (tx.x + tx.y) % 2 == 0 : tx.interior;  // half the front, all the back
    want[t] = front && !known[t];
  }
  const std::vector<int> from = NearestKnownTexels(atlas, known, want);
  int checked = 0;
  for (int t = 0; t < nt; ++t)
    if (want[t]) {
      ASSERT_GE(from[t], 0);
      EXPECT_GT(atlas.texels[from[t]].normal.z(), 0) << "took a texel of the other side";
      ++checked;
    }
  EXPECT_GT(checked, 50);
}

}  // namespace
}  // namespace svbrdf
