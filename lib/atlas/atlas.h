// Texel atlas: which surface point each texel of a W x H texture stands for.
// Texel (x, y) has its centre at uv = ((x + 0.5)/W, 1 - (y + 0.5)/H): row 0 is
// the top of the image, v points up as in OBJ. Texels are rasterised from
// the mesh's UV triangles (conservatively dilated by `dilate` texels so
// bilinear lookups at chart borders read valid data).
#pragma once
#include <vector>

#include "core/types.h"
#include "io/mesh.h"

namespace svbrdf {

struct Texel {
  int x = 0, y = 0;
  int prim = -1;          // triangle index
  double b1 = 0, b2 = 0;  // barycentrics in that triangle (clamped inside it)
  bool interior = true;   // false for dilation texels outside every UV triangle
  Vec3 position = Vec3::Zero();
  Vec3 normal = Vec3::Zero();   // interpolated smooth normal, unit
  Vec3 tangent = Vec3::Zero();  // dP/du projected on the tangent plane, unit
};

struct Atlas {
  int width = 0, height = 0;
  std::vector<Texel> texels;   // only covered texels
  std::vector<int> index;      // width*height, texel index or -1
  int At(int x, int y) const { return index[size_t(y) * width + x]; }
};

// Requires mesh.HasUVs(); throws Error otherwise. `cover_small`: a UV triangle
// that contains no texel centre (or whose corners, edge midpoints or centroid
// lie in texels it did not claim) still claims those texels, before dilation:
// every triangle then has data under its bilinear lookups (generated chart
// atlases with triangles smaller than a texel).
Atlas BuildAtlas(const Mesh& mesh, int width, int height, int dilate = 1, bool cover_small = false);

// Gives a mesh without UVs a simple atlas: each triangle gets its own cell in
// a square grid, with a gutter (enough for per-texel reconstruction; charts
// are not merged). Returns the mesh with texcoords/face_uvs filled.
Mesh MakeTrivialAtlasUVs(const Mesh& mesh, int resolution);

// Texture coordinates (in mesh's UVs) of the surface point texel t stands
// for: its triangle and barycentrics. For a texel of any atlas of the same
// triangles.
Vec2 TexelUv(const Mesh& mesh, const Texel& t);

// UV coordinates to continuous texel coordinates (texel centres at +0.5).
inline Vec2 UvToTexel(const Vec2& uv, int width, int height) {
  return Vec2(uv.x() * width, (1.0 - uv.y()) * height);
}

}  // namespace svbrdf
