// COLMAP's sparse model text format (cameras.txt, images.txt, points3D.txt),
// as documented in COLMAP's "Output format" page: the calibrate command writes
// cameras.txt, the SfM import reads all three. Pixel convention and camera
// parameter order are COLMAP's, as in lib/camera.
#pragma once
#include <map>
#include <string>
#include <vector>

#include "camera/camera.h"

namespace svbrdf {

struct ColmapImage {
  int id = 0;
  int camera_id = 0;
  std::string name;
  Rigid3 cam_from_world;
  std::vector<Vec2> points2d;
  std::vector<long> point3d_ids;  // -1 when the observation has no 3D point
};

struct ColmapPoint {
  long id = 0;
  Vec3 xyz = Vec3::Zero();
  double error = 0;  // mean reprojection error (pixels) as COLMAP reports it
};

struct ColmapModel {
  std::vector<Camera> cameras;
  std::vector<ColmapImage> images;
  std::map<long, ColmapPoint> points;
};

// Reads DIR/cameras.txt, DIR/images.txt and (if present) DIR/points3D.txt;
// throws Error naming the file and line on anything malformed.
ColmapModel ReadColmapText(const std::string& dir);
std::vector<Camera> ReadColmapCameras(const std::string& cameras_txt);
// Writes cameras.txt atomically.
void WriteColmapCameras(const std::vector<Camera>& cameras, const std::string& cameras_txt);

}  // namespace svbrdf
