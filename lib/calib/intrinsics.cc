#include "calib/intrinsics.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/colmap_text.h"
#include "calib/cv_bridge.h"
#include "core/error.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "io/scene.h"

namespace svbrdf {

namespace fs = std::filesystem;

void CalibrateOptions::Check() const {
  board.Check();
  if (model == CameraModelId::kOrthographic)
    throw Error("calibrate: ORTHOGRAPHIC is not calibrated from boards (photometric rigs: svbrdf import-ps)");
  if (min_points < 4) throw Error("calibrate: min_points must be >= 4");
  if (!(reject_factor > 1)) throw Error("calibrate: reject_factor must be > 1");
  if (min_views < 1) throw Error("calibrate: min_views must be >= 1");
  if (!(point_outlier_factor > 1) || !(min_point_outlier_px >= 0))
    throw Error("calibrate: point_outlier_factor must be > 1 and min_point_outlier_px >= 0");
}

namespace {

int CalibFlags(CameraModelId model) {
  const int no_radial = cv::CALIB_FIX_K1 | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3;
  switch (model) {
    case CameraModelId::kSimplePinhole: return cv::CALIB_FIX_ASPECT_RATIO | cv::CALIB_ZERO_TANGENT_DIST | no_radial;
    case CameraModelId::kPinhole: return cv::CALIB_ZERO_TANGENT_DIST | no_radial;
    case CameraModelId::kSimpleRadial:
      return cv::CALIB_FIX_ASPECT_RATIO | cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3;
    case CameraModelId::kRadial: return cv::CALIB_FIX_ASPECT_RATIO | cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_FIX_K3;
    case CameraModelId::kOpenCV: return cv::CALIB_FIX_K3;
    case CameraModelId::kOrthographic: break;  // rejected by CalibrateOptions::Check
  }
  return 0;
}

Camera ToColmapCamera(CameraModelId model, int w, int h, const cv::Mat& K, const cv::Mat& dist) {
  Camera c;
  c.id = 1;
  c.model = model;
  c.width = w;
  c.height = h;
  const double fx = K.at<double>(0, 0), fy = K.at<double>(1, 1), cx = K.at<double>(0, 2), cy = K.at<double>(1, 2);
  const double k1 = dist.at<double>(0), k2 = dist.at<double>(1), p1 = dist.at<double>(2), p2 = dist.at<double>(3);
  switch (model) {
    case CameraModelId::kSimplePinhole: c.params = {fx, cx, cy}; break;
    case CameraModelId::kPinhole: c.params = {fx, fy, cx, cy}; break;
    case CameraModelId::kSimpleRadial: c.params = {fx, cx, cy, k1}; break;
    case CameraModelId::kRadial: c.params = {fx, cx, cy, k1, k2}; break;
    case CameraModelId::kOpenCV: c.params = {fx, fy, cx, cy, k1, k2, p1, p2}; break;
    case CameraModelId::kOrthographic: throw Error("calibrate: ORTHOGRAPHIC is not calibrated from boards");
  }
  return c;
}

Rigid3 FromRvecTvec(const cv::Mat& rvec, const cv::Mat& tvec) {
  const Vec3 r(rvec.at<double>(0), rvec.at<double>(1), rvec.at<double>(2));
  Rigid3 p;
  p.rotation = r.norm() > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(r.norm(), r.normalized()))
                            : Eigen::Quaterniond::Identity();
  p.translation = Vec3(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  return p;
}

// One calibrateCamera run over the views marked used; fills residuals, rms, poses.
double Fit(std::vector<ViewCalibration>& views, int w, int h, const CalibrateOptions& o, Camera* cam) {
  const std::vector<Vec3> obj = o.board.ObjectPoints();
  std::vector<std::vector<cv::Point3f>> object_points;
  std::vector<std::vector<cv::Point2f>> image_points;
  std::vector<int> index;
  for (size_t v = 0; v < views.size(); ++v) {
    if (!views[v].used) continue;
    std::vector<cv::Point3f> op;
    std::vector<cv::Point2f> ip;
    for (size_t i = 0; i < views[v].ids.size(); ++i) {
      const Vec3& X = obj[views[v].ids[i]];
      op.emplace_back(float(X.x()), float(X.y()), float(X.z()));
      ip.emplace_back(float(views[v].points[i].x()), float(views[v].points[i].y()));
    }
    object_points.push_back(op);
    image_points.push_back(ip);
    index.push_back(int(v));
  }
  cv::Mat K = cv::Mat::eye(3, 3, CV_64F), dist = cv::Mat::zeros(5, 1, CV_64F);
  std::vector<cv::Mat> rvecs, tvecs;
  const double rms = cv::calibrateCamera(object_points, image_points, cv::Size(w, h), K, dist, rvecs, tvecs,
                                         CalibFlags(o.model),
                                         cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12));
  *cam = ToColmapCamera(o.model, w, h, K, dist);
  for (size_t k = 0; k < index.size(); ++k) {
    ViewCalibration& view = views[index[k]];
    view.cam_from_board = FromRvecTvec(rvecs[k], tvecs[k]);
    std::vector<cv::Point2f> proj;
    cv::projectPoints(object_points[k], rvecs[k], tvecs[k], K, dist, proj);
    double sum = 0;
    view.residuals.clear();
    for (size_t i = 0; i < proj.size(); ++i) {
      const Vec2 r(proj[i].x - image_points[k][i].x, proj[i].y - image_points[k][i].y);
      view.residuals.push_back(r);
      sum += r.squaredNorm();
    }
    view.rms = std::sqrt(sum / std::max<size_t>(1, proj.size()));
  }
  return rms;
}

}  // namespace

CalibrationResult CalibrateFromDetections(std::vector<ViewCalibration> views, int w, int h,
                                          const CalibrateOptions& o) {
  o.Check();
  auto count_used = [&] { return int(std::count_if(views.begin(), views.end(), [](auto& v) { return v.used; })); };
  auto too_few = [&](const char* stage) {
    std::string why;
    for (const auto& v : views)
      if (!v.used) why += Msg("\n  ", v.name, ": ", v.why);
    return Error(Msg("calibrate: only ", count_used(), " usable view(s) ", stage, ", need ", o.min_views, why));
  };
  const std::vector<Vec3> obj = o.board.ObjectPoints();
  for (auto& v : views) {
    if (v.used && int(v.points.size()) < o.min_points) {
      v.used = false;
      v.why = Msg("only ", v.points.size(), " board points (need ", o.min_points, ")");
    }
    if (!v.used) continue;
    // Points along one line (a partly hidden ChArUco board) do not fix a homography.
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    Vec2 mean = Vec2::Zero();
    for (int id : v.ids) mean += obj[id].head<2>() / double(v.ids.size());
    for (int id : v.ids) cov += (obj[id].head<2>() - mean) * (obj[id].head<2>() - mean).transpose();
    const double min_spread = std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov / double(v.ids.size())).eigenvalues()[0]);
    if (min_spread < 0.5 * o.board.square) {
      v.used = false;
      v.why = Msg("board points nearly collinear (spread ", min_spread / o.board.square, " squares)");
    }
  }
  if (count_used() < o.min_views) throw too_few("with the board");
  CalibrationResult r;
  r.rms_all_found = Fit(views, w, h, o, &r.camera);
  // Reject single points far off the fit (a corner whose refinement window
  // caught an occluder's edge, e.g. a mirror ball standing on the board),
  // then refit: one such corner costs more than the rest of its view gives.
  std::vector<double> norms;
  for (const auto& v : views)
    if (v.used)
      for (const Vec2& res : v.residuals) norms.push_back(res.norm());
  std::nth_element(norms.begin(), norms.begin() + norms.size() / 2, norms.end());
  const double point_limit = std::max(o.min_point_outlier_px, o.point_outlier_factor * norms[norms.size() / 2]);
  int dropped_points = 0;
  for (auto& v : views) {
    if (!v.used) continue;
    ViewCalibration kept = v;
    kept.ids.clear();
    kept.points.clear();
    for (size_t i = 0; i < v.ids.size(); ++i)
      if (v.residuals[i].norm() <= point_limit) kept.ids.push_back(v.ids[i]), kept.points.push_back(v.points[i]);
    if (kept.ids.size() == v.ids.size() || int(kept.ids.size()) < o.min_points) continue;
    dropped_points += int(v.ids.size() - kept.ids.size());
    kept.outlier_points = int(v.ids.size() - kept.ids.size());
    v = std::move(kept);
  }
  double rms_now = dropped_points > 0 ? Fit(views, w, h, o, &r.camera) : r.rms_all_found;
  // Reject outlier views (blur, misdetection) once, then refit.
  std::vector<double> rms;
  for (const auto& v : views)
    if (v.used) rms.push_back(v.rms);
  std::nth_element(rms.begin(), rms.begin() + rms.size() / 2, rms.end());
  const double median = rms[rms.size() / 2];
  const double limit = std::max(0.5, o.reject_factor * median);
  bool rejected = false;
  for (auto& v : views)
    if (v.used && v.rms > limit && count_used() > o.min_views) {
      v.used = false;
      v.why = Msg("reprojection RMS ", v.rms, " px > ", o.reject_factor, " x median ", median, " px");
      rejected = true;
    }
  r.rms = rejected ? Fit(views, w, h, o, &r.camera) : rms_now;
  r.outlier_points = dropped_points;
  r.used_views = count_used();
  r.views = std::move(views);
  return r;
}

CalibrationResult CalibrateIntrinsics(const std::vector<std::string>& paths, const CalibrateOptions& o) {
  o.Check();
  if (paths.empty()) throw Error("calibrate: no images given");
  std::vector<ViewCalibration> views(paths.size());
  std::vector<std::pair<int, int>> sizes(paths.size());
  Progress progress("detect board", long(paths.size()), o.progress);
  ParallelFor(long(paths.size()), 0, [&](long i) {
    ViewCalibration& v = views[i];
    v.name = fs::path(paths[i]).filename().string();
    const Image img = ReadImage(paths[i]);
    sizes[i] = {img.width, img.height};
    const BoardDetection det = DetectBoard(img, o.board);
    v.used = det.found;
    v.why = det.why;
    v.ids = det.ids;
    v.points = det.points;
    progress.Tick();
  });
  progress.Finish();
  for (size_t i = 1; i < paths.size(); ++i)
    if (sizes[i] != sizes[0])
      throw Error(Msg("calibrate: ", paths[i], " is ", sizes[i].first, "x", sizes[i].second, " but ", paths[0],
                      " is ", sizes[0].first, "x", sizes[0].second, "; calibrate one camera at a time"));
  return CalibrateFromDetections(std::move(views), sizes[0].first, sizes[0].second, o);
}

nlohmann::json CalibrationResult::ToJson() const {
  nlohmann::json views_json = nlohmann::json::array();
  for (const auto& v : views) {
    nlohmann::json j = {{"image", v.name}, {"used", v.used}, {"points", v.points.size()}};
    if (v.outlier_points > 0) j["outlier_points_dropped"] = v.outlier_points;
    if (!v.residuals.empty()) j["rms_px"] = v.rms;
    if (!v.used) j["rejected_because"] = v.why;
    else
      j["cam_from_board"] = {{"q", {v.cam_from_board.rotation.w(), v.cam_from_board.rotation.x(),
                                    v.cam_from_board.rotation.y(), v.cam_from_board.rotation.z()}},
                             {"t", {v.cam_from_board.translation.x(), v.cam_from_board.translation.y(),
                                    v.cam_from_board.translation.z()}}};
    views_json.push_back(j);
  }
  return {{"camera",
           {{"model", CameraModelName(camera.model)}, {"width", camera.width}, {"height", camera.height},
            {"params", camera.params}, {"pixel_convention", "COLMAP: centre of the top-left pixel at (0.5, 0.5)"},
            {"opencv_principal_point", {camera.cx() - 0.5, camera.cy() - 0.5}}}},
          {"rms_px", rms},
          {"rms_px_before_rejection", rms_all_found},
          {"outlier_points_dropped", outlier_points},
          {"used_views", used_views},
          {"views", views_json}};
}

namespace {

cv::Scalar Colour(double residual_px) {  // green (0) .. red (>= 1 px), BGR
  const double t = std::clamp(residual_px, 0.0, 1.0);
  return cv::Scalar(0, 255 * (1 - t), 255 * t);
}

void SaveBgr(const cv::Mat& bgr, const std::string& path) {
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  WriteImage(path, FromCv(rgb), PixelFormat::kUInt8, ColorSpace::kLinear);
}

}  // namespace

void WriteCalibration(const CalibrationResult& r, const std::vector<std::string>& paths, const std::string& out) {
  fs::create_directories(out);
  WriteColmapCameras({r.camera}, (fs::path(out) / "cameras.txt").string());
  WriteFileAtomic((fs::path(out) / "calibration.json").string(), r.ToJson().dump(2) + "\n");
  const double gain = 20.0;  // residual vectors are drawn magnified
  // Residual field of all used views over the image plane.
  const int w = r.camera.width, h = r.camera.height;
  cv::Mat field(h, w, CV_8UC3, cv::Scalar(30, 30, 30));
  for (const auto& v : r.views) {
    if (!v.used) continue;
    for (size_t i = 0; i < v.points.size(); ++i) {
      const cv::Point2d p(v.points[i].x() - 0.5, v.points[i].y() - 0.5);
      const cv::Point2d q = p + gain * cv::Point2d(v.residuals[i].x(), v.residuals[i].y());
      cv::line(field, p, q, Colour(v.residuals[i].norm()), 1, cv::LINE_AA);
      cv::circle(field, p, 1, cv::Scalar(200, 200, 200), cv::FILLED);
    }
  }
  cv::putText(field, Msg("residuals x", gain, ", RMS ", std::round(r.rms * 1000) / 1000, " px"), cv::Point(8, 20),
              cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  SaveBgr(field, (fs::path(out) / "residuals.png").string());
  for (size_t k = 0; k < r.views.size(); ++k) {
    const auto& v = r.views[k];
    if (!v.used || k >= paths.size()) continue;
    const Image img = ReadImage(paths[k]);
    cv::Mat grey = ToCv8(ToDisplayGrey(img, IsHighDynamicRange(img))), bgr;
    cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
    for (size_t i = 0; i < v.points.size(); ++i) {
      const cv::Point2d p(v.points[i].x() - 0.5, v.points[i].y() - 0.5);
      cv::circle(bgr, p, 3, cv::Scalar(255, 160, 0), 1, cv::LINE_AA);
      cv::line(bgr, p, p + gain * cv::Point2d(v.residuals[i].x(), v.residuals[i].y()), Colour(v.residuals[i].norm()),
               1, cv::LINE_AA);
    }
    cv::putText(bgr, Msg(v.name, ": ", v.points.size(), " points, RMS ", std::round(v.rms * 1000) / 1000, " px"),
                cv::Point(8, 20), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 255, 255), 1, cv::LINE_AA);
    SaveBgr(bgr, (fs::path(out) / "corners.png").string());
    break;
  }
}

}  // namespace svbrdf
