// Point-lamp position from mirror-sphere highlights, refined in the images.
//
// calib/light_probe's NearestPointToRays intersects the reflected rays in
// 3-D: it weights every ray alike, although a highlight's pixel error turns
// into very different ray errors (a highlight near the sphere's rim, seen at
// a grazing angle, or a sphere far from the camera swings its reflected ray
// much more per pixel). Here the lamp position is refined so that the
// predicted highlights (the point of each sphere that mirrors the lamp into
// the camera) land on the observed ones, in pixels, over all views and
// spheres at once (Ceres, robust loss): the maximum-likelihood estimate for
// equal pixel noise. The sphere centres stay as given: with one lamp's few
// views the centre and the lamp trade off, so freeing the centres as well,
// even held near their given positions, makes the lamps worse on the
// synthetic raw set (bench_results/front_half.md).
#pragma once
#include <vector>

#include "calib/light_probe.h"

namespace svbrdf {

struct HighlightObservation {
  const Camera* camera = nullptr;
  Rigid3 cam_from_world;
  int sphere = 0;  // index into the spheres
  Vec2 pixel = Vec2::Zero();
};

// Parameters (name, meaning, range):
//   huber_px           robust loss scale on the highlight residual, pixels, > 0
//   max_iterations     Ceres iterations, >= 1
struct LampRefineOptions {
  double huber_px = 0.5;
  int max_iterations = 50;
  void Check() const;
};

struct LampRefineResult {
  Vec3 position = Vec3::Zero();
  double initial_rms_px = 0, rms_px = 0;
};

// The point of `sphere` whose mirror reflection sends light from `lamp` to
// the camera centre `eye` (templated so Ceres Jets flow through).
template <class T>
void SpecularPoint(const T* eye, const T* lamp, const T* centre, double radius, T* point);

LampRefineResult RefineLampPosition(const std::vector<HighlightObservation>& observations,
                                    const std::vector<MirrorSphere>& spheres, const Vec3& initial,
                                    const LampRefineOptions& options);

}  // namespace svbrdf

#include "registration/lamp_position_impl.h"
