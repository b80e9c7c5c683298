#include "light/light.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"

namespace svbrdf {
namespace {

// Horizontal angle of `dir_out` (unit, from the light) around `axis`,
// measured from `up` (projected onto the plane normal to the axis) towards
// axis x up, i.e. counter-clockwise when looking along -axis. In [0, 2 pi).
double HorizontalAngle(const Vec3& axis, const Vec3& up, const Vec3& dir_out) {
  Vec3 e0 = up - axis * axis.dot(up);
  if (e0.squaredNorm() < 1e-20) e0 = axis.unitOrthogonal();  // up parallel to the axis: any reference
  e0.normalize();
  const Vec3 e1 = axis.cross(e0);
  double h = std::atan2(dir_out.dot(e1), dir_out.dot(e0));
  if (h < 0) h += 2 * kPi;
  return h;
}

}  // namespace

LightSample SampleLight(const Light& light, const Vec3& x_world, const Eigen::Quaterniond& world_from_cam,
                        const Vec3& cam_centre_world) {
  // A camera-frame light (flash) moves and turns with the camera of the image.
  auto to_world_dir = [&](const Vec3& d) -> Vec3 { return light.camera_frame ? world_from_cam * d : d; };
  LightSample s;
  if (light.type == LightType::kDirectional) {
    s.wi = to_world_dir(light.to_light).normalized();
    s.distance = std::numeric_limits<double>::infinity();
    s.normal_irradiance = light.irradiance;
    return s;
  }
  const Vec3 pos = light.camera_frame ? Vec3(world_from_cam * light.position + cam_centre_world) : light.position;
  const Vec3 d = pos - x_world;
  s.distance = d.norm();
  if (!(s.distance > 0)) return s;  // point on the light: no defined direction, no contribution
  s.wi = d / s.distance;
  const double inv_r2 = 1.0 / (s.distance * s.distance);
  switch (light.type) {
    case LightType::kPoint:
      s.normal_irradiance = light.intensity * inv_r2;
      break;
    case LightType::kSpot: {
      // alpha: angle between the beam axis and the direction from the light to the point.
      const double cos_alpha = to_world_dir(light.direction).normalized().dot(-s.wi);
      const double cos_cutoff = std::cos(light.cutoff_deg * kPi / 180.0);
      // max(0, .) keeps cutoffs beyond 90 degrees finite; pow(0, 0) = 1 for a uniform cone.
      if (cos_alpha >= cos_cutoff)
        s.normal_irradiance = light.intensity * std::pow(std::max(cos_alpha, 0.0), light.exponent) * inv_r2;
      break;
    }
    case LightType::kGoniometric: {
      if (!light.profile) throw Error(Msg("goniometric light ", light.id, ": IES profile '", light.ies, "' not loaded"));
      const Vec3 axis = to_world_dir(light.direction).normalized();
      const Vec3 out = -s.wi;
      const double vertical = std::acos(std::clamp(axis.dot(out), -1.0, 1.0));
      const double horizontal = HorizontalAngle(axis, to_world_dir(light.up), out);
      s.normal_irradiance = Rgb::Constant(light.profile->Intensity(vertical, horizontal) * light.scale * inv_r2);
      break;
    }
    case LightType::kDirectional:
      break;
  }
  return s;
}

}  // namespace svbrdf
