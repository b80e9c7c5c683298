// Lat-long (equirectangular) HDR environment light, importance sampled.
//
// Directions map to the image as in Mitsuba 3's `envmap` emitter (world +y up):
//   u = atan2(d.x, -d.z) / (2 pi)  (mod 1),   v = acos(d.y) / pi,
// pixel column u W, row v H (row 0 = straight up). Radiance is piecewise
// constant per texel (no filtering), so the sampler below is exact for it:
// texel (i, j) is chosen with probability proportional to its luminance
// times sin(theta) at the row centre (marginal CDF over rows, conditional
// CDF over columns), uniformly within the texel in (u, v), and the density
// per solid angle is p(u, v) / (2 pi^2 sin theta).
#pragma once
#include <string>
#include <vector>

#include "core/types.h"

namespace svbrdf {

class EnvironmentMap {
 public:
  // `rgb`: width*height*3 linear radiances, row-major, row 0 at the top.
  // Negative values (ringing of resampled HDR files) are set to 0 and
  // counted; throws Error naming `context` for non-finite values, a black
  // map or a wrong size.
  EnvironmentMap(int width, int height, std::vector<float> rgb, const std::string& context, double scale = 1.0);

  Rgb Radiance(const Vec3& dir) const;
  // Direction with density Pdf(dir) per solid angle from two uniforms in [0,1).
  Vec3 Sample(double u1, double u2, double* pdf) const;
  double Pdf(const Vec3& dir) const;

  int width() const { return width_; }
  int height() const { return height_; }
  static Vec2 DirectionToUv(const Vec3& dir);
  static Vec3 UvToDirection(const Vec2& uv);
  // Probability that Sample picks texel (x, y) (for tests).
  double TexelProbability(int x, int y) const;
  long clamped_negative() const { return clamped_negative_; }  // values set to 0 (see constructor)

 private:
  int width_, height_;
  std::vector<float> rgb_;
  std::vector<double> row_cdf_;   // height+1
  std::vector<double> col_cdf_;   // height * (width+1)
  std::vector<double> texel_p_;   // width*height, probabilities (sum 1)
  long clamped_negative_ = 0;
};

}  // namespace svbrdf
