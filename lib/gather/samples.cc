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

}  // namespace svbrdf
