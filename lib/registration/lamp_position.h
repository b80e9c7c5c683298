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
  int rejected = 0;  // highlights left out as outliers (RefineLampPositionMultiStart)
};

// The point of `sphere` whose mirror reflection sends light from `lamp` to
// the camera centre `eye` (templated so Ceres Jets flow through).
template <class T>
void SpecularPoint(const T* eye, const T* lamp, const T* centre, double radius, T* point);

LampRefineResult RefineLampPosition(const std::vector<HighlightObservation>& observations,
                                    const std::vector<MirrorSphere>& spheres, const Vec3& initial,
                                    const LampRefineOptions& options);

// The refinement from several starts, keeping the lowest highlight RMS: the
// rays' 3-D intersection and points at 0.1 .. 6.4 m along every ray (their
// mean per distance). With one ball, or balls close together, every
// reflected ray passes within a ball's radius of the others at the ball, so
// the least-squares intersection of slightly wrong rays is drawn to the ball
// itself, a local minimum of the image residual far from the lamp. Then
// highlights that the best lamp misses by more than 3 px and 5 times the
// median (another bright spot taken for a highlight that lies outside the
// photo or behind the object) are left out and the lamp refined again.
LampRefineResult RefineLampPositionMultiStart(const std::vector<HighlightObservation>& observations,
                                              const std::vector<MirrorSphere>& spheres, const std::vector<Ray3>& rays,
                                              const Vec3& intersection, const LampRefineOptions& options);

// The lamp refined jointly on its highlights and on the shading of the
// board's white paper it lights: a Lambertian paper of unknown albedo shows
// v = K cos / r^2 (K = albedo x intensity / pi, solved in closed form for
// each lamp position). With one ball, or balls close together, the
// highlights fix the lamp's direction from the ball well but its distance
// poorly (a pixel's quantisation moves it by centimetres at half a metre);
// the paper's fall-off over the board fixes the distance. Residuals:
// highlights in pixels over `highlight_px` (Cauchy loss), paper values
// minus the model over `paper_relative` times their median (its model
// error: vignetting, ambient light, the paper's non-Lambertian part). Paper
// samples whose v / g at the start is off the median by more than a factor
// 0.7 .. 1.4 (shadows the start did not predict) are left out. An ambient
// term A in v = A + K cos / r^2 trades off against the distance when the
// paper seen spans little of the fall-off (a few photos): it is solved only
// at the final position, for the intensity and the report.
struct LampPaperOptions {
  double highlight_px = 0.3;    // pixel quantisation of a sub-pixel highlight, > 0
  double paper_relative = 0.05; // > 0
  int max_samples = 2000;       // paper samples used (evenly subsampled), >= 10
  void Check() const;
};
struct LampPaperResult {
  Vec3 position = Vec3::Zero();
  double K = 0, ambient = 0;       // v = ambient + K cos / r^2 at the final position
  double ambient_share = 0;        // ambient / the median paper value
  double highlight_rms_px = 0, paper_rms_relative = 0;
};
LampPaperResult RefineLampWithPaper(const std::vector<HighlightObservation>& observations,
                                    const std::vector<MirrorSphere>& spheres,
                                    const std::vector<DiffuseSample>& paper, const Vec3& initial,
                                    const LampPaperOptions& options);

}  // namespace svbrdf

#include "registration/lamp_position_impl.h"
