// "Raw" photo sets for the front half of the pipeline (calibrate, poses,
// registration, lights, HDR): what a user photographs, rendered with exact
// ground truth that the pipeline never sees.
//
// A printed calibration board lies in the world plane z = 0 (world = board
// frame); a scanned object (procedural shape with a painted ground-truth
// SVBRDF) floats above its centre at a hidden pose; two mirror spheres of
// known radius rest on the board at known board positions; a few point lamps
// (glowing globes of radius `lamp_radius`) light the scene, one lamp per
// photo; the camera (OPENCV model with distortion) moves around on a ring.
// Board and spheres are rendered analytically with n x n supersampling (the
// board's corners must be sharp to sub-pixel accuracy); the object's pixels
// are lib/relight's rendering, so they match the ground-truth capture.
//
// Output folder:
//   photos/NNNN_bK.png   bracket K of photo NNNN (16-bit linear PNG, or .exr)
//   photos/calib_NNNN.png  board-only photos for the intrinsics
//   masks/NNNN.png       object segmentation as a user would supply it
//   mesh.obj             the scanned mesh in its own (object) frame
//   capture.json         the description file for `svbrdf capture`, with
//                        what a user knows (board, sphere radius and
//                        positions, mesh, a rough initial mesh placement)
//   truth/scene.json     the ground-truth capture: true camera, poses,
//                        lights, mesh placement, noise-free EXR images
//   truth/truth.json     the hidden values (world_from_object, lamps, camera)
//   gt/                  the ground-truth material (world-frame mesh)
//   heldout/scene.json   extra views and lights for evaluation
#pragma once
#include <string>
#include <vector>
#include <nlohmann/json.hpp>

#include "camera/camera.h"
#include "io/image.h"
#include "synth/ground_truth.h"

namespace svbrdf {

// Parameters (name, meaning, range):
//   board_texture      the printed board (1 channel, 0..1) and texture_from_board
//                      (affine, board metres -> texture pixels); from calib's DrawBoard
//   white_albedo, black_albedo   diffuse albedo of the board's paper and ink, (0, 1]
//   object, detail     procedural shape (sphere, torus, blob, cube) and its resolution
//   object_radius      metres, > 0
//   num_images, num_heldout  photos and held-out evaluation views
//   num_calibration    board-only photos at varied tilt, roll and position for
//                      the intrinsics (photos/calib_NNNN.png), >= 0
//   width, height      pixels; focal_factor: focal length / width
//   distortion         OPENCV k1 k2 p1 p2 of the true camera
//   distance           camera distance from the object centre, metres
//   elevation_min/max_deg  camera ring elevations above the board
//   num_lamps          point lamps, photo i uses lamp i % num_lamps
//   lamp_intensity     W/sr; lamp_radius: glowing globe seen in the mirrors, metres
//   flash_offset       empty: the lamps; [x, y, z]: instead a flash at this offset
//                      in the camera frame (metres) lights every photo
//                      (capture.json: a "flash" light without intensity)
//   sphere_radius      mirror spheres, metres; mirror_reflectance in (0, 1]
//   brackets, bracket_stops   exposures per photo and their spacing (stops);
//                      bracket k has exposure 2^(-k*stops)
//   format             png16 (linear 16 bit) | png8 (sRGB) | exr
//   noise              shot noise sigma = noise * sqrt(value)
//   init_error_deg/mm  error of the rough mesh placement written into capture.json
//   spp                n x n samples per pixel for board and spheres
struct RawPhotoOptions {
  Image board_texture;
  Eigen::Matrix<double, 2, 3> texture_from_board = Eigen::Matrix<double, 2, 3>::Zero();
  nlohmann::json board_json;  // copied into capture.json (pattern, size, ...)
  double white_albedo = 0.9, black_albedo = 0.05;
  std::string object = "cube";
  int detail = 48;
  GroundTruthOptions material;
  double object_radius = 0.05;
  int num_images = 16, num_heldout = 3;
  int num_calibration = 10;  // extra photos of the board alone, tilted and rolled, filling the frame
  int width = 480, height = 360;
  double focal_factor = 1.2;
  std::vector<double> distortion = {-0.06, 0.02, 0.0004, -0.0003};
  double distance = 0.6;
  double elevation_min_deg = 35, elevation_max_deg = 65;
  int num_lamps = 4;
  double lamp_intensity = 1.0, lamp_radius = 0.05;
  std::vector<double> flash_offset;
  double sphere_radius = 0.04, mirror_reflectance = 0.8;
  int brackets = 3;
  double bracket_stops = 4;
  std::string format = "png16";
  double noise = 0.0;
  double init_error_deg = 5, init_error_mm = 20;
  int spp = 3;
  uint64_t seed = 1;
  int threads = 0;
  void Check() const;
};

struct RawPhotoTruth {
  Camera camera;
  std::vector<Rigid3> cam_from_world;
  Rigid3 world_from_object;
  std::vector<Vec3> lamps;
  std::vector<int> photo_lamp;
  std::vector<Vec3> sphere_centres;
};

// Renders the set into out_dir (written under a temporary name, then renamed).
RawPhotoTruth SynthesizeRawPhotos(const RawPhotoOptions& options, const std::string& out_dir);

}  // namespace svbrdf
