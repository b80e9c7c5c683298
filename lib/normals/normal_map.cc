#include "normals/normal_map.h"

#include <algorithm>
#include <cmath>

namespace svbrdf {

Image NormalMapImage(const Atlas& atlas, const std::vector<Vec3>& normals, NormalMapSpace space) {
  Image img(atlas.width, atlas.height, 3, 0.0f);
  for (size_t t = 0; t < atlas.texels.size() && t < normals.size(); ++t) {
    const Texel& tx = atlas.texels[t];
    const Vec3 v = space == NormalMapSpace::kWorld ? normals[t] : MapValueFromNormal(normals[t], space, tx.normal, tx.tangent);
    for (int c = 0; c < 3; ++c) img.at(tx.x, tx.y, c) = float(v[c]);
  }
  return img;
}

Vec3 MaterialNormal(const Material& material, const Texel& texel, const Atlas& atlas) {
  if (material.normal_map.width == 0) return texel.normal;
  // Texel centre uv of the atlas, then continuous pixel coordinates of the map.
  const Vec2 uv((texel.x + 0.5) / atlas.width, 1.0 - (texel.y + 0.5) / atlas.height);
  const Vec2 p = UvToTexel(uv, material.normal_map.width, material.normal_map.height);
  Vec3 n;
  for (int c = 0; c < 3; ++c) n[c] = material.normal_map.Bilinear(p.x(), p.y(), c);
  return NormalFromMapValue(n, material.normal_map_space, texel.normal, texel.tangent);
}

namespace {
void MeanMedian(const std::vector<double>& v, double* mean, double* median) {
  double sum = 0;
  for (double d : v) sum += d;
  *mean = sum / v.size();
  *median = Median(v);
}
}  // namespace

NormalErrors CompareNormals(const Atlas& atlas, const std::vector<Vec3>& normals, const Material& truth) {
  NormalErrors out;
  for (size_t t = 0; t < atlas.texels.size() && t < normals.size(); ++t) {
    const Vec3 gt = MaterialNormal(truth, atlas.texels[t], atlas);
    out.degrees.push_back(std::acos(std::clamp(gt.dot(normals[t].normalized()), -1.0, 1.0)) * 180.0 / kPi);
  }
  if (out.degrees.empty()) return out;
  MeanMedian(out.degrees, &out.mean_deg, &out.median_deg);
  const Image& id = truth.material_id;
  if (id.width == 0 || id.channels < 1) return out;
  std::vector<std::vector<double>> by;
  for (size_t t = 0; t < out.degrees.size(); ++t) {
    // The truth's id at the texel centre's uv (nearest: ids do not blend).
    const Texel& tx = atlas.texels[t];
    const Vec2 uv((tx.x + 0.5) / atlas.width, 1.0 - (tx.y + 0.5) / atlas.height);
    const Vec2 p = UvToTexel(uv, id.width, id.height);
    const int x = std::clamp(int(std::floor(p.x())), 0, id.width - 1);
    const int y = std::clamp(int(std::floor(p.y())), 0, id.height - 1);
    const double v = id.at(x, y, 0);
    if (!(v >= 0 && v < 256)) continue;
    const size_t k = size_t(v);
    if (by.size() <= k) by.resize(k + 1);
    by[k].push_back(out.degrees[t]);
  }
  out.mean_by_material.assign(by.size(), 0.0);
  out.median_by_material.assign(by.size(), 0.0);
  for (size_t k = 0; k < by.size(); ++k)
    if (!by[k].empty()) MeanMedian(by[k], &out.mean_by_material[k], &out.median_by_material[k]);
  return out;
}

}  // namespace svbrdf
