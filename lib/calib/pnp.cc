#include "calib/pnp.h"

#include <opencv2/calib3d.hpp>

#include "core/error.h"

namespace svbrdf {

Rigid3 SolveBoardPose(const Camera& cam, const BoardSpec& board, const BoardDetection& det,
                      const std::string& context) {
  if (det.points.size() < 4) throw Error(Msg(context, ": only ", det.points.size(), " board points for PnP (need 4)"));
  const std::vector<Vec3> obj = board.ObjectPoints();
  std::vector<cv::Point3d> op;
  std::vector<cv::Point2d> ip;
  for (size_t i = 0; i < det.points.size(); ++i) {
    op.emplace_back(obj[det.ids[i]].x(), obj[det.ids[i]].y(), obj[det.ids[i]].z());
    ip.emplace_back(det.points[i].x(), det.points[i].y());  // COLMAP convention, matching cx, cy below
  }
  cv::Mat K = (cv::Mat_<double>(3, 3) << cam.fx(), 0, cam.cx(), 0, cam.fy(), cam.cy(), 0, 0, 1);
  cv::Mat dist = cv::Mat::zeros(4, 1, CV_64F);
  const auto& p = cam.params;
  switch (cam.model) {
    case CameraModelId::kSimpleRadial: dist.at<double>(0) = p[3]; break;
    case CameraModelId::kRadial: dist.at<double>(0) = p[3], dist.at<double>(1) = p[4]; break;
    case CameraModelId::kOpenCV: for (int k = 0; k < 4; ++k) dist.at<double>(k) = p[4 + k]; break;
    default: break;
  }
  cv::Mat rvec, tvec;
  if (!cv::solvePnP(op, ip, K, dist, rvec, tvec, false, cv::SOLVEPNP_ITERATIVE))
    throw Error(Msg(context, ": PnP failed"));
  const Vec3 r(rvec.at<double>(0), rvec.at<double>(1), rvec.at<double>(2));
  Rigid3 pose;
  if (r.norm() > 0) pose.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(r.norm(), r.normalized()));
  pose.translation = Vec3(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  return pose;
}

}  // namespace svbrdf
