// COLMAP camera models and rigid poses.
//
// Pixel convention (COLMAP): the centre of the top-left pixel is (0.5, 0.5);
// pixel (col, row) of an image array covers [col, col+1) x [row, row+1).
// Camera frame: x right, y down, z forward.
//
// Parameter order exactly as COLMAP's:
//   SIMPLE_PINHOLE f cx cy          PINHOLE fx fy cx cy
//   SIMPLE_RADIAL  f cx cy k        RADIAL  f cx cy k1 k2
//   OPENCV fx fy cx cy k1 k2 p1 p2
#pragma once
#include <string>
#include <vector>

#include "core/types.h"

namespace svbrdf {

enum class CameraModelId { kSimplePinhole, kPinhole, kSimpleRadial, kRadial, kOpenCV };

// Returns the model for a COLMAP name, or throws Error naming `context`.
CameraModelId CameraModelFromName(const std::string& name, const std::string& context);
std::string CameraModelName(CameraModelId id);
int CameraModelNumParams(CameraModelId id);

struct Camera {
  int id = 0;
  CameraModelId model = CameraModelId::kPinhole;
  int width = 0, height = 0;
  std::vector<double> params;

  // Focal lengths and principal point, whatever the model.
  double fx() const;
  double fy() const;
  double cx() const;
  double cy() const;
  // Camera-frame point (z > 0) to pixel coordinates (COLMAP convention).
  Vec2 Project(const Vec3& x_cam) const;
  // Pixel coordinates to a camera-frame ray direction with z = 1 (distortion
  // inverted iteratively, as COLMAP does).
  Vec3 Unproject(const Vec2& pixel) const;
  // Distortion on normalised image coordinates (identity for pinhole models).
  Vec2 Distort(const Vec2& xy) const;
  Vec2 Undistort(const Vec2& xy) const;
};

// Rigid transform named by what it maps: cam_from_world maps world points to
// camera coordinates, x_cam = rotation * x_world + translation.
struct Rigid3 {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Vec3 translation = Vec3::Zero();

  Vec3 operator*(const Vec3& x) const { return rotation * x + translation; }
  Rigid3 Inverse() const;
  // Camera centre in world coordinates when this is cam_from_world.
  Vec3 CentreInWorld() const { return Inverse().translation; }
  // Builds cam_from_world for a camera at `eye` looking at `target`, image y
  // axis pointing as close to -up as possible.
  static Rigid3 LookAt(const Vec3& eye, const Vec3& target, const Vec3& up);
};

}  // namespace svbrdf
