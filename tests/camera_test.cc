#include "camera/camera.h"

#include <gtest/gtest.h>

#include "core/error.h"

namespace svbrdf {
namespace {

Camera MakeCamera(CameraModelId model) {
  Camera c;
  c.model = model;
  c.width = 640;
  c.height = 480;
  switch (model) {
    case CameraModelId::kSimplePinhole: c.params = {500, 320, 240}; break;
    case CameraModelId::kPinhole: c.params = {500, 520, 321.5, 239.25}; break;
    case CameraModelId::kSimpleRadial: c.params = {500, 320, 240, -0.12}; break;
    case CameraModelId::kRadial: c.params = {500, 320, 240, -0.1, 0.03}; break;
    case CameraModelId::kOpenCV: c.params = {500, 510, 320, 240, -0.1, 0.02, 0.001, -0.002}; break;
    default: break;  // the perspective models only: the tests below pass no other
  }
  return c;
}

const CameraModelId kAllModels[] = {CameraModelId::kSimplePinhole, CameraModelId::kPinhole,
                                    CameraModelId::kSimpleRadial, CameraModelId::kRadial, CameraModelId::kOpenCV};

TEST(Camera, ParameterCountsAndNames) {
  EXPECT_EQ(CameraModelNumParams(CameraModelId::kSimplePinhole), 3);
  EXPECT_EQ(CameraModelNumParams(CameraModelId::kPinhole), 4);
  EXPECT_EQ(CameraModelNumParams(CameraModelId::kSimpleRadial), 4);
  EXPECT_EQ(CameraModelNumParams(CameraModelId::kRadial), 5);
  EXPECT_EQ(CameraModelNumParams(CameraModelId::kOpenCV), 8);
  for (CameraModelId m : kAllModels) {
    EXPECT_EQ(CameraModelFromName(CameraModelName(m), "test"), m);
    EXPECT_EQ(static_cast<int>(MakeCamera(m).params.size()), CameraModelNumParams(m));
  }
}

TEST(Camera, UnknownModelNameIsAnErrorNamingContext) {
  try {
    CameraModelFromName("FISHEYE", "scene.json: cameras[0].model");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("scene.json: cameras[0].model"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("FISHEYE"), std::string::npos);
  }
}

TEST(Camera, ProjectUnprojectRoundTripEveryModel) {
  for (CameraModelId m : kAllModels) {
    const Camera cam = MakeCamera(m);
    for (double px : {0.5, 100.0, 320.0, 639.5})
      for (double py : {0.5, 77.0, 240.0, 479.5}) {
        const Vec3 ray = cam.Unproject(Vec2(px, py));
        EXPECT_DOUBLE_EQ(ray.z(), 1.0);
        const Vec2 back = cam.Project(2.5 * ray);
        EXPECT_NEAR(back.x(), px, 1e-6) << CameraModelName(m);
        EXPECT_NEAR(back.y(), py, 1e-6) << CameraModelName(m);
      }
  }
}

TEST(Camera, DistortionFormulasMatchColmap) {
  const Vec2 x(0.2, -0.1);
  const double r2 = 0.05;
  Camera c = MakeCamera(CameraModelId::kSimpleRadial);
  EXPECT_NEAR(c.Distort(x).x(), 0.2 * (1 - 0.12 * r2), 1e-15);
  c = MakeCamera(CameraModelId::kRadial);
  EXPECT_NEAR(c.Distort(x).y(), -0.1 * (1 - 0.1 * r2 + 0.03 * r2 * r2), 1e-15);
  c = MakeCamera(CameraModelId::kOpenCV);
  const double radial = 1 - 0.1 * r2 + 0.02 * r2 * r2, p1 = 0.001, p2 = -0.002;
  EXPECT_NEAR(c.Distort(x).x(), 0.2 * radial + 2 * p1 * 0.2 * -0.1 + p2 * (r2 + 2 * 0.04), 1e-15);
  EXPECT_NEAR(c.Distort(x).y(), -0.1 * radial + 2 * p2 * 0.2 * -0.1 + p1 * (r2 + 2 * 0.01), 1e-15);
}

TEST(Camera, PixelCentreConvention) {
  for (CameraModelId m : kAllModels) {
    const Camera cam = MakeCamera(m);
    // The optical axis hits the principal point.
    const Vec2 c = cam.Project(Vec3(0, 0, 3));
    EXPECT_NEAR(c.x(), cam.cx(), 1e-12);
    EXPECT_NEAR(c.y(), cam.cy(), 1e-12);
  }
  // With a pinhole, a point projecting to (0.5, 0.5) is the centre of pixel
  // (0, 0): pixel = f x / z + c, no half-pixel shift.
  const Camera cam = MakeCamera(CameraModelId::kPinhole);
  const Vec3 p((0.5 - cam.cx()) / cam.fx(), (0.5 - cam.cy()) / cam.fy(), 1.0);
  const Vec2 px = cam.Project(4.0 * p);
  EXPECT_NEAR(px.x(), 0.5, 1e-12);
  EXPECT_NEAR(px.y(), 0.5, 1e-12);
  EXPECT_EQ(static_cast<int>(std::floor(px.x())), 0);
  EXPECT_EQ(static_cast<int>(std::floor(px.y())), 0);
}

TEST(Rigid3, InverseRoundTrip) {
  Rigid3 T;
  T.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  T.translation = Vec3(0.3, -1, 2);
  const Vec3 x(1.5, -0.25, 4);
  EXPECT_TRUE((T.Inverse() * (T * x)).isApprox(x, 1e-12));
  EXPECT_TRUE((T.Inverse().Inverse() * x).isApprox(T * x, 1e-12));
  // Centre maps to the camera origin.
  EXPECT_LT((T * T.CentreInWorld()).norm(), 1e-12);
}

TEST(Rigid3, LookAtPutsTargetOnAxisWithProperRotation) {
  const Vec3 eye(1, 2, 3), target(0.1, -0.2, 0.3), up(0, 1, 0);
  const Rigid3 T = Rigid3::LookAt(eye, target, up);
  const Mat3 R = T.rotation.toRotationMatrix();
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  EXPECT_TRUE((R * R.transpose()).isApprox(Mat3::Identity(), 1e-12));
  const Vec3 t_cam = T * target;
  EXPECT_NEAR(t_cam.x(), 0, 1e-12);
  EXPECT_NEAR(t_cam.y(), 0, 1e-12);
  EXPECT_NEAR(t_cam.z(), (target - eye).norm(), 1e-12);
  EXPECT_TRUE(T.CentreInWorld().isApprox(eye, 1e-12));
  // Image y points down: world up maps to negative camera y.
  EXPECT_LT((T.rotation * up).y(), 0);
  // Camera x points right: looking down -z with y up, right is world +x.
  const Rigid3 S = Rigid3::LookAt(Vec3(0, 0, 3), Vec3::Zero(), up);
  EXPECT_TRUE((S.rotation * Vec3::UnitX()).isApprox(Vec3::UnitX(), 1e-12));
  // Degenerate up (parallel to the view direction) still gives a rotation.
  const Rigid3 D = Rigid3::LookAt(Vec3(0, 3, 0), Vec3::Zero(), up);
  EXPECT_NEAR(D.rotation.toRotationMatrix().determinant(), 1.0, 1e-12);
  EXPECT_NEAR((D * Vec3::Zero()).head<2>().norm(), 0, 1e-12);
}

// check_capture.py's quat_to_R for q = [w, x, y, z], transcribed.
Mat3 QuatToRPython(double w, double x, double y, double z) {
  Mat3 R;
  R << 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y), 2 * (x * y + w * z),
      1 - 2 * (x * x + z * z), 2 * (y * z - w * x), 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y);
  return R;
}

TEST(Rigid3, QuaternionOrderAgreesWithChecker) {
  const Eigen::Quaterniond q = Eigen::Quaterniond(Eigen::AngleAxisd(1.1, Vec3(-1, 0.5, 2).normalized()));
  // Eigen's constructor takes (w, x, y, z), the order scene.json stores.
  const Eigen::Quaterniond from_json(q.w(), q.x(), q.y(), q.z());
  EXPECT_TRUE(from_json.toRotationMatrix().isApprox(QuatToRPython(q.w(), q.x(), q.y(), q.z()), 1e-12));
}

}  // namespace
}  // namespace svbrdf
