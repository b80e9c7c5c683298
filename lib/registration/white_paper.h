// The board's white paper as a diffuse reference: the pixels of a posed photo
// that see nothing but white paper.
//
// Any board the pattern options allow qualifies (ChArUco with any marker size,
// either layout, chessboards, circle grids): a pixel is kept when the printed
// drawing is white over the pixel and its neighbours' nearer halves (the
// board region a pixel and its blur see, found by back-projecting pixel
// corners onto the board plane), inside the pattern (how far the paper
// reaches beyond it is unknown), not covered by the object, not in the
// object's or a mirror ball's shadow from the light, away from the balls'
// reflections, not saturated.
#pragma once
#include <vector>

#include "calib/board.h"
#include "calib/light_probe.h"
#include "camera/camera.h"
#include "io/image.h"

namespace svbrdf {

class RayTracer;

struct PaperView {
  const Camera* camera = nullptr;
  Rigid3 cam_from_world;
  const Image* radiance = nullptr;   // linear, 3 channels
  const Image* saturated = nullptr;  // > 0 where clipped (may be null)
  const Image* object_mask = nullptr;  // > 0.5 on the object (may be null)
};

// Why candidate pixels were dropped, for error messages and the report.
struct PaperCounts {
  long white = 0;      // pixels that see only white paper of the pattern
  long hidden = 0;     // ... but the object covers them
  long shadowed = 0;   // ... in the shadow of the object or a ball
  long near_ball = 0;  // ... within 1.5 radii of a mirror ball
  long saturated = 0;  // ... clipped
  long kept = 0;
  PaperCounts& operator+=(const PaperCounts& o);
};

// Appends one DiffuseSample (albedo `paper_albedo`, board normal towards the
// camera) per kept pixel, every `stride` pixels in x and y. `occluder` (the
// registered object, may be null) and `spheres` cast shadows from `light`.
PaperCounts SampleWhitePaper(const BoardTexture& board, const PaperView& view, const std::vector<MirrorSphere>& spheres,
                             const RayTracer* occluder, const Vec3& light, double paper_albedo, int stride,
                             std::vector<DiffuseSample>* samples);

}  // namespace svbrdf
