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

// Models with terms that depend on the parameters only (e.g. the coat's
// internal diffuse reflectance) compute them once in Prepare().
template <class M>
auto PrepareModel(M& model, int) -> decltype(model.Prepare(), void()) { model.Prepare(); }
template <class M>
void PrepareModel(M&, long) {}

// EvalModel at n direction pairs with one parameter vector: the value class
// is filled (and prepared) once, not per sample, which is what the batched
// fit residuals need. dirs(i, &wi, &wo) gives pair i; rgb holds 3 n values.
template <class T, class Dirs>
void EvalModelBatch(const ModelSpec& spec, const T* p, int n, const Dirs& dirs, T* rgb) {
  brdf::WithModel<T>(spec, [&](auto& model) {
    brdf::ParamReader<T> reader{p};
    brdf::VisitParams(reader, spec, model);
    PrepareModel(model, 0);
    Vec3T<T> wi, wo;
    for (int i = 0; i < n; ++i) {
      dirs(i, &wi, &wo);
      T* out = rgb + 3 * i;
      if (!(wi.z() > T(0)) || !(wo.z() > T(0))) {
        out[0] = out[1] = out[2] = T(0);
        continue;
      }
      const brdf::RgbT<T> v = model.f(wi, wo);
      for (int c = 0; c < 3; ++c) out[c] = v[c];
    }
  });
}

}  // namespace svbrdf
