// Geometry of a fixed orthographic view: a height field with one quad per
// object pixel, built from per-pixel normals.
//
// The quad of pixel (x, y) spans the pixel's footprint exactly (vertices at
// pixel corners) and its texture coordinates map it onto texel (x, y) of a
// photo-sized map, so a material with one texel per pixel and nearest
// filtering renders each pixel from its own fit, however the renderer
// integrates the pixel.
#pragma once
#include <vector>

#include "camera/camera.h"
#include "io/image.h"
#include "io/mesh.h"

namespace svbrdf {

// How per-pixel normals are integrated into depth.
//
//   max_slope            |dz/dx| in pixels per pixel that a normal may claim
//                        (grazing normals at silhouettes), > 0; default 5
//   bilateral_iterations reweighting rounds of the discontinuity-preserving
//                        refinement (0 = the Poisson solution); default 40
//   bilateral_k          sharpness of the one-sided weights, > 0; default 2
//   tolerance            the refinement stops when its energy changes by less
//                        than this share between rounds; default 1e-3
struct NormalIntegrationOptions {
  double max_slope = 5.0;
  int bilateral_iterations = 40;
  double bilateral_k = 2.0;
  double tolerance = 1e-3;
  void Check() const;
};

// Depth (camera z, metres) per pixel of `region` from unit camera-frame
// normals (COLMAP frame: facing the camera means n.z < 0).
//
// The start is least squares on the forward differences between region pixels
// (Poisson integration), the slope of each pair from the two pixels' normals.
// Poisson integration spreads a depth jump (an ear in front of a body) into a
// ramp that casts shadows the object does not have, so the start is refined by
// bilateral normal integration (Cao et al., ECCV 2022): each pixel's normal
// constrains the forward and the backward difference of its row and column,
// weighted by sigmoid(k ((backward diff)^2 - (forward diff)^2)) and its
// complement, iteratively reweighted, so that a pixel follows the side it is
// continuous with and a jump stays a jump. Each connected part has mean depth
// 0. Pixels outside the region get 0.
std::vector<double> IntegrateNormals(const Image& normals_cam, const Image& region, double metres_per_pixel,
                                     const NormalIntegrationOptions& options = {});

// The height-field mesh: one quad per region pixel at depth `base_depth` +
// depth[pixel], in world coordinates of `cam_from_world`, with per-vertex
// normals averaged from the adjacent pixels' normals (camera frame given,
// world written) and UVs onto the photo-sized texel grid.
Mesh PixelGridMesh(const Camera& cam, const Rigid3& cam_from_world, const Image& region,
                   const std::vector<double>& depth, double base_depth, const Image& normals_cam);

// Fills the pixels of `image` outside `known` (1 channel) with the value of a
// nearest known pixel (breadth-first growth over 4-neighbours); returns false
// if no pixel is known.
bool FillFromNearest(const Image& known, Image* image);

// Fills the unit normals (3 channels) of `region` pixels outside `known` so
// that each is the normalised mean of its 4 region neighbours (a membrane
// over the holes, relaxed by Jacobi sweeps from a nearest-pixel start): a
// hole inherits the slope of its whole rim, not one side's. Returns false
// if no region pixel is known (the normals are left as they were).
bool FillNormalsSmoothly(const Image& known, const Image& region, Image* normals);

// Median of channel 0 of `values` over the `region` pixels within a
// (2 radius + 1)^2 window of each region pixel (0 outside the region).
Image RegionMedian(const Image& values, const Image& region, int radius);

}  // namespace svbrdf
