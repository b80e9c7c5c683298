#include "camera/camera.h"

#include <cmath>

#include "core/error.h"

namespace svbrdf {
namespace {

struct ModelInfo {
  CameraModelId id;
  const char* name;
  int num_params;
};

// COLMAP's names and parameter counts (colmap/sensor/models.h).
constexpr ModelInfo kModels[] = {
    {CameraModelId::kSimplePinhole, "SIMPLE_PINHOLE", 3}, {CameraModelId::kPinhole, "PINHOLE", 4},
    {CameraModelId::kSimpleRadial, "SIMPLE_RADIAL", 4},   {CameraModelId::kRadial, "RADIAL", 5},
    {CameraModelId::kOpenCV, "OPENCV", 8},        {CameraModelId::kOrthographic, "ORTHOGRAPHIC", 4},
};

const ModelInfo& Info(CameraModelId id) {
  for (const ModelInfo& m : kModels)
    if (m.id == id) return m;
  throw Error(Msg("internal: camera model id ", static_cast<int>(id), " has no entry"));
}

// Models with a single focal length store it first; the others store fx, fy.
bool SingleFocal(CameraModelId id) {
  return id == CameraModelId::kSimplePinhole || id == CameraModelId::kSimpleRadial || id == CameraModelId::kRadial;
}

}  // namespace

CameraModelId CameraModelFromName(const std::string& name, const std::string& context) {
  std::string names;
  for (const ModelInfo& m : kModels) {
    if (name == m.name) return m.id;
    names += names.empty() ? m.name : std::string(", ") + m.name;
  }
  throw Error(Msg(context, ": unknown camera model '", name, "' (expected one of ", names, ")"));
}

std::string CameraModelName(CameraModelId id) { return Info(id).name; }
int CameraModelNumParams(CameraModelId id) { return Info(id).num_params; }

double Camera::fx() const { return params.at(0); }
double Camera::fy() const { return SingleFocal(model) ? params.at(0) : params.at(1); }
double Camera::cx() const { return SingleFocal(model) ? params.at(1) : params.at(2); }
double Camera::cy() const { return SingleFocal(model) ? params.at(2) : params.at(3); }

Vec2 Camera::Distort(const Vec2& xy) const {
  const double u = xy.x(), v = xy.y();
  const double r2 = u * u + v * v;
  switch (model) {
    case CameraModelId::kSimplePinhole:
    case CameraModelId::kPinhole:
    case CameraModelId::kOrthographic:
      return xy;
    case CameraModelId::kSimpleRadial:
      return xy * (1.0 + params[3] * r2);
    case CameraModelId::kRadial:
      return xy * (1.0 + params[3] * r2 + params[4] * r2 * r2);
    case CameraModelId::kOpenCV: {
      // COLMAP's OpenCVCameraModel::Distortion.
      const double k1 = params[4], k2 = params[5], p1 = params[6], p2 = params[7];
      const double radial = k1 * r2 + k2 * r2 * r2;
      const double uv = u * v;
      return Vec2(u + u * radial + 2.0 * p1 * uv + p2 * (r2 + 2.0 * u * u),
                  v + v * radial + 2.0 * p2 * uv + p1 * (r2 + 2.0 * v * v));
    }
  }
  return xy;
}

Vec2 Camera::Undistort(const Vec2& xy) const {
  if (model == CameraModelId::kSimplePinhole || model == CameraModelId::kPinhole || IsOrthographic()) return xy;
  // Newton iterations on Distort(x) = xy with a central-difference Jacobian,
  // as COLMAP's IterativeUndistortion: distortion has no closed-form inverse.
  constexpr int kMaxIterations = 100;
  constexpr double kStep = 1e-7;
  Vec2 x = xy;
  for (int it = 0; it < kMaxIterations; ++it) {
    const Vec2 residual = Distort(x) - xy;
    if (residual.squaredNorm() < 1e-30) break;
    Eigen::Matrix2d J;
    for (int k = 0; k < 2; ++k) {
      const double h = kStep * std::max(1.0, std::abs(x[k]));
      Vec2 xp = x, xm = x;
      xp[k] += h;
      xm[k] -= h;
      J.col(k) = (Distort(xp) - Distort(xm)) / (2.0 * h);
    }
    const Vec2 step = J.partialPivLu().solve(residual);
    if (!step.allFinite()) break;
    x -= step;
    if (step.squaredNorm() < 1e-28 * std::max(1.0, x.squaredNorm())) break;
  }
  return x;
}

Vec2 Camera::Project(const Vec3& x_cam) const {
  if (IsOrthographic()) return Vec2(fx() * x_cam.x() + cx(), fy() * x_cam.y() + cy());
  const Vec2 d = Distort(Vec2(x_cam.x() / x_cam.z(), x_cam.y() / x_cam.z()));
  return Vec2(fx() * d.x() + cx(), fy() * d.y() + cy());
}

Vec3 Camera::Unproject(const Vec2& pixel) const {
  if (IsOrthographic()) return Vec3(0, 0, 1);
  const Vec2 d((pixel.x() - cx()) / fx(), (pixel.y() - cy()) / fy());
  const Vec2 x = Undistort(d);
  return Vec3(x.x(), x.y(), 1.0);
}

void Camera::PixelRay(const Vec2& pixel, Vec3* origin, Vec3* direction) const {
  if (IsOrthographic()) {
    *origin = Vec3((pixel.x() - cx()) / fx(), (pixel.y() - cy()) / fy(), 0.0);
    *direction = Vec3(0, 0, 1);
    return;
  }
  *origin = Vec3::Zero();
  *direction = Unproject(pixel);
}

Vec3 Camera::ToViewer(const Vec3& x_cam) const {
  if (IsOrthographic()) return Vec3(0, 0, -1);
  return (-x_cam).normalized();
}

Rigid3 Rigid3::Inverse() const {
  Rigid3 inv;
  inv.rotation = rotation.conjugate();
  inv.translation = -(inv.rotation * translation);
  return inv;
}

Rigid3 Rigid3::LookAt(const Vec3& eye, const Vec3& target, const Vec3& up) {
  const Vec3 z = (target - eye).normalized();
  // Image y points down, so start from -up; if up is parallel to the view
  // direction any perpendicular will do.
  Vec3 down = -up;
  if (down.cross(z).squaredNorm() < 1e-20 * down.squaredNorm()) down = z.unitOrthogonal();
  const Vec3 x = down.cross(z).normalized();
  const Vec3 y = z.cross(x);
  Mat3 world_from_cam;
  world_from_cam << x, y, z;
  Rigid3 cam_from_world;
  cam_from_world.rotation = Eigen::Quaterniond(Mat3(world_from_cam.transpose())).normalized();
  cam_from_world.translation = -(cam_from_world.rotation * eye);
  return cam_from_world;
}

}  // namespace svbrdf
