// Per-texel fit of glTF metallic-roughness parameters (see gltf.h).
#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"
#include "export/directions.h"
#include "export/gltf.h"
#include "export/gltf_brdf.h"
#include "export/nearest_form.h"

namespace svbrdf {

void GltfExportOptions::Check() const {
  if (metallic_steps < 2 || metallic_steps > 1001) throw Error("export: metallic_steps must be in [2, 1001]");
  if (roughness_steps < 2 || roughness_steps > 1001) throw Error("export: roughness_steps must be in [2, 1001]");
}

std::vector<GltfTexel> FitGltfTexels(const Material& m, const GltfExportOptions& o) {
  o.Check();
  const DirectionPairs d = DirectionPairs::Standard(20, 12);
  const size_t n = d.size();
  const int K = static_cast<int>(m.basis.size());
  // Features of each basis material: F[k][3 j + c].
  std::vector<std::vector<double>> F;
  for (const BasisMaterial& b : m.basis) F.push_back(BrdfFeatures(b.spec, b.params, d));
  // Gram of the basis features per channel: FF[(k K + l) 3 + c].
  std::vector<double> FF(size_t(K) * K * 3, 0.0);
  for (int k = 0; k < K; ++k)
    for (int l = 0; l < K; ++l)
      for (size_t j = 0; j < n; ++j)
        for (int c = 0; c < 3; ++c) FF[(k * K + l) * 3 + c] += F[k][3 * j + c] * F[l][3 * j + c];

  // Grid of (metallic, roughness) with the affine parts' inner products.
  struct GridPoint {
    double metallic, roughness, aa, ac, cc;
    std::vector<double> af, cf;  // [k 3 + c]
  };
  std::vector<GridPoint> grid;
  for (int im = 0; im < o.metallic_steps; ++im)
    for (int ir = 0; ir < o.roughness_steps; ++ir) grid.push_back(
        {double(im) / (o.metallic_steps - 1), 0.03 + 0.97 * ir / (o.roughness_steps - 1), 0, 0, 0, {}, {}});
  // Basis materials that are glTF BRDFs themselves (reconstruct --for gltf)
  // add their own (metallic, roughness): a texel of one such material is then
  // reproduced exactly.
  for (const BasisMaterial& b : m.basis)
    if (b.spec.family == Family::kGltf)
      grid.push_back({BasisParam(b, "metallic"), BasisParam(b, "roughness"), 0, 0, 0, {}, {}});
  ParallelFor(static_cast<long>(grid.size()), o.threads, [&](long gi) {
    GridPoint& g = grid[gi];
    g.af.assign(size_t(K) * 3, 0.0);
    g.cf.assign(size_t(K) * 3, 0.0);
    for (size_t j = 0; j < n; ++j) {
      const GltfAffine f = GltfBrdfAffine(g.metallic, g.roughness, d.wi[j], d.wo[j]);
      const double s = std::sqrt(d.weight[j]) * d.wi[j].z();
      const double a = s * f.a, c = s * f.c;
      g.aa += a * a;
      g.ac += a * c;
      g.cc += c * c;
      for (int k = 0; k < K; ++k)
        for (int ch = 0; ch < 3; ++ch) {
          g.af[k * 3 + ch] += a * F[k][3 * j + ch];
          g.cf[k * 3 + ch] += c * F[k][3 * j + ch];
        }
    }
  });

  std::vector<GltfTexel> out(size_t(m.width) * m.height);
  ParallelFor(m.height, o.threads, [&](long y) {
    std::vector<double> w(size_t(K) * 3);
    for (int x = 0; x < m.width; ++x) {
      GltfTexel& t = out[size_t(y) * m.width + x];
      bool any = false;
      for (int k = 0; k < K; ++k)
        for (int c = 0; c < 3; ++c) any |= (w[k * 3 + c] = m.weights[k].at(x, int(y), c)) != 0;
      if (!any) continue;
      double yy[3] = {0, 0, 0};
      for (int k = 0; k < K; ++k)
        for (int l = 0; l < K; ++l)
          for (int c = 0; c < 3; ++c) yy[c] += w[k * 3 + c] * w[l * 3 + c] * FF[(k * K + l) * 3 + c];
      double best = 1e300;
      for (const GridPoint& g : grid) {
        double err = 0;
        Rgb b;
        for (int c = 0; c < 3; ++c) {
          double ay = 0, cy = 0;
          for (int k = 0; k < K; ++k) ay += w[k * 3 + c] * g.af[k * 3 + c], cy += w[k * 3 + c] * g.cf[k * 3 + c];
          b[c] = g.aa > 0 ? std::clamp((ay - g.ac) / g.aa, 0.0, 1.0) : 0.0;
          err += b[c] * b[c] * g.aa + 2 * b[c] * (g.ac - ay) + g.cc - 2 * cy + yy[c];
        }
        if (err < best) {
          best = err;
          t.base_color = b;
          t.metallic = g.metallic;
          t.roughness = g.roughness;
        }
      }
      const double norm = yy[0] + yy[1] + yy[2];
      t.error = norm > 0 ? std::sqrt(std::max(0.0, best) / norm) : 0.0;
    }
  });
  return out;
}

}  // namespace svbrdf
