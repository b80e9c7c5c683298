#include "gather/samples.h"

namespace svbrdf {

void SampleSet::Reserve(int64_t n) {
  texel.reserve(n);
  image.reserve(n);
  geom.reserve(n);
  for (int k = 0; k < 3; ++k) {
    wi[k].reserve(n);
    wo[k].reserve(n);
    y[k].reserve(n);
  }
}

void SampleSet::Push(int32_t t, int32_t img, const float wi_[3], const float wo_[3], float g, const float y_[3]) {
  texel.push_back(t);
  image.push_back(img);
  geom.push_back(g);
  for (int k = 0; k < 3; ++k) {
    wi[k].push_back(wi_[k]);
    wo[k].push_back(wo_[k]);
    y[k].push_back(y_[k]);
  }
}

SampleSet KeepSamples(const SampleSet& samples, const std::vector<char>& keep) {
  SampleSet out;
  out.num_texels = samples.num_texels;
  out.texel_begin.assign(samples.num_texels + 1, 0);
  out.Reserve(samples.size());
  for (int t = 0; t < samples.num_texels; ++t) {
    for (int64_t s = samples.texel_begin[t]; s < samples.texel_begin[t + 1]; ++s) {
      if (!keep[s]) continue;
      const float wi[3] = {samples.wi[0][s], samples.wi[1][s], samples.wi[2][s]};
      const float wo[3] = {samples.wo[0][s], samples.wo[1][s], samples.wo[2][s]};
      const float y[3] = {samples.y[0][s], samples.y[1][s], samples.y[2][s]};
      out.Push(samples.texel[s], samples.image[s], wi, wo, samples.geom[s], y);
      if (samples.HasFootprint())
        out.footprint.insert(out.footprint.end(), samples.footprint.begin() + 3 * SampleSet::kFootprintSubsamples * s,
                             samples.footprint.begin() + 3 * SampleSet::kFootprintSubsamples * (s + 1));
    }
    out.texel_begin[t + 1] = out.size();
  }
  return out;
}

}  // namespace svbrdf
