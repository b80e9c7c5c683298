#include "normals/normal_map.h"

#include <algorithm>
#include <cmath>

namespace svbrdf {

Image NormalMapImage(const Atlas& atlas, const std::vector<Vec3>& normals) {
  Image img(atlas.width, atlas.height, 3, 0.0f);
  for (size_t t = 0; t < atlas.texels.size() && t < normals.size(); ++t)
    for (int c = 0; c < 3; ++c) img.at(atlas.texels[t].x, atlas.texels[t].y, c) = float(normals[t][c]);
  return img;
}

Vec3 MaterialNormal(const Material& material, const Texel& texel, const Atlas& atlas) {
  if (material.normal_map.width == 0) return texel.normal;
  // Texel centre uv of the atlas, then continuous pixel coordinates of the map.
  const Vec2 uv((texel.x + 0.5) / atlas.width, 1.0 - (texel.y + 0.5) / atlas.height);
  const Vec2 p = UvToTexel(uv, material.normal_map.width, material.normal_map.height);
  Vec3 n;
  for (int c = 0; c < 3; ++c) n[c] = material.normal_map.Bilinear(p.x(), p.y(), c);
  return n.squaredNorm() > 1e-12 ? Vec3(n.normalized()) : texel.normal;
}

NormalErrors CompareNormals(const Atlas& atlas, const std::vector<Vec3>& normals, const Material& truth) {
  NormalErrors out;
  for (size_t t = 0; t < atlas.texels.size() && t < normals.size(); ++t) {
    const Vec3 gt = MaterialNormal(truth, atlas.texels[t], atlas);
    out.degrees.push_back(std::acos(std::clamp(gt.dot(normals[t].normalized()), -1.0, 1.0)) * 180.0 / kPi);
  }
  if (out.degrees.empty()) return out;
  double sum = 0;
  for (double d : out.degrees) sum += d;
  out.mean_deg = sum / out.degrees.size();
  std::vector<double> sorted = out.degrees;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  out.median_deg = sorted[sorted.size() / 2];
  return out;
}

}  // namespace svbrdf
