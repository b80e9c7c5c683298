#include "registration/lamp_position.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <cmath>

#include "core/error.h"
#include "registration/project.h"

namespace svbrdf {

void LampRefineOptions::Check() const {
  if (!(huber_px > 0)) throw Error("lamp refinement: huber_px must be > 0");
  if (max_iterations < 1) throw Error("lamp refinement: max_iterations must be >= 1");
}

namespace {

// Predicted minus observed highlight, pixels.
struct HighlightCost {
  HighlightCost(const HighlightObservation& o, const MirrorSphere& sphere)
      : o(o), centre(sphere.centre), radius(sphere.radius), eye(o.cam_from_world.CentreInWorld()) {}
  template <class T>
  bool operator()(const T* lamp, T* residual) const {
    const T e[3] = {T(eye.x()), T(eye.y()), T(eye.z())};
    const T c[3] = {T(centre.x()), T(centre.y()), T(centre.z())};
    T x[3];
    SpecularPoint(e, lamp, c, radius, x);
    const Mat3 R = o.cam_from_world.rotation.toRotationMatrix();
    const Vec3& t = o.cam_from_world.translation;
    T xc[3];
    for (int r = 0; r < 3; ++r) xc[r] = T(R(r, 0)) * x[0] + T(R(r, 1)) * x[1] + T(R(r, 2)) * x[2] + T(t[r]);
    std::vector<T> params(o.camera->params.begin(), o.camera->params.end());
    T px[2];
    ProjectT(o.camera->model, params.data(), xc, px);
    residual[0] = px[0] - T(o.pixel.x());
    residual[1] = px[1] - T(o.pixel.y());
    return true;
  }
  HighlightObservation o;
  Vec3 centre;
  double radius;
  Vec3 eye;
};

double Rms(const std::vector<HighlightObservation>& obs, const std::vector<MirrorSphere>& s, const Vec3& lamp) {
  double sum = 0;
  for (const HighlightObservation& o : obs) {
    const Vec3 eye = o.cam_from_world.CentreInWorld();
    Vec3 x;
    SpecularPoint(eye.data(), lamp.data(), s[o.sphere].centre.data(), s[o.sphere].radius, x.data());
    sum += (o.camera->Project(o.cam_from_world * x) - o.pixel).squaredNorm();
  }
  return std::sqrt(sum / obs.size());
}

}  // namespace

LampRefineResult RefineLampPosition(const std::vector<HighlightObservation>& obs,
                                    const std::vector<MirrorSphere>& spheres, const Vec3& initial,
                                    const LampRefineOptions& o) {
  o.Check();
  if (obs.size() < 2) throw Error("lamp refinement: need at least two highlights");
  for (const HighlightObservation& h : obs)
    if (!h.camera || h.sphere < 0 || h.sphere >= int(spheres.size()))
      throw Error("lamp refinement: observation without camera or with an unknown sphere");
  LampRefineResult r;
  r.position = initial;
  r.initial_rms_px = Rms(obs, spheres, initial);
  ceres::Problem problem;
  for (const HighlightObservation& h : obs)
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<HighlightCost, 2, 3>(new HighlightCost(h, spheres[h.sphere])),
        new ceres::HuberLoss(o.huber_px), r.position.data());
  ceres::Solver::Options so;
  so.max_num_iterations = o.max_iterations;
  so.linear_solver_type = ceres::DENSE_QR;
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  r.rms_px = Rms(obs, spheres, r.position);
  return r;
}

}  // namespace svbrdf
