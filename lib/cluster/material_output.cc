#include "cluster/reconstruct.h"

namespace svbrdf {

Material MixedMaterial(const std::vector<BasisMaterial>& basis, const std::vector<float>& weights, const Atlas& atlas,
                       const Mesh& mesh) {
  Material m;
  m.mesh = mesh;
  m.width = atlas.width;
  m.height = atlas.height;
  m.basis = basis;
  const int K = static_cast<int>(basis.size());
  for (int k = 0; k < K; ++k) m.weights.emplace_back(atlas.width, atlas.height, 3, 0.0f);
  for (size_t t = 0; t < atlas.texels.size(); ++t) {
    const Texel& tx = atlas.texels[t];
    for (int k = 0; k < K; ++k)
      for (int c = 0; c < 3; ++c) m.weights[k].at(tx.x, tx.y, c) = weights[(t * K + k) * 3 + c];
  }
  return m;
}

Material ToMaterial(const SvbrdfEstimate& est, const Atlas& atlas, const Mesh& mesh) {
  Material m = MixedMaterial(est.basis, est.weights, atlas, mesh);
  m.confidence = Image(atlas.width, atlas.height, 1, 0.0f);
  m.material_id = Image(atlas.width, atlas.height, 1, 0.0f);  // texels outside the atlas: 0 (their weights are 0)
  for (size_t t = 0; t < atlas.texels.size(); ++t) {
    const Texel& tx = atlas.texels[t];
    m.confidence.at(tx.x, tx.y, 0) = est.confidence[t];
    m.material_id.at(tx.x, tx.y, 0) = float(est.label[t]);
  }
  return m;
}


}  // namespace svbrdf
