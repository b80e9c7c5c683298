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

// Depth (camera z, metres) per pixel of `region` from unit camera-frame
// normals (COLMAP frame: facing the camera means n.z < 0) by least squares on
// the forward differences between region pixels (Poisson integration), the
// slope of each pair from the two pixels' normals. Slopes are clamped to
// `max_slope` (normals at grazing silhouettes). Each connected part has mean
// depth 0. Pixels outside the region get 0.
std::vector<double> IntegrateNormals(const Image& normals_cam, const Image& region, double metres_per_pixel,
                                     double max_slope = 5.0);

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
