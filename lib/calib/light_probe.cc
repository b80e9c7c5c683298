#include "calib/light_probe.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace svbrdf {

bool FindHighlight(const Image& img, const Camera& cam, const Rigid3& cam_from_world, const MirrorSphere& s,
                   Vec2* pixel) {
  const Vec3 c = cam_from_world * s.centre;
  if (c.z() <= s.radius) return false;
  const Vec2 centre = cam.Project(c);
  const double r_px = 0.5 * (cam.fx() + cam.fy()) * s.radius / std::sqrt(c.squaredNorm() - s.radius * s.radius);
  // Search inside 90 % of the disc: the rim reflects grazing rays poorly.
  const double search = 0.9 * r_px;
  auto lum = [&](int x, int y) {
    double v = 0;
    for (int k = 0; k < std::min(3, img.channels); ++k) v += img.at(x, y, k);
    return v / std::min(3, img.channels);
  };
  int bx = -1, by = -1;
  double best = 0, sum = 0;
  long n = 0;
  for (int y = int(centre.y() - search); y <= int(centre.y() + search); ++y)
    for (int x = int(centre.x() - search); x <= int(centre.x() + search); ++x) {
      if (x < 0 || y < 0 || x >= img.width || y >= img.height) continue;
      if ((Vec2(x + 0.5, y + 0.5) - centre).norm() > search) continue;
      const double v = lum(x, y);
      sum += v;
      ++n;
      if (v > best) best = v, bx = x, by = y;
    }
  if (bx < 0 || n == 0 || best < 5 * sum / n) return false;
  // Centroid of the spot: pixels above half the peak near the maximum.
  double wx = 0, wy = 0, ws = 0;
  const int win = std::max(2, int(0.15 * r_px));
  for (int y = by - win; y <= by + win; ++y)
    for (int x = bx - win; x <= bx + win; ++x) {
      if (x < 0 || y < 0 || x >= img.width || y >= img.height) continue;
      const double w = lum(x, y) - 0.1 * best;
      if (w <= 0) continue;
      wx += w * (x + 0.5);
      wy += w * (y + 0.5);
      ws += w;
    }
  *pixel = Vec2(wx / ws, wy / ws);
  return true;
}

bool ReflectedRay(const Camera& cam, const Rigid3& cam_from_world, const MirrorSphere& s, const Vec2& pixel,
                  Ray3* ray) {
  const Rigid3 world_from_cam = cam_from_world.Inverse();
  const Vec3 eye = world_from_cam.translation;
  const Vec3 d = (world_from_cam.rotation * cam.Unproject(pixel)).normalized();
  const Vec3 oc = eye - s.centre;
  const double b = oc.dot(d), disc = b * b - (oc.squaredNorm() - s.radius * s.radius);
  if (disc < 0) return false;
  const double t = -b - std::sqrt(disc);
  if (t <= 0) return false;
  const Vec3 x = eye + t * d;
  const Vec3 n = (x - s.centre) / s.radius;
  ray->origin = x;
  ray->direction = (d - 2 * d.dot(n) * n).normalized();
  return true;
}

Vec3 NearestPointToRays(const std::vector<Ray3>& rays, double* rms_m) {
  if (rays.size() < 2) throw Error("light triangulation: need at least two rays");
  Mat3 A = Mat3::Zero();
  Vec3 b = Vec3::Zero();
  for (const Ray3& r : rays) {
    const Mat3 P = Mat3::Identity() - r.direction * r.direction.transpose();
    A += P;
    b += P * r.origin;
  }
  if (A.determinant() < 1e-9 * std::pow(double(rays.size()), 3))
    throw Error("light triangulation: rays are (nearly) parallel; use spheres seen from different places");
  const Vec3 x = A.ldlt().solve(b);
  if (rms_m) {
    double s = 0;
    for (const Ray3& r : rays) s += ((Mat3::Identity() - r.direction * r.direction.transpose()) * (x - r.origin)).squaredNorm();
    *rms_m = std::sqrt(s / rays.size());
  }
  return x;
}

void AppendIntensityEstimates(const std::vector<DiffuseSample>& samples, const Vec3& light, std::vector<Rgb>* est) {
  for (const DiffuseSample& s : samples) {
    const Vec3 to_l = light - s.point;
    const double r2 = to_l.squaredNorm(), cos_i = s.normal.dot(to_l.normalized());
    if (cos_i < 0.2 || s.albedo <= 0 || s.exposure <= 0 || !(s.value.maxCoeff() > 0)) continue;
    est->push_back(s.value * kPi * r2 / (s.exposure * s.albedo * cos_i));
  }
}

Rgb MedianIntensity(const std::vector<Rgb>& est) {
  if (est.empty()) throw Error("light intensity: no usable diffuse reference samples");
  Rgb out;
  std::vector<double> channel(est.size());
  for (int c = 0; c < 3; ++c) {
    for (size_t i = 0; i < est.size(); ++i) channel[i] = est[i][c];
    std::nth_element(channel.begin(), channel.begin() + channel.size() / 2, channel.end());
    out[c] = channel[channel.size() / 2];
  }
  return out;
}

}  // namespace svbrdf
