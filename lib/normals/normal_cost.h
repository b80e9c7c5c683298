// The measurement model of one BRDF sample under a tilted shading normal, and
// the Ceres cost functors of the per-texel normal fit (internal to
// lib/normals and its tests; templated on the scalar so ceres::Jet flows through).
//
// Samples (lib/gather/samples.h) are stored in the texel's mesh frame: z is
// the interpolated mesh normal n0, x the UV tangent t, y = n0 x t. The
// refined normal is parametrised on the tangent plane by two numbers (a, b):
//     n(a, b) = normalize(a t + b s + n0)      (local: normalize(a, b, 1)),
// so (a, b) = (0, 0) is the mesh normal, every direction of the upper
// hemisphere has exactly one (a, b), and tan(tilt) = |(a, b)|.
// The shading frame keeps the tangent direction (Gram-Schmidt of t against n),
// as relight does with the face's dP/du, so anisotropic models stay aligned.
//
// A sample measured y_c = f_c(wi, wo) cos_i(n) s and gather stored
// geom = cos_i(n0) s, hence under the normal n the prediction is
//     y_c = sum_k w_kc f_kc(wi', wo') geom cos_i(n) / cos_i(n0),
// with wi', wo' the directions in the tilted frame.
#pragma once
#include <cmath>
#include <vector>

#include "brdf/model.h"
#include "brdf/model_eval.h"
#include "core/error.h"
#include "gather/samples.h"

namespace svbrdf::normals {

// One sample of a texel, in its mesh frame (copied from the SampleSet).
struct TexelSample {
  double wi[3], wo[3];
  double geom;
  double y[3];
  // Added to (a, b) for this sample: a neighbour's sample pooled into a
  // texel's fit is predicted under the neighbour's normal relative to the
  // texel's (0 for the texel's own samples).
  double offset[2] = {0, 0};
  // Footprint sub-samples (SampleSet::footprint): the sample is the weighted
  // mean over its footprint's normals, each a tilt (a, b) of the mesh
  // frame added to the texel's; num_sub = 0: the texel's normal only.
  static constexpr int kMaxSub = SampleSet::kFootprintSubsamples;
  double sub[kMaxSub][3] = {};  // a, b, weight
  int num_sub = 0;
  // Copies sample i's sub-samples (those of weight > 0) from `set`.
  void SetFootprint(const SampleSet& set, int64_t i) {
    num_sub = 0;
    if (!set.HasFootprint()) return;
    const float* fp = &set.footprint[size_t(i) * 3 * kMaxSub];
    for (int j = 0; j < kMaxSub; ++j, fp += 3)
      if (fp[2] > 0) sub[num_sub][0] = fp[0], sub[num_sub][1] = fp[1], sub[num_sub][2] = fp[2], ++num_sub;
  }
};

// A basis material with the texel's mixing weights per channel.
struct WeightedBasis {
  const ModelSpec* spec = nullptr;
  std::vector<double> params;
  double w[3] = {0, 0, 0};
};

// Largest parameter vector the functors hold on the stack.
constexpr int kMaxModelParams = 64;

// Directions of a sample in the frame of the normal normalize(a, b, 1) and
// the ratio cos_i(n) / cos_i(n0). Returns false when the light or the viewer
// is below the tilted surface (the sample then predicts black).
template <class T>
bool TiltedDirections(const T* ab_texel, const TexelSample& s, Vec3T<T>* wi, Vec3T<T>* wo, T* cos_ratio,
                      double extra_a = 0, double extra_b = 0) {
  const Vec3T<T> li(T(s.wi[0]), T(s.wi[1]), T(s.wi[2])), lo(T(s.wo[0]), T(s.wo[1]), T(s.wo[2]));
  return TiltedSampleDirections(li, lo, T(ab_texel[0] + (s.offset[0] + extra_a)),
                                T(ab_texel[1] + (s.offset[1] + extra_b)), wi, wo, cos_ratio);
}

// Calls frame(wi, wo, shading) for each direction pair the sample is the
// weighted mean over under the texel's normal (a, b): its footprint
// sub-samples' tilts added to (a, b) (TexelSample::sub), or the texel's
// normal alone; shading = the pair's weight x cos ratio x geom. Pairs below
// the tilted horizon are skipped (they predict black).
template <class T, class Frame>
void ForEachSampleFrame(const T* ab, const TexelSample& s, Frame&& frame) {
  Vec3T<T> wi, wo;
  T ratio;
  if (s.num_sub == 0) {
    if (TiltedDirections(ab, s, &wi, &wo, &ratio)) frame(wi, wo, T(ratio * s.geom));
    return;
  }
  for (int j = 0; j < s.num_sub; ++j)
    if (TiltedDirections(ab, s, &wi, &wo, &ratio, s.sub[j][0], s.sub[j][1])) frame(wi, wo, T(ratio * (s.sub[j][2] * s.geom)));
}

// Value of basis k alone (weight 1) for the directions wi, wo of a sample
// in its tilted frame (times neither cos ratio nor geom).
template <class T>
void EvalBasis(const WeightedBasis& basis, const Vec3T<T>& wi, const Vec3T<T>& wo, T* rgb) {
  const int np = basis.spec->NumParams();
  T p[kMaxModelParams];
  for (int j = 0; j < np; ++j) p[j] = T(basis.params[j]);
  EvalModel(*basis.spec, p, wi, wo, rgb);
}

// Prediction of basis k alone (weight 1) for sample s under normal (a, b).
template <class T>
void PredictBasis(const WeightedBasis& basis, const TexelSample& s, const T* ab, T* rgb) {
  rgb[0] = rgb[1] = rgb[2] = T(0);
  ForEachSampleFrame(ab, s, [&](const Vec3T<T>& wi, const Vec3T<T>& wo, const T& shading) {
    T f[3];
    EvalBasis(basis, wi, wo, f);
    for (int c = 0; c < 3; ++c) rgb[c] += f[c] * shading;
  });
}

// Residuals prediction - measurement (3 channels) of one sample under the
// texel's weighted basis materials; parameter block: (a, b).
// `scale` weighs the sample (residuals times scale): a neighbour's sample
// pooled into the texel's fit counts less than the texel's own.
struct NormalSampleCost {
  const TexelSample* sample;
  const std::vector<WeightedBasis>* basis;
  double scale = 1.0;

  template <class T>
  bool operator()(const T* ab, T* residual) const {
    T sum[3] = {T(0), T(0), T(0)};
    // Each tilted frame once per sample, shared by the basis materials.
    ForEachSampleFrame(ab, *sample, [&](const Vec3T<T>& wi, const Vec3T<T>& wo, const T& shading) {
      for (const WeightedBasis& b : *basis) {
        T rgb[3];
        EvalBasis(b, wi, wo, rgb);
        for (int c = 0; c < 3; ++c) sum[c] += b.w[c] * rgb[c] * shading;
      }
    });
    for (int c = 0; c < 3; ++c) residual[c] = scale * (sum[c] - sample->y[c]);
    return true;
  }
};

// A sample's RGB residual scaled so that its square is the Cauchy loss
// c^2 log(1 + |r|^2 / c^2) (no scaling for c <= 0).
template <class T>
inline void ApplyCauchy(double cauchy, T* r) {
  if (!(cauchy > 0)) return;
  using std::log1p;
  using std::sqrt;
  const T u = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) / (cauchy * cauchy);
  // log1p(u)/u -> 1 as u -> 0; the series avoids 0/0 and its NaN derivative.
  const T f = sqrt(u < T(1e-8) ? T(1.0) - u * 0.5 : log1p(u) / u);
  for (int c = 0; c < 3; ++c) r[c] *= f;
}

// All samples of one texel's normal fit in one residual block (3 residuals
// per sample, then the 2 of the tilt prior): Ceres' per-block overhead and
// allocations are paid once per texel instead of once per sample. Sample i's
// residuals are scaled by sqrt(weight_i) and, with a Cauchy scale c > 0,
// robustified per sample: r_i becomes r_i sqrt(rho(|r_i|^2) / |r_i|^2),
// rho(s) = c^2 log(1 + s / c^2), so that the summed squares are
// sum_i rho(|r_i|^2), the objective of a ceres::CauchyLoss on per-sample blocks.
struct NormalBatchCost {
  const std::vector<TexelSample>* samples;
  const std::vector<const std::vector<WeightedBasis>*>* basis;  // per sample (may be empty)
  const std::vector<double>* weight;
  double cauchy = 0;       // c; 0 = plain least squares
  double prior_scale = 0;  // TiltPrior scale
  // The prior's centre: (0, 0) is the mesh normal; a prior towards the mesh
  // normal and one towards the neighbours' tilts sum to one Gaussian
  // centred between them (refine.cc, smooth_tilt).
  double prior_mean[2] = {0, 0};

  template <class T>
  bool operator()(const T* ab, T* residual) const {
    using std::log1p;
    using std::sqrt;
    const size_t n = samples->size();
    for (size_t i = 0; i < n; ++i) {
      T* r = residual + 3 * i;
      if ((*basis)[i]->empty()) {
        r[0] = r[1] = r[2] = T(0);
        continue;
      }
      NormalSampleCost{&(*samples)[i], (*basis)[i], sqrt((*weight)[i])}(ab, r);
      ApplyCauchy(cauchy, r);
    }
    residual[3 * n] = prior_scale * (ab[0] - prior_mean[0]);
    residual[3 * n + 1] = prior_scale * (ab[1] - prior_mean[1]);
    return true;
  }
};

// Gaussian prior of the tilt towards the mesh normal: residuals scale * (a, b),
// scale = noise sigma / prior sigma of tan(tilt) (see refine.h).
struct TiltPrior {
  double scale;
  template <class T>
  bool operator()(const T* ab, T* residual) const {
    residual[0] = scale * ab[0];
    residual[1] = scale * ab[1];
    return true;
  }
};

// Throws when a model has more parameters than the functors hold.
inline void CheckParamCount(const ModelSpec& spec) {
  if (spec.NumParams() > kMaxModelParams)
    throw Error(Msg("normal refinement: model ", spec.Label(), " has ", spec.NumParams(), " parameters, at most ",
                    kMaxModelParams, " supported"));
}

}  // namespace svbrdf::normals
