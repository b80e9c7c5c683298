// EvalModel for any scalar (double, ceres::Jet): unpacks the parameter vector
// into the family's value class and evaluates it.
#pragma once
#include "brdf/model.h"
#include "brdf/model_layout.h"

namespace svbrdf {

template <class T>
void EvalModel(const ModelSpec& spec, const T* p, const Vec3T<T>& wi, const Vec3T<T>& wo, T* rgb) {
  if (!(wi.z() > T(0)) || !(wo.z() > T(0))) {
    rgb[0] = rgb[1] = rgb[2] = T(0);
    return;
  }
  brdf::WithModel<T>(spec, [&](auto& model) {
    brdf::ParamReader<T> reader{p};
    brdf::VisitParams(reader, spec, model);
    const brdf::RgbT<T> v = model.f(wi, wo);
    for (int c = 0; c < 3; ++c) rgb[c] = v[c];
  });
}

}  // namespace svbrdf
