#include "registration/silhouette.h"

#include <ceres/ceres.h>
#include <ceres/cubic_interpolation.h>
#include <ceres/rotation.h>
#include <map>

#include "calib/segment.h"
#include "core/error.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "raytrace/raytracer.h"
#include "registration/project.h"

namespace svbrdf {

void SilhouetteOptions::Check() const {
  if (outer_iterations < 1) throw Error("silhouette: outer_iterations must be >= 1");
  if (!(huber_px > 0)) throw Error("silhouette: huber_px must be > 0");
  if (max_points_per_view < 10) throw Error("silhouette: max_points_per_view must be >= 10");
}

namespace {

Rigid3 Compose(const Rigid3& a_from_b, const Rigid3& b_from_c) {
  Rigid3 r;
  r.rotation = a_from_b.rotation * b_from_c.rotation;
  r.translation = a_from_b.rotation * b_from_c.translation + a_from_b.translation;
  return r;
}

Image RenderWithTracer(const RayTracer& tracer, const Rigid3& world_from_object, const Camera& cam,
                       const Rigid3& cam_from_world) {
  const Rigid3 object_from_cam = Compose(cam_from_world, world_from_object).Inverse();
  Image mask(cam.width, cam.height, 1);
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      Hit hit;
      const Vec3 d = object_from_cam.rotation * cam.Unproject(Vec2(x + 0.5, y + 0.5));
      mask.at(x, y, 0) = tracer.Intersect(object_from_cam.translation, d, &hit) ? 1.0f : 0.0f;
    }
  return mask;
}

// Object-frame points on the visible contour generators of the mesh for one view.
std::vector<Vec3> ContourPoints(const Mesh& mesh, const RayTracer& tracer, const Rigid3& world_from_object,
                                const Rigid3& cam_from_world, int max_points) {
  const Vec3 eye_obj = Compose(cam_from_world, world_from_object).Inverse().translation;
  std::vector<char> front(mesh.faces.size());
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const Vec3i& t = mesh.faces[f];
    const Vec3 n = (mesh.positions[t[1]] - mesh.positions[t[0]]).cross(mesh.positions[t[2]] - mesh.positions[t[0]]);
    front[f] = n.dot(eye_obj - mesh.positions[t[0]]) > 0;
  }
  std::map<std::pair<int, int>, int> edge_face;  // edge -> first face
  std::vector<Vec3> pts;
  for (size_t f = 0; f < mesh.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      int a = mesh.faces[f][k], b = mesh.faces[f][(k + 1) % 3];
      if (a > b) std::swap(a, b);
      auto [it, inserted] = edge_face.emplace(std::make_pair(a, b), int(f));
      if (inserted || front[it->second] == front[f]) continue;
      for (double s : {0.25, 0.75}) pts.push_back((1 - s) * mesh.positions[a] + s * mesh.positions[b]);
    }
  // Keep points the camera sees (inner contours behind the object are not on the outline).
  std::vector<Vec3> visible;
  for (const Vec3& p : pts) {
    const Vec3 d = p - eye_obj;
    const double dist = d.norm();
    Hit hit;
    if (!tracer.Intersect(eye_obj, d / dist, &hit) || hit.t > dist - 1e-3 * dist) visible.push_back(p);
  }
  if (int(visible.size()) > max_points) {
    std::vector<Vec3> thin;
    const double step = double(visible.size()) / max_points;
    for (int i = 0; i < max_points; ++i) thin.push_back(visible[size_t(i * step)]);
    visible.swap(thin);
  }
  return visible;
}

// Signed mask distance at the projection of one contour point; pose update
// (angle-axis about the object's pivot, translation) is the unknown.
struct ContourCost {
  ContourCost(const Vec3& y, const Vec3& pivot, const Rigid3& cam_from_world, const Camera& cam,
              const ceres::BiCubicInterpolator<ceres::Grid2D<float, 1>>* sdf)
      : y(y), pivot(pivot), cam_from_world(cam_from_world), cam(cam), sdf(sdf) {}
  template <class T>
  bool operator()(const T* omega, const T* t, T* residual) const {
    const T yy[3] = {T(y.x()), T(y.y()), T(y.z())};
    T xw[3];
    ceres::AngleAxisRotatePoint(omega, yy, xw);
    for (int k = 0; k < 3; ++k) xw[k] += T(pivot[k]) + t[k];
    const Eigen::Matrix3d R = cam_from_world.rotation.toRotationMatrix();
    T xc[3];
    for (int r = 0; r < 3; ++r)
      xc[r] = T(R(r, 0)) * xw[0] + T(R(r, 1)) * xw[1] + T(R(r, 2)) * xw[2] + T(cam_from_world.translation[r]);
    T px[2];
    std::vector<T> params(cam.params.begin(), cam.params.end());
    ProjectT(cam.model, params.data(), xc, px);
    // Grid rows/cols are pixel indices whose centres sit at +0.5 (COLMAP).
    sdf->Evaluate(px[1] - T(0.5), px[0] - T(0.5), residual);
    return true;
  }
  Vec3 y, pivot;
  Rigid3 cam_from_world;
  const Camera& cam;
  const ceres::BiCubicInterpolator<ceres::Grid2D<float, 1>>* sdf;
};

}  // namespace

Image RenderSilhouette(const Mesh& mesh, const Rigid3& world_from_object, const Camera& cam,
                       const Rigid3& cam_from_world) {
  RayTracer tracer(mesh);
  return RenderWithTracer(tracer, world_from_object, cam, cam_from_world);
}

SilhouetteResult AlignSilhouettes(const Mesh& mesh, const Rigid3& init, const std::vector<SilhouetteView>& views,
                                  const SilhouetteOptions& o) {
  o.Check();
  if (views.empty()) throw Error("silhouette: no views");
  RayTracer tracer(mesh);
  SilhouetteResult r;
  r.iou_before.resize(views.size());
  r.iou_after.resize(views.size());
  ParallelFor(long(views.size()), o.threads, [&](long v) {
    r.iou_before[v] = MaskIoU(RenderWithTracer(tracer, init, views[v].camera, views[v].cam_from_world), views[v].mask);
  });
  std::vector<Image> sdf(views.size());
  std::vector<std::unique_ptr<ceres::Grid2D<float, 1>>> grids;
  std::vector<std::unique_ptr<ceres::BiCubicInterpolator<ceres::Grid2D<float, 1>>>> interp;
  for (size_t v = 0; v < views.size(); ++v) {
    const Image& m = views[v].mask;
    if (m.width != views[v].camera.width || m.height != views[v].camera.height)
      throw Error(Msg("silhouette: view ", v, ": mask size ", m.width, "x", m.height, " differs from the camera's"));
    sdf[v] = SignedDistance(m);
    grids.emplace_back(new ceres::Grid2D<float, 1>(sdf[v].pixels.data(), 0, m.height, 0, m.width));
    interp.emplace_back(new ceres::BiCubicInterpolator<ceres::Grid2D<float, 1>>(*grids.back()));
  }
  // Pose = rotation about the mesh's centroid, then translation.
  Vec3 centroid = Vec3::Zero();
  for (const Vec3& p : mesh.positions) centroid += p;
  centroid /= double(mesh.positions.size());
  Rigid3 current = init;
  Progress progress("silhouette registration", o.outer_iterations, o.progress);
  for (int it = 0; it < o.outer_iterations; ++it) {
    std::vector<std::vector<Vec3>> contour(views.size());
    ParallelFor(long(views.size()), o.threads, [&](long v) {
      contour[v] = ContourPoints(mesh, tracer, current, views[v].cam_from_world, o.max_points_per_view);
    });
    const Vec3 pivot = current * centroid;
    double omega[3] = {0, 0, 0}, t[3] = {0, 0, 0};
    ceres::Problem::Options po;
    ceres::Problem problem(po);
    long count = 0;
    for (size_t v = 0; v < views.size(); ++v)
      for (const Vec3& p : contour[v]) {
        const Vec3 y = current.rotation * (p - centroid);
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ContourCost, 1, 3, 3>(
                                     new ContourCost(y, pivot, views[v].cam_from_world, views[v].camera, interp[v].get())),
                                 new ceres::HuberLoss(o.huber_px), omega, t);
        ++count;
      }
    if (count < 6) throw Error("silhouette: fewer than 6 contour points in all views; is the mesh in view?");
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = 50;
    so.num_threads = ResolveThreads(o.threads);
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    const Vec3 w(omega[0], omega[1], omega[2]);
    const Eigen::Quaterniond dq = w.norm() > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized()))
                                               : Eigen::Quaterniond::Identity();
    Rigid3 next;
    next.rotation = (dq * current.rotation).normalized();
    next.translation = pivot + Vec3(t[0], t[1], t[2]) - next.rotation * centroid;
    current = next;
    r.mean_distance_px = count ? std::sqrt(2 * summary.final_cost / count) : 0;
    progress.Tick();
  }
  progress.Finish();
  r.world_from_object = current;
  ParallelFor(long(views.size()), o.threads, [&](long v) {
    r.iou_after[v] = MaskIoU(RenderWithTracer(tracer, current, views[v].camera, views[v].cam_from_world), views[v].mask);
  });
  return r;
}

}  // namespace svbrdf
