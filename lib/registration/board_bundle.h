// Joint refinement of the camera intrinsics and every photo's pose over the
// board corners (a bundle adjustment with the board's known geometry fixed),
// with Ceres: residual = projected board point - detected point, pixels,
// Huber loss so that a few bad detections do not pull the solution.
#pragma once
#include <vector>

#include "camera/camera.h"

namespace svbrdf {

struct BoardObservations {
  std::vector<int> ids;      // into the board's object points
  std::vector<Vec2> points;  // COLMAP pixel convention
};

// Parameters (name, meaning, range):
//   refine_intrinsics  also refine the camera parameters (shared by all views)
//   huber_px           Huber loss scale, pixels, > 0
//   max_iterations     Levenberg-Marquardt iterations, >= 1
struct BundleOptions {
  bool refine_intrinsics = true;
  double huber_px = 1.0;
  int max_iterations = 100;
  void Check() const;
};

struct BundleResult {
  Camera camera;
  std::vector<Rigid3> cam_from_board;
  std::vector<double> view_rms_px;  // per view, after refinement
  double rms_px = 0;                // over all points
  double initial_rms_px = 0;
};

BundleResult AdjustBoardBundle(const Camera& camera, const std::vector<Rigid3>& cam_from_board,
                               const std::vector<BoardObservations>& views, const std::vector<Vec3>& object_points,
                               const BundleOptions& options);

}  // namespace svbrdf
