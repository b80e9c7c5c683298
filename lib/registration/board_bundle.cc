#include "registration/board_bundle.h"

#include <array>
#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <cmath>

#include "core/error.h"
#include "registration/project.h"

namespace svbrdf {

void BundleOptions::Check() const {
  if (!(huber_px > 0)) throw Error("bundle: huber_px must be > 0");
  if (max_iterations < 1) throw Error("bundle: max_iterations must be >= 1");
}

namespace {

// Reprojection of one fixed board point: pose as quaternion [w x y z] + t.
struct BoardPointCost {
  BoardPointCost(CameraModelId model, const Vec3& X, const Vec2& observed) : model(model), X(X), observed(observed) {}
  template <class T>
  bool operator()(const T* params, const T* q, const T* t, T* residual) const {
    const T x[3] = {T(X.x()), T(X.y()), T(X.z())};
    T xc[3];
    ceres::QuaternionRotatePoint(q, x, xc);
    for (int k = 0; k < 3; ++k) xc[k] += t[k];
    T px[2];
    ProjectT(model, params, xc, px);
    residual[0] = px[0] - T(observed.x());
    residual[1] = px[1] - T(observed.y());
    return true;
  }
  CameraModelId model;
  Vec3 X;
  Vec2 observed;
};

double ViewRms(const Camera& cam, const Rigid3& pose, const BoardObservations& v, const std::vector<Vec3>& obj) {
  double sum = 0;
  for (size_t i = 0; i < v.ids.size(); ++i) sum += (cam.Project(pose * obj[v.ids[i]]) - v.points[i]).squaredNorm();
  return v.ids.empty() ? 0 : std::sqrt(sum / v.ids.size());
}

}  // namespace

BundleResult AdjustBoardBundle(const Camera& camera, const std::vector<Rigid3>& poses,
                               const std::vector<BoardObservations>& views, const std::vector<Vec3>& obj,
                               const BundleOptions& o) {
  o.Check();
  if (poses.size() != views.size()) throw Error("bundle: one pose per view needed");
  BundleResult r;
  r.camera = camera;
  std::vector<std::array<double, 4>> q(views.size());
  std::vector<std::array<double, 3>> t(views.size());
  ceres::Problem problem;
  long n = 0;
  double sum0 = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    const auto& rq = poses[v].rotation;
    q[v] = {rq.w(), rq.x(), rq.y(), rq.z()};
    t[v] = {poses[v].translation.x(), poses[v].translation.y(), poses[v].translation.z()};
    sum0 += std::pow(ViewRms(camera, poses[v], views[v], obj), 2) * views[v].ids.size();
    for (size_t i = 0; i < views[v].ids.size(); ++i, ++n) {
      auto* cost = new BoardPointCost(camera.model, obj[views[v].ids[i]], views[v].points[i]);
      ceres::CostFunction* f = nullptr;
      switch (camera.model) {  // parameter-block sizes are compile-time for autodiff
        case CameraModelId::kSimplePinhole: f = new ceres::AutoDiffCostFunction<BoardPointCost, 2, 3, 4, 3>(cost); break;
        case CameraModelId::kPinhole: f = new ceres::AutoDiffCostFunction<BoardPointCost, 2, 4, 4, 3>(cost); break;
        case CameraModelId::kSimpleRadial: f = new ceres::AutoDiffCostFunction<BoardPointCost, 2, 4, 4, 3>(cost); break;
        case CameraModelId::kRadial: f = new ceres::AutoDiffCostFunction<BoardPointCost, 2, 5, 4, 3>(cost); break;
        case CameraModelId::kOpenCV: f = new ceres::AutoDiffCostFunction<BoardPointCost, 2, 8, 4, 3>(cost); break;
        case CameraModelId::kOrthographic:
          delete cost;
          throw Error("bundle: ORTHOGRAPHIC cameras (photometric rigs) are not calibrated from boards");
      }
      problem.AddResidualBlock(f, new ceres::HuberLoss(o.huber_px), r.camera.params.data(), q[v].data(), t[v].data());
    }
    if (!views[v].ids.empty()) problem.SetManifold(q[v].data(), new ceres::QuaternionManifold);
  }
  if (n == 0) throw Error("bundle: no observations");
  r.initial_rms_px = std::sqrt(sum0 / n);
  if (!o.refine_intrinsics) problem.SetParameterBlockConstant(r.camera.params.data());
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_SCHUR;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  so.gradient_tolerance = 1e-12;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  double sum = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    Rigid3 p;
    p.rotation = Eigen::Quaterniond(q[v][0], q[v][1], q[v][2], q[v][3]).normalized();
    p.translation = Vec3(t[v][0], t[v][1], t[v][2]);
    r.cam_from_board.push_back(p);
    const double rms = ViewRms(r.camera, p, views[v], obj);
    r.view_rms_px.push_back(rms);
    sum += rms * rms * views[v].ids.size();
  }
  r.rms_px = std::sqrt(sum / n);
  return r;
}

}  // namespace svbrdf
