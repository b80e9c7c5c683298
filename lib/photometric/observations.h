// Per-pixel observations of a photometric capture: one fixed orthographic
// view, one directional light per photo. Every object pixel is its own texel.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "camera/camera.h"
#include "io/image.h"
#include "io/mesh.h"
#include "io/scene.h"

namespace svbrdf {

// True when every image of `scene` shares one ORTHOGRAPHIC camera and one
// pose and every light is directional: the capture of a photometric-stereo
// rig, reconstructed per pixel (lib/photometric) instead of per texel.
bool IsPhotometricCapture(const Scene& scene);

struct PsObservations {
  Camera cam;
  Rigid3 cam_from_world;
  int width = 0, height = 0, lights = 0;
  std::vector<int> pixel;       // y * width + x of each object pixel (P of them)
  std::vector<Vec3> to_light;   // per light, camera frame (COLMAP: y down, z forward), unit
  Vec3 to_viewer = Vec3(0, 0, -1);
  // [p][l][c]: the photo divided by exposure x irradiance (the radiance under
  // a unit light), and the square root of its fit weight: exposure x
  // irradiance (so residuals are in the photo's units) times the sRGB
  // encoding's slope at the photo's value to the power `srgb_weight_exponent`
  // (1: errors in the units held-out PSNR is measured in, which lets dark,
  // 8-bit-quantised values dominate; 0: linear; 0.5 between). Weight 0 marks
  // unusable values (outside the photo's mask, saturated).
  std::vector<float> value, weight;
  std::vector<double> depth;  // per pixel (P): camera-frame z of the capture mesh at the pixel centre
  Image region;  // 1 channel: 1 on the object (the capture mesh seen by the pixel centre)
  Image valid;   // 1 channel: 1 where some photo has a usable value

  size_t At(long p, int l) const { return (size_t(p) * lights + l) * 3; }
  int P() const { return int(pixel.size()); }
  // Whether the value at i = At(p, l) is usable in every channel (what a
  // luminance fit needs).
  bool UsableRgb(size_t i) const { return !(weight[i] <= 0 || weight[i + 1] <= 0 || weight[i + 2] <= 0); }
};

// Reads every photo and mask of `scene` (IsPhotometricCapture must hold);
// `mesh` gives the object region (pixel centres whose ray hits it).
PsObservations LoadObservations(const Scene& scene, const Mesh& mesh, double srgb_weight_exponent, int threads,
                                bool progress);

// Camera-frame normals per pixel from the capture mesh (the shading normal at
// each region pixel's centre); 3 channels, zero outside the region.
Image MeshNormalsCamera(const PsObservations& obs, const Mesh& mesh);

// Cast shadows [p][l]: 1 where the pixel's surface point does not see light
// l past `mesh` (the height field); attached shadows are left to the model.
std::vector<uint8_t> CastShadows(const PsObservations& obs, const Mesh& mesh, int threads);

// Lambertian least squares on each pixel's luminance (Woodham 1980) over its
// inlier photos: values below the pixel's 25th percentile (shadows,
// interreflection) and above its 75th (highlights) are left out, then photos
// the first estimate puts in attached shadow. Camera-frame unit normals, 3
// channels. A pixel is determined when at least kMinDeterminingPhotos of its
// inlier photos hold light (a value above 0); the others (black or
// mirror-like surfaces, which send no light to the camera under most
// lights, or pixels in shadow in most photos) face the camera and get 0 in
// `determined` (1 channel, photo-sized; optional). `misfit` (optional, 1
// channel, photo-sized) gets how far the inlier photos are from Lambertian:
// the RMS residual of the fit over their mean value (metals and other
// lobe-dominated surfaces, where the estimate is poor, stand out).
Image LambertianNormals(const PsObservations& obs, const std::vector<uint8_t>& shadowed, int threads,
                        Image* determined = nullptr, Image* misfit = nullptr);
constexpr int kMinDeterminingPhotos = 6;

}  // namespace svbrdf
