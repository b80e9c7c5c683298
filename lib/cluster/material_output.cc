#include "cluster/reconstruct.h"

namespace svbrdf {

Material ToMaterial(const SvbrdfEstimate& est, const Atlas& atlas, const Mesh& mesh) {
  Material m;
  m.mesh = mesh;
  m.width = atlas.width;
  m.height = atlas.height;
  m.basis = est.basis;
  const int K = static_cast<int>(est.basis.size());
  for (int k = 0; k < K; ++k) m.weights.emplace_back(atlas.width, atlas.height, 3, 0.0f);
  m.confidence = Image(atlas.width, atlas.height, 1, 0.0f);
  m.material_id = Image(atlas.width, atlas.height, 1, 0.0f);  // texels outside the atlas: 0 (their weights are 0)
  for (size_t t = 0; t < atlas.texels.size(); ++t) {
    const Texel& tx = atlas.texels[t];
    for (int k = 0; k < K; ++k)
      for (int c = 0; c < 3; ++c) m.weights[k].at(tx.x, tx.y, c) = est.weights[(t * K + k) * 3 + c];
    m.confidence.at(tx.x, tx.y, 0) = est.confidence[t];
    m.material_id.at(tx.x, tx.y, 0) = float(est.label[t]);
  }
  return m;
}


}  // namespace svbrdf
