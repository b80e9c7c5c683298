// A fixed quadrature over pairs of directions (light wi, viewer wo) in the
// local shading frame (z = normal), used to compare and fit BRDFs:
//   E(f, g) = sum_j weight_j (f(wi_j, wo_j) - g(wi_j, wo_j))^2 cos^2(theta_i,j)
// approximates the integral over viewing and lighting directions of the
// squared difference of reflected radiance under unit irradiance. Light
// directions are placed through half vectors densely near the normal
// (theta_h = pi/2 t^2), so narrow highlights (exponents up to ~1000) are
// resolved; weights are the solid-angle measure of each sample (Jacobian
// d(wi)/d(h) = 4 <wo|h>).
#pragma once
#include <vector>

#include "brdf/model.h"
#include "core/types.h"

namespace svbrdf {

struct DirectionPairs {
  std::vector<Vec3> wi, wo;
  std::vector<double> weight;  // quadrature weight: solid angle of wi x weight of the view (sum 1 over views)
  size_t size() const { return wi.size(); }

  // Viewing directions at 5 elevations (midpoints of 18-degree steps,
  // weighted by cos sin, i.e. by projected area) and azimuths 0 and 90
  // degrees (so anisotropic lobes are seen along both tangent axes);
  // `theta_steps` x `phi_steps` half vectors per viewing direction.
  static DirectionPairs Standard(int theta_steps = 24, int phi_steps = 16);
};

// Feature vector of a BRDF on the quadrature: entry (j, c) at [3 j + c] is
// sqrt(weight_j) cos(theta_i,j) f_c(wi_j, wo_j), so that squared Euclidean
// distances between feature vectors are E above.
std::vector<double> BrdfFeatures(const ModelSpec& spec, const std::vector<double>& params, const DirectionPairs& d);

// Relative RMSE between two feature vectors: sqrt(|a - b|^2 / |a|^2) (0 when a is 0).
double RelativeFeatureError(const std::vector<double>& reference, const std::vector<double>& test);

}  // namespace svbrdf
