// `svbrdf capture`: from a folder of photographs and a small description of
// what the user knows to a contract capture (scene.json) that `reconstruct`
// reads. Stages: intrinsics (calib), HDR merge of brackets with saturation
// masks, board detection + PnP + bundle adjustment (poses), silhouette
// registration of the scanned mesh, lamp positions from mirror spheres
// (rays intersected, then refined in the images) and intensities from the
// board's known albedo. Each stage's errors go into
// OUT/report/capture_report.json.
//
// Description file (JSON, "format": "svbrdf-capture-description/1"), paths
// relative to the photo folder:
//   board: {pattern, cols, rows, square, marker, dictionary, white_albedo, black_albedo}
//   camera: {"calibrate": true, "model": "OPENCV"} or {"cameras_txt": "calib/cameras.txt"}
//   calibration_photos: [files]  board-only photos for the intrinsics (optional)
//   images_color_space: "linear" (16-bit linear / EXR brackets) or "srgb" / "nonlinear"
//         (8-bit brackets; the camera response is recovered from them)
//   mesh: {file, world_from_mesh: {q, t}}  the scanned mesh and its rough
//         placement in the board frame (world = board frame, metres)
//   masks: "given" (each photo's "mask") or "grabcut" (seeded by the projected mesh)
//   mirror_spheres: {radius, centres: [[x, y, z], ...]}  in the board frame
//   lights: [{id, type: "point"}] or [{id, type: "flash", offset: [x, y, z], intensity}]
//           (a flash's intensity, when left out, is measured on the board's white paper)
//   poses: "board" | "colmap";  known_distance: {images: [a, b] | point_ids: [i, j] |
//          points: [[x, y, z], [x, y, z]], metres}  scales the COLMAP model when
//          fewer than 3 photos show the board (else reported as a check)
//   photos: [{files: [brackets], exposures: [relative], light: id, mask: file}]
#pragma once
#include <nlohmann/json.hpp>
#include <string>

namespace svbrdf {

struct CaptureJob {
  std::string photos_dir;
  std::string description;  // default: photos_dir/capture.json
  std::string out_dir;
  int silhouette_iterations = 10;
  int threads = 0;  // 0 = all cores (silhouettes, photos, COLMAP)
  bool progress = true;
  void Check() const;
};

// Writes out_dir/{scene.json, mesh.obj, images/, masks/, saturation/, report/}
// (under a temporary name, renamed when complete); returns the report.
nlohmann::json RunCapture(const CaptureJob& job);

}  // namespace svbrdf
