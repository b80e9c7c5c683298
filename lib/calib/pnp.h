// Pose of a calibrated camera from one view of a board (OpenCV solvePnP,
// iterative Levenberg-Marquardt from the homography start), in COLMAP's
// pixel convention like everything in lib/calib.
#pragma once
#include "calib/board.h"
#include "camera/camera.h"

namespace svbrdf {

// cam_from_board; throws Error (naming `context`) with fewer than 4 points.
Rigid3 SolveBoardPose(const Camera& camera, const BoardSpec& board, const BoardDetection& detection,
                      const std::string& context);

}  // namespace svbrdf
