// Photometric-stereo folders in DiLiGenT's layout (Shi et al., CVPR 2016):
// one fixed camera, one photo per calibrated directional light.
//
//   NNN.png or the files listed in filenames.txt   8- or 16-bit linear photos
//   light_directions.txt   one unit vector per photo towards its light, in
//                          the camera frame x right, y up, z towards the camera
//   light_intensities.txt  one RGB intensity per photo (the photo divided by
//                          it is the photo under a unit light)
//   mask.png               the object (non-zero)
//
// ImportPs turns such a folder into a capture in the contract
// (shared/spec/dataset.md): an ORTHOGRAPHIC camera, directional lights, per
// photo masks without saturated pixels, training and held-out scene.json and
// an image-plane mesh (lib/photometric/pixel_mesh.h).
#pragma once
#include <string>
#include <vector>

#include "core/types.h"
#include "io/image.h"

namespace svbrdf {

struct PsFolder {
  std::string dir;
  std::vector<std::string> files;  // photo file names, relative to dir, in light order
  std::vector<Vec3> to_light;      // per photo, unit, DiLiGenT camera frame (y up, z towards the camera)
  std::vector<Rgb> intensity;      // per photo, RGB
  Image mask;                      // 1 channel, 1 = object
  int width = 0, height = 0;
};

// Reads the folder's text files and mask and checks every photo's size
// (headers only); throws Error naming the file and the line or field at fault.
PsFolder ReadPsFolder(const std::string& dir);

// Options of `svbrdf import-ps`.
//   hold_out_every     lights N, 2N, ... (1-based) go to heldout/scene.json   [2, photos]
//   erode_px           held-out photo masks are the object mask eroded by
//                      this many pixels (boundary pixels mix object and
//                      background: evaluation leaves them out)              [0, 20]
//   erode_training_px  the same for the training photos (0: every object
//                      pixel gets a normal and a material from its photos)  [0, 20]
//   pixels_per_metre   the ORTHOGRAPHIC camera's sx = sy: the metric scale of
//                      the capture, which photometric rigs rarely know       > 0
//   normals_file       optional float RGB EXR of unit normals (DiLiGenT's
//                      frame, zero outside the object): the mesh carries them
//   truth_normals_file optional, the same kind of file kept as ground truth
//                      for evaluation only (the capture's normals stay unknown)
//   quantization       how the 8-bit photos' counts were made from the
//                      sensor's values: "floor" (truncated, as 16-bit >> 8
//                      and DiLiGenT's 8-bit copies do) or "round". A floored
//                      count k stands for a value in [k, k + 1): the capture
//                      stores k + 1/2 (as 16-bit PNG), which on dark photos
//                      (DiLiGenT's median 3-16 of 255) is a bias of 3-15 %
//                      otherwise; 0 stays 0 (in shadow the light is near 0,
//                      and a half count there reads as light), 255 stays
//                      saturated. 16-bit and float photos are copied as they
//                      are                                                 floor | round
struct ImportPsOptions {
  std::string in_dir, out_dir;
  int hold_out_every = 6;
  int erode_px = 2;
  int erode_training_px = 0;
  double pixels_per_metre = 1000.0;
  std::string normals_file, truth_normals_file;
  std::string quantization = "floor";
  bool progress = true;
  void Check() const;
};

struct ImportPsResult {
  int training = 0, held_out = 0;
  long object_pixels = 0;
  long saturated_samples = 0;  // pixel x photo pairs left out of the masks
  int dequantized = 0;         // 8-bit photos stored with floored counts put at k + 1/2
};

// Writes out_dir/scene.json, out_dir/heldout/scene.json, images, masks and
// mesh.obj; the folder appears only when complete.
ImportPsResult ImportPs(const ImportPsOptions& options);

// Reads a normals file as ImportPsOptions describes (DiLiGenT frame) and
// returns it in the COLMAP camera frame (y down, z forward), checking its
// size against width x height.
Image ReadCameraNormals(const std::string& path, int width, int height);
// DiLiGenT's camera frame <-> COLMAP's: (x, y, z) -> (x, -y, -z), its own inverse.
inline Vec3 FlipYZ(const Vec3& v) { return Vec3(v.x(), -v.y(), -v.z()); }

}  // namespace svbrdf
