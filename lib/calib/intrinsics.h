// Camera intrinsics from photographs of a calibration board (OpenCV's
// calibrateCamera, Zhang's method), expressed as a COLMAP camera model in
// COLMAP's pixel convention (see calib/board.h), with the per-view
// reprojection errors, rejected views and the reasons, and the board pose of
// every used view.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "calib/board.h"
#include "camera/camera.h"

namespace svbrdf {

// Parameters (name, meaning, range):
//   board          the target (calib/board.h)
//   model          COLMAP model to fit: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL,
//                  RADIAL or OPENCV (default; OpenCV's k1 k2 p1 p2, k3 fixed at 0)
//   min_points     views with fewer detected points are rejected, >= 4
//   reject_factor  after a first fit, views whose RMS exceeds reject_factor x the
//                  median view RMS (and 0.5 px) are rejected and the fit repeated, > 1
//   min_views      fewer usable views is an error, >= 1
//   point_outlier_factor, min_point_outlier_px  after a first fit, single
//                  points whose residual exceeds max(min_point_outlier_px,
//                  point_outlier_factor x the median residual) are dropped
//                  (> 1, >= 0 pixels)
struct CalibrateOptions {
  BoardSpec board;
  CameraModelId model = CameraModelId::kOpenCV;
  int min_points = 6;
  double reject_factor = 4.0;
  int min_views = 3;
  double point_outlier_factor = 4.0, min_point_outlier_px = 0.1;
  bool progress = true;
  void Check() const;
};

struct ViewCalibration {
  std::string name;
  bool used = false;
  std::string why;            // reason for rejection (empty when used)
  std::vector<int> ids;       // board point ids
  std::vector<Vec2> points;   // detected, COLMAP convention (outliers removed)
  int outlier_points = 0;     // detections dropped as far off the first fit
  std::vector<Vec2> residuals;  // projected - detected, pixels (views that reached a fit)
  double rms = 0;             // pixels, over this view's points
  Rigid3 cam_from_board;
};

struct CalibrationResult {
  Camera camera;              // id 1
  double rms = 0;             // over all points of the used views, pixels
  double rms_all_found = 0;   // first fit, every view with a detection (before rejection)
  int outlier_points = 0;     // single points dropped (see CalibrateOptions)
  int used_views = 0;
  std::vector<ViewCalibration> views;
  nlohmann::json ToJson() const;
};

// Detects the board in every image (read through lib/io) and fits the camera.
// Throws Error naming the images when too few views have the board.
CalibrationResult CalibrateIntrinsics(const std::vector<std::string>& image_paths, const CalibrateOptions& options);
// Same from detections already made (names and sizes given).
CalibrationResult CalibrateFromDetections(std::vector<ViewCalibration> views, int width, int height,
                                          const CalibrateOptions& options);

// Writes DIR/cameras.txt, DIR/calibration.json, DIR/corners.png (detections
// and magnified residuals on the first used view) and DIR/residuals.png (the
// residual field of all used views over the image plane).
void WriteCalibration(const CalibrationResult& result, const std::vector<std::string>& image_paths,
                      const std::string& out_dir);

}  // namespace svbrdf
