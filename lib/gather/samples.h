// Per-texel BRDF samples, structure of arrays in float32 (compact: 44 bytes a
// sample). Samples are sorted by texel; texel t owns [texel_begin[t], texel_begin[t+1]).
//
// Measurement model for sample s of texel t, channel c:
//     y[c][s] = f_c(wi[s], wo[s]) * geom[s]
// where f is the BRDF (1/sr) in the texel's local frame (z = normal),
// y = pixel / (exposure * light intensity_c) (light intensity in W/sr, or the
// irradiance of a directional light), and geom = cos(theta_i) / r^2 (cos(theta_i)
// for directional lights, times the spot/goniometric angular factor).
// Residuals of fits are therefore in units of reflected radiance per unit light.
#pragma once
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/types.h"

namespace svbrdf {

struct SampleSet {
  int num_texels = 0;
  std::vector<int64_t> texel_begin;       // num_texels + 1 offsets
  std::vector<int32_t> texel;             // texel index per sample (into Atlas::texels)
  std::vector<int32_t> image;             // image index per sample (into Scene::images)
  std::vector<float> wi[3], wo[3];        // unit directions, local frame
  std::vector<float> geom;
  std::vector<float> y[3];
  // Footprint sub-samples (GatherOptions::footprint_subsamples): the photo
  // value is a bilinear lookup of four pixels, each integrating the surface
  // over its area, so the sample is predicted as the weighted mean of the
  // BRDF under the shading normals its lookup's rays meet, in a quadrature
  // of kFootprintSubsamples entries (a, b, w) per sample
  // (gather/footprint_quadrature.h): a normal as the tilt
  // normalize(a, b, 1) of the sample's local frame, and its weight (the
  // weights sum to 1; w = 0: unused). Empty: the texel-centre normal only.
  static constexpr int kFootprintSubsamples = 4;
  std::vector<float> footprint;  // 3 * kFootprintSubsamples floats per sample
  bool HasFootprint() const { return !footprint.empty(); }

  int64_t size() const { return static_cast<int64_t>(geom.size()); }
  void Reserve(int64_t n);
  void Push(int32_t t, int32_t img, const float wi_[3], const float wo_[3], float g, const float y_[3]);
};

// Directions wi, wo of a sample's local frame in the frame of the tilted
// normal normalize(a, b, 1) (tangent: x made orthogonal to it, as relight's
// dP/du) and the ratio cos_i(tilted) / cos_i(local). False when the light or
// the viewer is below the tilted surface. Any scalar (ceres::Jet for the
// normal fits, lib/normals/normal_cost.h).
template <class T>
bool TiltedSampleDirections(const Vec3T<T>& wi, const Vec3T<T>& wo, const T& a, const T& b, Vec3T<T>* wi_t,
                            Vec3T<T>* wo_t, T* cos_ratio) {
  using std::sqrt;
  const T inv = T(1) / sqrt(a * a + b * b + T(1));
  const Vec3T<T> n(a * inv, b * inv, inv);
  // Tangent: (1, 0, 0) made orthogonal to n; |t|^2 = 1 - n_x^2 > 0 since n_z > 0.
  Vec3T<T> t(T(1) - n.x() * n.x(), -n.x() * n.y(), -n.x() * n.z());
  t /= sqrt(t.squaredNorm());
  const Vec3T<T> bt = n.cross(t);
  *wi_t = Vec3T<T>(wi.dot(t), wi.dot(bt), wi.dot(n));
  *wo_t = Vec3T<T>(wo.dot(t), wo.dot(bt), wo.dot(n));
  *cos_ratio = wi_t->z() / wi.z();
  return wi_t->z() > T(0) && wo_t->z() > T(0);
}

// The samples s with keep[s] != 0 (keep.size() == samples.size()), still sorted by texel.
SampleSet KeepSamples(const SampleSet& samples, const std::vector<char>& keep);

}  // namespace svbrdf
