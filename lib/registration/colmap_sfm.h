// Poses by structure from motion: the COLMAP command-line tool run headless
// as a subprocess with the calibrated camera held fixed, its text model
// imported (calib/colmap_text.h), then scaled and placed in metric board
// coordinates by a similarity fitted to the photos whose board pose is known
// (or scaled by a known distance between two camera centres).
#pragma once
#include <map>
#include <string>
#include <vector>

#include "calib/colmap_text.h"

namespace svbrdf {

// Parameters (name, meaning, range):
//   colmap          the COLMAP executable (Debian package `colmap`)
//   max_image_size  SIFT extraction downscales larger images to this, pixels, >= 64
//   threads         -1 = all cores (COLMAP's convention)
struct ColmapSfmOptions {
  std::string colmap = "colmap";
  int max_image_size = 1600;
  int threads = -1;
  // COLMAP's --random_seed of the matcher's and mapper's RANSAC (COLMAP
  // 3.8): another seed is another try when a reconstruction fails.
  int random_seed = 0;
  void Check() const;
};

// The name an image has in the COLMAP model: its stem + ".png" (COLMAP is
// given 8-bit tone-mapped copies).
std::string ColmapImageName(const std::string& path);

// Runs feature_extractor (one camera, `camera`'s model and parameters),
// exhaustive_matcher, mapper (intrinsics not refined) and model_converter in
// `workspace` (created; logs in workspace/<step>.log) and returns the
// largest reconstruction. Images are referred to by file name. Throws Error
// naming the failing step and its log.
ColmapModel RunColmapSfm(const std::vector<std::string>& image_paths, const Camera& camera,
                         const std::string& workspace, const ColmapSfmOptions& options);

// x_board = scale * (rotation * x_colmap) + translation.
struct ColmapToBoard {
  double scale = 1;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Vec3 translation = Vec3::Zero();
  int matched = 0;            // images used for the fit
  double centre_rms_m = 0;    // camera-centre residual after the fit, metres
  // The image's pose in board coordinates.
  Rigid3 CamFromBoard(const Rigid3& cam_from_colmap) const;
};

// Similarity from camera centres of images posed both by COLMAP and by the
// board (by image name); needs 3 or more. Throws Error otherwise.
ColmapToBoard AlignColmapToBoard(const ColmapModel& model, const std::map<std::string, Rigid3>& cam_from_board);
// Scale only (orientation and origin stay COLMAP's): the centres of images
// `a` and `b` are `metres` apart.
ColmapToBoard ScaleColmapByDistance(const ColmapModel& model, const std::string& a, const std::string& b, double metres);

// A distance the user measured, one of three kinds (capture.json's
// "known_distance"): between the centres of two photos ("images"), two
// 3-D points of the model by their points3D.txt ids ("point_ids"), or two
// points given in the model's own coordinates ("points", e.g. picked in
// COLMAP's GUI).
struct KnownDistance {
  std::string image_a, image_b;
  long point_a = -1, point_b = -1;
  std::vector<Vec3> points;  // 2, model coordinates
  double metres = 0;
};
// Scale only, from a known distance; throws Error naming what is missing.
ColmapToBoard ScaleColmapByKnownDistance(const ColmapModel& model, const KnownDistance& known);

}  // namespace svbrdf
