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
//   ORTHOGRAPHIC sx sy cx cy        (not COLMAP's; shared/spec/dataset.md)
//
// ORTHOGRAPHIC is the fixed camera of photometric-stereo rigs whose lens is
// telecentric or far away: sx, sy are pixels per metre and (cx, cy) the
// principal point; a camera-frame point (x, y, z) projects to
// (sx x + cx, sy y + cy) whatever its z > 0, and every pixel's ray runs along
// +z from the plane z = 0. So rays start at PixelRay's origin, not at the
// camera centre, and the viewer direction is -z everywhere (ToViewer).
#pragma once
#include <string>
#include <vector>

#include "core/types.h"

namespace svbrdf {

enum class CameraModelId { kSimplePinhole, kPinhole, kSimpleRadial, kRadial, kOpenCV, kOrthographic };

// Returns the model for a COLMAP name, or throws Error naming `context`.
CameraModelId CameraModelFromName(const std::string& name, const std::string& context);
std::string CameraModelName(CameraModelId id);
int CameraModelNumParams(CameraModelId id);

struct Camera {
  int id = 0;
  CameraModelId model = CameraModelId::kPinhole;
  int width = 0, height = 0;
  std::vector<double> params;

  bool IsOrthographic() const { return model == CameraModelId::kOrthographic; }
  // Focal lengths (ORTHOGRAPHIC: pixels per metre) and principal point, whatever the model.
  double fx() const;
  double fy() const;
  double cx() const;
  double cy() const;
  // Camera-frame point (z > 0) to pixel coordinates (COLMAP convention).
  Vec2 Project(const Vec3& x_cam) const;
  // Pixel coordinates to a camera-frame ray direction with z = 1 (distortion
  // inverted iteratively, as COLMAP does); (0, 0, 1) for ORTHOGRAPHIC, whose
  // rays do not start at the camera centre: use PixelRay for origins.
  Vec3 Unproject(const Vec2& pixel) const;
  // The camera-frame ray through a pixel: origin (the centre, or the pixel's
  // point on the plane z = 0 for ORTHOGRAPHIC) and direction with z = 1.
  void PixelRay(const Vec2& pixel, Vec3* origin, Vec3* direction) const;
  // Unit camera-frame direction from a camera-frame point towards the viewer.
  Vec3 ToViewer(const Vec3& x_cam) const;
  // Size in metres of one pixel at camera-frame distance `distance`.
  double MetresPerPixel(double distance) const { return IsOrthographic() ? 1.0 / fx() : distance / fx(); }
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
