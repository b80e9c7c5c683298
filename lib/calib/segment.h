// Object masks and their distance fields (OpenCV): the signed distance to a
// mask's boundary that silhouette registration descends, and GrabCut
// segmentation seeded by a projected mesh.
#pragma once
#include "io/image.h"

namespace svbrdf {

// Signed distance (pixels) from every pixel centre to the mask's boundary:
// positive inside (value > 0.5), negative outside; the boundary between an
// inside and an outside pixel is at 0 (hence the half-pixel shift).
Image SignedDistance(const Image& mask);

// GrabCut (Rother et al. 2004) seeded by `prior` (1 = the projected mesh):
// pixels deeper than `margin_px` inside the prior are probable foreground,
// farther than `margin_px` outside are background, a band between is left
// to the colour model. Returns a 0/1 mask.
Image GrabCutMask(const Image& photo, const Image& prior, int margin_px = 6, int iterations = 4);

// Intersection over union of two masks (value > 0.5 = inside).
double MaskIoU(const Image& a, const Image& b);

}  // namespace svbrdf
