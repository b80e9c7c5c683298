#include "light/envmap.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace svbrdf {

EnvironmentMap::EnvironmentMap(int width, int height, std::vector<float> rgb, const std::string& context, double scale)
    : width_(width), height_(height), rgb_(std::move(rgb)) {
  if (width < 1 || height < 1 || rgb_.size() != size_t(width) * height * 3)
    throw Error(Msg(context, ": environment map must be a width x height x 3 image"));
  if (!(scale > 0) || !std::isfinite(scale)) throw Error(Msg(context, ": environment scale must be > 0"));
  for (size_t i = 0; i < rgb_.size(); ++i) {
    if (!std::isfinite(rgb_[i]))
      throw Error(Msg(context, ": pixel (", (i / 3) % width, ", ", (i / 3) / width,
                      ") has a non-finite value; an environment map needs finite radiances"));
    // Resampled HDR files carry small negative ringing; it is no light.
    if (rgb_[i] < 0) {
      rgb_[i] = 0;
      ++clamped_negative_;
    }
    rgb_[i] = float(rgb_[i] * scale);
  }
  texel_p_.assign(size_t(width) * height, 0.0);
  row_cdf_.assign(height + 1, 0.0);
  col_cdf_.assign(size_t(height) * (width + 1), 0.0);
  double total = 0;
  for (int y = 0; y < height; ++y) {
    const double sin_t = std::sin(kPi * (y + 0.5) / height);
    double* cdf = &col_cdf_[size_t(y) * (width + 1)];
    for (int x = 0; x < width; ++x) {
      const float* p = &rgb_[(size_t(y) * width + x) * 3];
      const double w = (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]) * sin_t;
      texel_p_[size_t(y) * width + x] = w;
      cdf[x + 1] = cdf[x] + w;
    }
    row_cdf_[y + 1] = row_cdf_[y] + cdf[width];
    total += cdf[width];
  }
  if (!(total > 0)) throw Error(Msg(context, ": environment map is black (no light to sample)"));
  for (double& p : texel_p_) p /= total;
}

Vec2 EnvironmentMap::DirectionToUv(const Vec3& d) {
  double u = std::atan2(d.x(), -d.z()) / (2 * kPi);
  if (u < 0) u += 1;
  return Vec2(u, std::acos(std::clamp(d.y(), -1.0, 1.0)) / kPi);
}

Vec3 EnvironmentMap::UvToDirection(const Vec2& uv) {
  const double phi = 2 * kPi * uv.x(), theta = kPi * uv.y();
  return Vec3(std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi));
}

Rgb EnvironmentMap::Radiance(const Vec3& dir) const {
  const Vec2 uv = DirectionToUv(dir);
  const int x = std::clamp(int(uv.x() * width_), 0, width_ - 1), y = std::clamp(int(uv.y() * height_), 0, height_ - 1);
  const float* p = &rgb_[(size_t(y) * width_ + x) * 3];
  return Rgb(p[0], p[1], p[2]);
}

double EnvironmentMap::TexelProbability(int x, int y) const { return texel_p_[size_t(y) * width_ + x]; }

double EnvironmentMap::Pdf(const Vec3& dir) const {
  const Vec2 uv = DirectionToUv(dir);
  const int x = std::clamp(int(uv.x() * width_), 0, width_ - 1), y = std::clamp(int(uv.y() * height_), 0, height_ - 1);
  const double sin_t = std::sin(kPi * uv.y());
  if (!(sin_t > 0)) return 0;
  // Density in (u, v) is P(texel) * W * H; d(omega) = 2 pi^2 sin(theta) du dv.
  return texel_p_[size_t(y) * width_ + x] * width_ * height_ / (2 * kPi * kPi * sin_t);
}

Vec3 EnvironmentMap::Sample(double u1, double u2, double* pdf) const {
  const double total = row_cdf_[height_];
  // Row from the marginal CDF, then column from the row's conditional CDF;
  // the remainder of each uniform places the point inside the texel.
  const double t1 = u1 * total;
  int y = int(std::upper_bound(row_cdf_.begin(), row_cdf_.end(), t1) - row_cdf_.begin()) - 1;
  y = std::clamp(y, 0, height_ - 1);
  while (y < height_ - 1 && row_cdf_[y + 1] - row_cdf_[y] <= 0) ++y;
  const double row_w = row_cdf_[y + 1] - row_cdf_[y];
  const double fy = std::clamp((t1 - row_cdf_[y]) / row_w, 0.0, 1.0);
  const double* cdf = &col_cdf_[size_t(y) * (width_ + 1)];
  const double t2 = u2 * cdf[width_];
  int x = int(std::upper_bound(cdf, cdf + width_ + 1, t2) - cdf) - 1;
  x = std::clamp(x, 0, width_ - 1);
  while (x < width_ - 1 && cdf[x + 1] - cdf[x] <= 0) ++x;
  const double fx = std::clamp((t2 - cdf[x]) / (cdf[x + 1] - cdf[x]), 0.0, 1.0);
  const Vec2 uv((x + fx) / width_, std::clamp((y + fy) / height_, 1e-9, 1 - 1e-9));
  const Vec3 d = UvToDirection(uv);
  const double sin_t = std::sin(kPi * uv.y());
  *pdf = texel_p_[size_t(y) * width_ + x] * width_ * height_ / (2 * kPi * kPi * sin_t);
  return d;
}

}  // namespace svbrdf
