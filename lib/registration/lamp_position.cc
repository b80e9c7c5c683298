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

LampRefineResult RefineLampPositionMultiStart(const std::vector<HighlightObservation>& obs,
                                              const std::vector<MirrorSphere>& spheres, const std::vector<Ray3>& rays,
                                              const Vec3& intersection, const LampRefineOptions& o) {
  std::vector<Vec3> starts{intersection};
  for (double d = 0.1; d < 7; d *= 2) {
    Vec3 mean = Vec3::Zero();
    for (const Ray3& r : rays) mean += r.origin + d * r.direction;
    starts.push_back(mean / double(rays.size()));
  }
  LampRefineResult best;
  bool first = true;
  for (const Vec3& start : starts) {
    const LampRefineResult r = RefineLampPosition(obs, spheres, start, o);
    if (first || r.rms_px < best.rms_px) best = r;
    first = false;
  }
  // Outliers: misses by more than 3 px and 5x the median miss.
  std::vector<double> miss;
  for (const HighlightObservation& h : obs) miss.push_back(Rms({h}, spheres, best.position));
  std::vector<double> sorted = miss;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double bound = std::max(3.0, 5 * sorted[sorted.size() / 2]);
  std::vector<HighlightObservation> inliers;
  for (size_t i = 0; i < obs.size(); ++i)
    if (miss[i] <= bound) inliers.push_back(obs[i]);
  if (inliers.size() < obs.size() && inliers.size() >= 2) {
    const int rejected = int(obs.size() - inliers.size());
    best = RefineLampPosition(inliers, spheres, best.position, o);
    best.rejected = rejected;
  }
  best.initial_rms_px = Rms(obs, spheres, intersection);
  return best;
}

void LampPaperOptions::Check() const {
  if (!(highlight_px > 0) || !(paper_relative > 0)) throw Error("lamp refinement: noise scales must be > 0");
  if (max_samples < 10) throw Error("lamp refinement: max_samples must be >= 10");
}

namespace {

// Paper values (grey) at x_i with normals n_i: for a lamp position, the best
// (A, K) >= 0 in closed form, and the relative residuals.
struct PaperFit {
  std::vector<Vec3> points, normals;
  std::vector<double> values;
  // g_i = cos_i / r_i^2 for lamp p (T: double or Jet).
  template <class T>
  T Geometry(size_t i, const T* p) const {
    const T d[3] = {p[0] - points[i].x(), p[1] - points[i].y(), p[2] - points[i].z()};
    const T r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    using std::sqrt;
    const T cos = (d[0] * normals[i].x() + d[1] * normals[i].y() + d[2] * normals[i].z()) / sqrt(r2);
    return cos / r2;
  }
  double typical = 1;  // median value: residuals are relative to it
  bool with_ambient = false;
  // Least squares of v = A + K g; A clamped at 0.
  template <class T>
  void Solve(const T* p, T* A, T* K) const {
    T s00 = T(0), s01 = T(0), s11 = T(0), b0 = T(0), b1 = T(0);
    for (size_t i = 0; i < values.size(); ++i) {
      const T g = Geometry(i, p);
      const double w = 1.0;
      s00 += T(w), s01 += T(w) * g, s11 += T(w) * g * g, b0 += T(w * values[i]), b1 += T(w * values[i]) * g;
    }
    const T det = s00 * s11 - s01 * s01;
    *A = (s11 * b0 - s01 * b1) / det;
    *K = (s00 * b1 - s01 * b0) / det;
    if (*A < T(0) || !with_ambient) *A = T(0), *K = b1 / s11;
  }
};

struct PaperCost {
  const PaperFit* fit;
  double scale;
  template <class T>
  bool operator()(T const* const* params, T* residual) const {
    const T* p = params[0];
    T A, K;
    fit->Solve(p, &A, &K);
    for (size_t i = 0; i < fit->values.size(); ++i)
      residual[i] = (A + K * fit->Geometry(i, p) - T(fit->values[i])) / T(fit->typical * scale);
    return true;
  }
};

struct ScaledHighlightCost {
  HighlightCost cost;
  double scale;
  template <class T>
  bool operator()(const T* lamp, T* residual) const {
    cost(lamp, residual);
    residual[0] /= T(scale), residual[1] /= T(scale);
    return true;
  }
};

}  // namespace

LampPaperResult RefineLampWithPaper(const std::vector<HighlightObservation>& obs,
                                    const std::vector<MirrorSphere>& spheres,
                                    const std::vector<DiffuseSample>& paper, const Vec3& initial,
                                    const LampPaperOptions& o) {
  o.Check();
  PaperFit fit;
  const size_t step = std::max<size_t>(1, paper.size() / size_t(o.max_samples));
  for (size_t i = 0; i < paper.size(); i += step) {
    const double v = paper[i].value.mean() / paper[i].exposure;
    if (!(v > 0)) continue;
    fit.points.push_back(paper[i].point);
    fit.normals.push_back(paper[i].normal);
    fit.values.push_back(v);
  }
  // Paper in a shadow the start did not predict (or lit by a reflection)
  // departs from v ~ g by far more than the model's error: left out.
  {
    std::vector<double> ratio;
    for (size_t i = 0; i < fit.values.size(); ++i) ratio.push_back(fit.values[i] / fit.Geometry(i, initial.data()));
    std::vector<double> sorted = ratio;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double median = sorted.empty() ? 0.0 : sorted[sorted.size() / 2];
    PaperFit kept;
    for (size_t i = 0; i < fit.values.size(); ++i)
      if (ratio[i] > 0.7 * median && ratio[i] < 1.4 * median) {
        kept.points.push_back(fit.points[i]);
        kept.normals.push_back(fit.normals[i]);
        kept.values.push_back(fit.values[i]);
      }
    fit = kept;
  }
  if (fit.values.size() < 10) throw Error("lamp refinement: fewer than 10 paper samples");
  {
    std::vector<double> sorted = fit.values;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    fit.typical = sorted[sorted.size() / 2];
  }
  LampPaperResult r;
  r.position = initial;
  ceres::Problem problem;
  for (const HighlightObservation& h : obs)
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ScaledHighlightCost, 2, 3>(
                                 new ScaledHighlightCost{HighlightCost(h, spheres[h.sphere]), o.highlight_px}),
                             new ceres::CauchyLoss(3.0), r.position.data());
  auto* paper_cost = new ceres::DynamicAutoDiffCostFunction<PaperCost, 4>(new PaperCost{&fit, o.paper_relative});
  paper_cost->AddParameterBlock(3);
  paper_cost->SetNumResiduals(int(fit.values.size()));
  problem.AddResidualBlock(paper_cost, nullptr, r.position.data());
  ceres::Solver::Options so;
  so.max_num_iterations = 100;
  so.linear_solver_type = ceres::DENSE_QR;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  fit.with_ambient = true;
  fit.Solve(r.position.data(), &r.ambient, &r.K);
  r.ambient_share = r.ambient / fit.typical;
  r.highlight_rms_px = obs.empty() ? 0.0 : Rms(obs, spheres, r.position);
  double sum = 0;
  for (size_t i = 0; i < fit.values.size(); ++i)
    sum += std::pow((r.ambient + r.K * fit.Geometry(i, r.position.data()) - fit.values[i]) / fit.typical, 2);
  r.paper_rms_relative = std::sqrt(sum / fit.values.size());
  return r;
}

}  // namespace svbrdf
