// The front half of the pipeline on a synthetic raw photo set with hidden
// ground truth (lib/synth/raw_photos.h): intrinsics from the board, board
// poses (PnP + bundle adjustment), silhouette registration of the mesh,
// lamp positions from mirror spheres, HDR merging of brackets.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <fstream>
#include <random>
#include <sstream>
#include <unistd.h>

#include "calib/board.h"
#include "calib/colmap_text.h"
#include "calib/hdr.h"
#include "calib/intrinsics.h"
#include "calib/light_probe.h"
#include "calib/pnp.h"
#include "calib/segment.h"
#include "core/error.h"
#include "evaluate/metrics.h"
#include "io/scene.h"
#include "pipeline/reconstruction.h"
#include "relight/relight.h"
#include "registration/board_bundle.h"
#include "registration/capture_job.h"
#include "registration/colmap_sfm.h"
#include "registration/lamp_position.h"
#include "registration/project.h"
#include "registration/silhouette.h"
#include "synth/raw_photos.h"

namespace svbrdf {
namespace {

namespace fs = std::filesystem;

double AngleDeg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return Eigen::AngleAxisd(a * b.conjugate()).angle() * 180 / kPi;
}

// Raw-photo options with a ChArUco board (the suite's unless given) drawn
// into the scene.
RawPhotoOptions RawOptionsWithBoard(const BoardSpec& board = DefaultRawBoard()) {
  RawPhotoOptions o;
  const BoardTexture tex = DrawBoard(board, 48);
  o.board_texture = tex.image;
  o.texture_from_board = tex.texture_from_board;
  o.board_json = {{"pattern", "charuco"}, {"cols", board.cols}, {"rows", board.rows}, {"square", board.square},
                  {"marker", board.marker}, {"dictionary", board.dictionary},
                  {"layout", board.legacy_layout ? "legacy" : "new"}};
  return o;
}

// `capture` on PHOTOS_DIR into OUT_DIR, quiet, with one silhouette
// iteration (enough for the tests that check lights and poses, not the
// registration); DESCRIPTION defaults to PHOTOS_DIR/capture.json.
nlohmann::json QuickCapture(const std::string& photos_dir, const std::string& out_dir,
                            const std::string& description = "", int threads = 0) {
  CaptureJob job;
  job.photos_dir = photos_dir;
  job.description = description;
  job.out_dir = out_dir;
  job.progress = false;
  job.silhouette_iterations = 1;
  job.threads = threads;
  return RunCapture(job);
}

// One raw set shared by all tests of the suite: rendered once per process
// (tests/CMakeLists.txt runs this binary as one ctest test) in a temporary
// folder that TearDownTestSuite removes.
struct RawSet {
  std::string dir;
  RawPhotoTruth truth;
  nlohmann::json desc;
  std::vector<std::string> bracket0;  // calibration photos, then the longest exposure of every photo
  int num_calibration = 0;
  nlohmann::json capture_report;
};

class Registration : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    raw_ = new RawSet;
    std::string tmpl = (fs::temp_directory_path() / "svbrdf_raw_XXXXXX").string();
    if (!mkdtemp(tmpl.data())) throw Error("registration_test: cannot create a temporary folder");
    raw_->dir = tmpl + "/raw";
    RawPhotoOptions o = RawOptionsWithBoard();
    o.num_images = 12;
    o.num_heldout = 2;
    o.num_lamps = 3;
    o.num_calibration = 12;
    o.material.texture_size = 32;
    o.threads = 0;
    raw_->truth = SynthesizeRawPhotos(o, raw_->dir);
    raw_->desc = ReadJsonFile(raw_->dir + "/capture.json");
    for (const auto& p : raw_->desc["calibration_photos"]) raw_->bracket0.push_back(raw_->dir + "/" + p.get<std::string>());
    raw_->num_calibration = int(raw_->bracket0.size());
    for (const auto& p : raw_->desc["photos"]) raw_->bracket0.push_back(raw_->dir + "/" + p["files"][0].get<std::string>());
  }
  static void TearDownTestSuite() {
    fs::remove_all(fs::path(raw_->dir).parent_path());
    delete raw_;
    raw_ = nullptr;
  }
  static const RawSet& Raw() { return *raw_; }
  // `capture` on the raw set, run once for the tests that need it.
  static const nlohmann::json& CaptureReport() {
    if (raw_->capture_report.is_null()) {
      CaptureJob job;
      job.photos_dir = raw_->dir;
      job.out_dir = CaptureDir();
      job.progress = false;
      raw_->capture_report = RunCapture(job);
    }
    return raw_->capture_report;
  }
  static std::string CaptureDir() { return (fs::path(raw_->dir).parent_path() / "capture").string(); }
  static RawSet* raw_;
};
RawSet* Registration::raw_ = nullptr;

TEST(RegistrationMath, ProjectTMatchesCameraProject) {
  Camera c;
  c.model = CameraModelId::kOpenCV;
  c.params = {500, 510, 320, 240, -0.1, 0.03, 0.001, -0.002};
  const Vec3 x(0.1, -0.2, 1.3);
  double px[2];
  ProjectT(c.model, c.params.data(), x.data(), px);
  EXPECT_NEAR((Vec2(px[0], px[1]) - c.Project(x)).norm(), 0.0, 1e-9);
}

// The specular point obeys the mirror law, and the lamp refined in the
// images from highlights with 0.05 px noise lands near the truth from a
// start 3 cm off.
TEST(RegistrationMath, LampRefinedFromHighlightPixels) {
  Camera cam;
  cam.model = CameraModelId::kOpenCV;
  cam.width = 480, cam.height = 360;
  cam.params = {576, 576, 240, 180, -0.06, 0.02, 0, 0};
  const std::vector<MirrorSphere> spheres = {{Vec3(0.05, 0.06, -0.04), 0.04}, {Vec3(0.33, 0.22, -0.04), 0.04}};
  const Vec3 lamp(0.25, 0.05, -0.6), target(0.19, 0.14, 0);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0, 0.05);
  std::vector<HighlightObservation> obs;
  std::vector<Rigid3> poses;
  for (int i = 0; i < 8; ++i)
    poses.push_back(Rigid3::LookAt(target + Vec3(0.5 * std::cos(0.8 * i), 0.5 * std::sin(0.8 * i), -0.45), target, Vec3(0, 0, -1)));
  for (const Rigid3& p : poses)
    for (size_t s = 0; s < spheres.size(); ++s) {
      const Vec3 eye = p.CentreInWorld();
      Vec3 x;
      SpecularPoint(eye.data(), lamp.data(), spheres[s].centre.data(), spheres[s].radius, x.data());
      const Vec3 n = (x - spheres[s].centre) / spheres[s].radius;
      const Vec3 to_eye = (eye - x).normalized(), to_lamp = (lamp - x).normalized();
      EXPECT_NEAR(std::abs(n.norm() - 1), 0.0, 1e-12);
      EXPECT_NEAR((to_lamp - (2 * n.dot(to_eye) * n - to_eye)).norm(), 0.0, 1e-9);  // mirror law
      obs.push_back({&cam, p, int(s), cam.Project(p * x) + Vec2(noise(rng), noise(rng))});
    }
  const LampRefineResult r = RefineLampPosition(obs, spheres, lamp + Vec3(0.02, -0.015, 0.015), LampRefineOptions{});
  std::printf("lamp from highlights with 0.05 px noise: %.2f mm off, RMS %.3f -> %.3f px\n",
              1e3 * (r.position - lamp).norm(), r.initial_rms_px, r.rms_px);
  EXPECT_LT(1e3 * (r.position - lamp).norm(), 3.0);
  EXPECT_LT(r.rms_px, 0.1);
  EXPECT_GT(r.initial_rms_px, 0.5);
}

// One small ball (2 cm) and a lamp 45 cm above the board: highlights
// quantised to the pixel centre, as a sub-pixel highlight is imaged, fix the
// lamp's direction but hardly its distance; the board paper's shading
// (v = K cos / r^2, with 2 % ambient light and 1 % noise) fixes it. The
// multi-start also finds the lamp from the rays' intersection, which one
// ball draws to the ball itself.
TEST(RegistrationMath, OneBallLampFromHighlightsAndPaperShading) {
  Camera cam;
  cam.model = CameraModelId::kPinhole;
  cam.width = 640, cam.height = 480;
  cam.params = {768, 768, 320, 240};
  const std::vector<MirrorSphere> spheres = {{Vec3(0.05, 0.05, -0.02), 0.02}};
  const Vec3 lamp(0.285, -0.04, -0.45), target(0.17, 0.12, 0);
  std::vector<HighlightObservation> obs;
  std::vector<Ray3> rays;
  for (int i = 0; i < 16; ++i) {
    const Rigid3 p = Rigid3::LookAt(target + Vec3(0.45 * std::cos(0.39 * i), 0.45 * std::sin(0.39 * i), -0.35), target,
                                    Vec3(0, 0, -1));
    Vec3 x;
    SpecularPoint(p.CentreInWorld().data(), lamp.data(), spheres[0].centre.data(), spheres[0].radius, x.data());
    const Vec2 px = cam.Project(p * x);
    const Vec2 quantised(std::floor(px.x()) + 0.5, std::floor(px.y()) + 0.5);
    Ray3 ray;
    ASSERT_TRUE(ReflectedRay(cam, p, spheres[0], quantised, &ray));
    rays.push_back(ray);
    obs.push_back({&cam, p, 0, quantised});
  }
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0, 0.01);
  std::vector<DiffuseSample> paper;
  const double K = 0.11, ambient = 0.02 * K * 4.0;  // about 2 % of the lamp's light at the board's centre
  for (double x = 0.0; x <= 0.33; x += 0.01)
    for (double y = 0.0; y <= 0.24; y += 0.01) {
      DiffuseSample d;
      d.point = Vec3(x, y, 0);
      d.normal = Vec3(0, 0, -1);
      const Vec3 to = lamp - d.point;
      const double v = ambient + K * d.normal.dot(to.normalized()) / to.squaredNorm();
      d.value = Rgb::Constant(v * (1 + noise(rng)));
      d.albedo = 0.8;
      paper.push_back(d);
    }
  const Vec3 from_rays = NearestPointToRays(rays);
  const LampRefineResult hl = RefineLampPositionMultiStart(obs, spheres, rays, from_rays, LampRefineOptions{});
  const LampPaperResult joint = RefineLampWithPaper(obs, spheres, paper, hl.position, LampPaperOptions{});
  std::printf("one ball: rays' intersection %.1f mm off, highlights alone %.1f mm, with the paper's shading %.1f mm\n",
              1e3 * (from_rays - lamp).norm(), 1e3 * (hl.position - lamp).norm(), 1e3 * (joint.position - lamp).norm());
  EXPECT_GT(1e3 * (from_rays - lamp).norm(), 50.0);  // the degenerate intersection this guards against
  EXPECT_LT(1e3 * (joint.position - lamp).norm(), 10.0);
  EXPECT_LT(joint.highlight_rms_px, 0.5);
}

// A COLMAP text model in its own frame and units (a similarity away from the
// board frame), as `colmap model_converter` writes it, placed back in metres
// by the images whose board pose is known.
TEST(RegistrationMath, ColmapModelPlacedByBoardPoses) {
  std::vector<Rigid3> truth;
  for (int i = 0; i < 6; ++i)
    truth.push_back(Rigid3::LookAt(Vec3(0.5 * std::cos(i), 0.5 * std::sin(i), -0.4 - 0.03 * i), Vec3(0.1, 0.05, 0), Vec3(0, 0, -1)));
  const double s = 0.37;  // x_board = s * R * x_colmap + T
  const Eigen::Quaterniond R(Eigen::AngleAxisd(0.7, Vec3(1, -2, 0.5).normalized()));
  const Vec3 T(0.2, -0.1, 0.3);
  std::string tmpl = (fs::temp_directory_path() / "svbrdf_colmap_XXXXXX").string();
  ASSERT_TRUE(mkdtemp(tmpl.data()));
  {
    std::ofstream cams(tmpl + "/cameras.txt"), ims(tmpl + "/images.txt");
    cams << "# Camera list\n1 PINHOLE 480 360 500 500 240 180\n";
    ims << "# Image list\n";
    ims.precision(17);
    for (size_t i = 0; i < truth.size(); ++i) {
      const Eigen::Quaterniond q = truth[i].rotation * R;
      const Vec3 t = (truth[i].rotation * T + truth[i].translation) / s;
      ims << i + 1 << " " << q.w() << " " << q.x() << " " << q.y() << " " << q.z() << " " << t.x() << " " << t.y() << " "
          << t.z() << " 1 img" << i << ".png\n\n";
    }
  }
  const ColmapModel model = ReadColmapText(tmpl);
  fs::remove_all(tmpl);
  std::map<std::string, Rigid3> known;  // the board seen in 4 of the 6 images
  for (int i = 0; i < 4; ++i) known["img" + std::to_string(i) + ".png"] = truth[i];
  const ColmapToBoard align = AlignColmapToBoard(model, known);
  EXPECT_EQ(align.matched, 4);
  EXPECT_NEAR(align.scale, s, 1e-9);
  EXPECT_LT(align.centre_rms_m, 1e-9);
  for (size_t i = 0; i < truth.size(); ++i) {  // including the two without the board
    const Rigid3 p = align.CamFromBoard(model.images[i].cam_from_world);
    EXPECT_LT(AngleDeg(p.rotation, truth[i].rotation), 1e-6);
    EXPECT_LT((p.translation - truth[i].translation).norm(), 1e-9);
  }
  const ColmapToBoard by_distance = ScaleColmapByDistance(
      model, "img0.png", "img3.png", (truth[0].CentreInWorld() - truth[3].CentreInWorld()).norm());
  EXPECT_NEAR(by_distance.scale, s, 1e-9);
  // A known distance between two 3-D points of the model, by id or by
  // coordinates (model units), scales it to metres.
  ColmapModel with_points = model;
  const Vec3 pa(0.3, -0.2, 1.1), pb(-0.4, 0.5, 0.9);  // model units
  with_points.points[17] = {17, pa, 0.3};
  with_points.points[42] = {42, pb, 0.3};
  KnownDistance kd;
  kd.point_a = 17, kd.point_b = 42;
  kd.metres = s * (pa - pb).norm();
  EXPECT_NEAR(ScaleColmapByKnownDistance(with_points, kd).scale / s, 1.0, 1e-12);
  KnownDistance kp;
  kp.points = {pa, pb};
  kp.metres = kd.metres;
  EXPECT_NEAR(ScaleColmapByKnownDistance(model, kp).scale / s, 1.0, 1e-12);
  kd.point_b = 43;  // not in the model
  EXPECT_THROW(ScaleColmapByKnownDistance(with_points, kd), Error);
  known.erase("img0.png");
  known.erase("img1.png");
  EXPECT_THROW(AlignColmapToBoard(model, known), Error);  // two images cannot place a model
}

TEST_F(Registration, IntrinsicsFromSyntheticBoardViews) {
  const RawSet& raw = Raw();
  CalibrateOptions o;
  o.board = DefaultRawBoard();
  o.progress = false;
  const CalibrationResult r = CalibrateIntrinsics(raw.bracket0, o);
  const Camera& t = raw.truth.camera;
  std::printf("intrinsics: %d views, RMS %.3f px; fx %.3f (true %.3f), fy %.3f (%.3f), cx %.3f (%.3f), cy %.3f (%.3f), "
              "k1 %.4f (%.4f), k2 %.4f (%.4f)\n",
              r.used_views, r.rms, r.camera.fx(), t.fx(), r.camera.fy(), t.fy(), r.camera.cx(), t.cx(), r.camera.cy(),
              t.cy(), r.camera.params[4], t.params[4], r.camera.params[5], t.params[5]);
  EXPECT_GE(r.used_views, 15);
  EXPECT_LT(std::abs(r.camera.fx() / t.fx() - 1), 0.002);
  EXPECT_LT(std::abs(r.camera.fy() / t.fy() - 1), 0.002);
  EXPECT_LT(std::abs(r.camera.cx() - t.cx()), 0.5);  // issue 10: principal point within 0.5 px
  EXPECT_LT(std::abs(r.camera.cy() - t.cy()), 0.5);
  // Distortion: compare the displacement it causes at the image corner.
  Camera est = r.camera;
  const Vec2 corner((0 - t.cx()) / t.fx(), (0 - t.cy()) / t.fy());
  const double disp_err = ((est.Distort(corner) - t.Distort(corner)) * t.fx()).norm();
  std::printf("distortion error at the image corner: %.3f px (true displacement %.1f px)\n", disp_err,
              ((t.Distort(corner) - corner) * t.fx()).norm());
  EXPECT_LT(disp_err, 1.5);
}

TEST_F(Registration, BoardPosesPnpAndBundle) {
  const RawSet& raw = Raw();
  CalibrateOptions o;
  o.board = DefaultRawBoard();
  o.progress = false;
  const CalibrationResult cal = CalibrateIntrinsics(raw.bracket0, o);
  std::vector<Rigid3> poses;
  std::vector<BoardObservations> obs;
  std::vector<int> index;
  // Bundle over every view with the board (calibration photos constrain the
  // intrinsics); poses are compared for the object photos.
  for (size_t i = 0; i < cal.views.size(); ++i) {
    if (!cal.views[i].used) continue;
    BoardDetection det;
    det.ids = cal.views[i].ids;
    det.points = cal.views[i].points;
    poses.push_back(SolveBoardPose(cal.camera, o.board, det, cal.views[i].name));
    obs.push_back({det.ids, det.points});
    index.push_back(int(i));
  }
  const BundleResult ba = AdjustBoardBundle(cal.camera, poses, obs, o.board.ObjectPoints(), BundleOptions{});
  double worst_deg = 0, worst_mm = 0, worst_pnp_deg = 0, worst_pnp_mm = 0;
  int compared = 0;
  for (size_t k = 0; k < index.size(); ++k) {
    if (index[k] < raw.num_calibration) continue;
    ++compared;
    const Rigid3& t = raw.truth.cam_from_world[index[k] - raw.num_calibration];
    worst_deg = std::max(worst_deg, AngleDeg(ba.cam_from_board[k].rotation, t.rotation));
    worst_mm = std::max(worst_mm, 1e3 * (ba.cam_from_board[k].CentreInWorld() - t.CentreInWorld()).norm());
    worst_pnp_deg = std::max(worst_pnp_deg, AngleDeg(poses[k].rotation, t.rotation));
    worst_pnp_mm = std::max(worst_pnp_mm, 1e3 * (poses[k].CentreInWorld() - t.CentreInWorld()).norm());
  }
  EXPECT_GE(compared, 7);
  std::printf("poses (%d object views): PnP worst %.4f deg %.3f mm; bundle worst %.4f deg %.3f mm, RMS %.3f -> %.3f px\n",
              compared, worst_pnp_deg, worst_pnp_mm, worst_deg, worst_mm, ba.initial_rms_px, ba.rms_px);
  EXPECT_LT(worst_deg, 0.1);  // issue 10: 0.1 deg / 1 mm
  EXPECT_LT(worst_mm, 1.0);
}

TEST_F(Registration, SilhouettesFromPerturbedStart) {
  const RawSet& raw = Raw();
  const Mesh mesh = LoadMesh(raw.dir + "/mesh.obj");
  std::vector<SilhouetteView> views;
  for (size_t i = 0; i < raw.truth.cam_from_world.size(); ++i)
    views.push_back({raw.truth.camera, raw.truth.cam_from_world[i],
                     ReadImage(raw.dir + "/" + raw.desc["photos"][i]["mask"].get<std::string>())});
  // 5 degrees about an oblique axis and 2 cm off.
  Rigid3 start = raw.truth.world_from_object;
  start.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(5 * kPi / 180, Vec3(1, 2, -1).normalized())) * start.rotation;
  start.translation += Vec3(0.012, -0.011, 0.0115);
  SilhouetteOptions so;
  so.progress = false;
  const SilhouetteResult r = AlignSilhouettes(mesh, start, views, so);
  const double deg = AngleDeg(r.world_from_object.rotation, raw.truth.world_from_object.rotation);
  Vec3 centroid = Vec3::Zero();
  for (const Vec3& p : mesh.positions) centroid += p / double(mesh.positions.size());
  const double mm = 1e3 * (r.world_from_object * centroid - raw.truth.world_from_object * centroid).norm();
  double iou0 = 0, iou1 = 0;
  for (size_t v = 0; v < views.size(); ++v) iou0 += r.iou_before[v] / views.size(), iou1 += r.iou_after[v] / views.size();
  std::printf("silhouette registration: %.3f deg, %.3f mm from truth; mean IoU %.4f -> %.4f; contour distance %.3f px\n",
              deg, mm, iou0, iou1, r.mean_distance_px);
  EXPECT_LT(deg, 0.2);
  EXPECT_LT(mm, 1.0);
  EXPECT_GT(iou1, iou0);
}

TEST_F(Registration, LampPositionsFromMirrorSpheres) {
  const RawSet& raw = Raw();
  const double radius = raw.desc["mirror_spheres"]["radius"];
  std::vector<std::vector<Ray3>> rays(raw.truth.lamps.size());
  for (size_t i = 0; i < raw.truth.cam_from_world.size(); ++i) {
    std::vector<Image> shots;
    std::vector<double> exposures;
    const auto& p = raw.desc["photos"][i];
    for (size_t k = 0; k < p["files"].size(); ++k) {
      shots.push_back(ReadImage(raw.dir + "/" + p["files"][k].get<std::string>()));
      exposures.push_back(p["exposures"][k]);
    }
    const HdrResult hdr = MergeLinear(shots, exposures, HdrOptions{});
    for (const Vec3& c : raw.truth.sphere_centres) {
      Vec2 px;
      Ray3 ray;
      if (FindHighlight(hdr.radiance, raw.truth.camera, raw.truth.cam_from_world[i], {c, radius}, &px) &&
          ReflectedRay(raw.truth.camera, raw.truth.cam_from_world[i], {c, radius}, px, &ray))
        rays[raw.truth.photo_lamp[i]].push_back(ray);
    }
  }
  for (size_t l = 0; l < rays.size(); ++l) {
    double rms;
    const Vec3 x = NearestPointToRays(rays[l], &rms);
    const double err_mm = 1e3 * (x - raw.truth.lamps[l]).norm();
    std::printf("lamp %zu: %zu rays, error %.2f mm (ray RMS %.2f mm)\n", l, rays[l].size(), err_mm, 1e3 * rms);
    EXPECT_LT(err_mm, 5.0);
  }
}

TEST_F(Registration, HdrMergeIsLinear) {
  const RawSet& raw = Raw();
  const auto& p = raw.desc["photos"][0];
  std::vector<Image> shots;
  std::vector<double> exposures;
  for (size_t k = 0; k < p["files"].size(); ++k) {
    shots.push_back(ReadImage(raw.dir + "/" + p["files"][k].get<std::string>()));
    exposures.push_back(p["exposures"][k]);
  }
  const HdrResult hdr = MergeLinear(shots, exposures, HdrOptions{});
  const Image truth = ReadImage(raw.dir + "/truth/images/0000.exr");
  double num = 0, den = 0, worst_bright = 0;
  long saturated = 0, bright = 0;
  for (size_t i = 0; i < truth.pixels.size(); ++i) {
    const double t = truth.pixels[i], m = hdr.radiance.pixels[i];
    num += (m - t) * (m - t);
    den += t * t;
    if (t > 1.5) ++bright, worst_bright = std::max(worst_bright, std::abs(m / t - 1));  // above the longest exposure's range
  }
  for (float s : hdr.saturated.pixels) saturated += s > 0;
  const double rel = std::sqrt(num / den);
  std::printf("HDR merge: relative RMS error %.5f; %ld pixels beyond bracket 0 recovered, worst %.4f; %ld saturated\n",
              rel, bright, worst_bright, saturated);
  EXPECT_LT(rel, 0.01);
  EXPECT_GT(bright, 0);
  EXPECT_LT(worst_bright, 0.01);
}

// The whole `capture` job on the raw set: a contract scene.json whose camera,
// poses, lamps and registration match the hidden truth.
TEST_F(Registration, CaptureJobOnRawPhotos) {
  const RawSet& raw = Raw();
  const nlohmann::json& report = CaptureReport();
  const Scene scene = LoadScene(CaptureDir() + "/scene.json");
  ASSERT_GE(scene.images.size(), 7u);
  EXPECT_LT(std::abs(scene.cameras[0].fx() / raw.truth.camera.fx() - 1), 0.005);
  double worst_deg = 0, worst_mm = 0, worst_lamp_mm = 0, min_iou = 1;
  for (const ImageEntry& e : scene.images) {
    const Rigid3& t = raw.truth.cam_from_world[std::stoi(fs::path(e.file).stem().string())];
    worst_deg = std::max(worst_deg, AngleDeg(e.cam_from_world.rotation, t.rotation));
    worst_mm = std::max(worst_mm, 1e3 * (e.cam_from_world.CentreInWorld() - t.CentreInWorld()).norm());
  }
  for (const Light& l : scene.lights)
    worst_lamp_mm = std::max(worst_lamp_mm, 1e3 * (l.position - raw.truth.lamps[l.id - 1]).norm());
  for (const auto& v : report["registration"]["mask_iou"]) min_iou = std::min(min_iou, v["after"].get<double>());
  std::printf("capture job: %zu images, poses worst %.3f deg %.2f mm, lamps worst %.2f mm, mask IoU min %.4f\n",
              scene.images.size(), worst_deg, worst_mm, worst_lamp_mm, min_iou);
  EXPECT_LT(worst_deg, 0.1);
  EXPECT_LT(worst_mm, 1.0);
  // Lamps from estimated poses, refined on the highlights and the paper's
  // shading (bench_results/capture_seeds.md).
  EXPECT_LT(worst_lamp_mm, 5.0);  // issue 10: 5 mm
  EXPECT_GT(min_iou, 0.99);
  for (const Light& l : scene.lights) {
    std::printf("lamp %d intensity %.4f (true 1)\n", l.id, l.intensity[0]);
    EXPECT_NEAR(l.intensity[0], 1.0, 0.02);  // RawPhotoOptions::lamp_intensity; issue 10: 2 %
  }
}

// Raw photos -> capture -> reconstruct against the same reconstruction from
// the ground-truth capture of the same photos (held-out PSNR). Small and fast:
// 16 x 16 texels, at most 2 basis materials.
double HeldOutPsnr(const std::string& scene_path, const std::string& work, const std::string& heldout_path) {
  ReconstructionJob job;
  job.scene_path = scene_path;
  job.out_dir = work + "/material";
  job.gather.texture_size = 16;
  job.gather.progress = false;
  job.estimate.progress = false;
  job.estimate.max_clusters = 2;
  job.report = false;
  RunReconstruction(job);
  const Material rec = LoadMaterial(job.out_dir);
  const Scene held = LoadScene(heldout_path);
  RelightOptions rl;
  rl.progress = false;
  RelightScene(rec, held, work + "/relit", rl);
  return CompareToScene(held, work + "/relit").mean_psnr_srgb;
}

TEST_F(Registration, RawPhotosToMaterialNearTheTruthCapture) {
  const RawSet& raw = Raw();
  CaptureReport();
  const Scene captured = LoadScene(CaptureDir() + "/scene.json");
  // The ground-truth capture restricted to the photos `capture` kept.
  Scene truth = LoadScene(raw.dir + "/truth/scene.json");
  std::vector<ImageEntry> kept;
  for (const ImageEntry& e : truth.images)
    for (const ImageEntry& c : captured.images)
      if (fs::path(c.file).filename() == fs::path(e.file).filename()) kept.push_back(e);
  ASSERT_EQ(kept.size(), captured.images.size());
  truth.images = kept;
  SaveScene(truth, raw.dir + "/truth/same_photos.json");
  // The capture with the mesh at its true placement: isolates registration.
  Scene true_mesh = captured;
  true_mesh.mesh = fs::absolute(raw.dir + "/truth/gt/mesh.obj").string();
  SaveScene(true_mesh, CaptureDir() + "/scene_true_mesh.json");
  const std::string work = fs::path(raw.dir).parent_path().string();
  const std::string held = raw.dir + "/truth/heldout/scene.json";
  const double from_raw = HeldOutPsnr(CaptureDir() + "/scene.json", work + "/e2e_raw", held);
  const double from_raw_true_mesh = HeldOutPsnr(CaptureDir() + "/scene_true_mesh.json", work + "/e2e_mesh", held);
  const double from_truth = HeldOutPsnr(raw.dir + "/truth/same_photos.json", work + "/e2e_truth", held);
  std::printf("held-out PSNR (%zu photos): raw photos -> capture -> reconstruct %.2f dB; the same with the mesh at its "
              "true placement %.2f dB; ground-truth capture %.2f dB\n",
              kept.size(), from_raw, from_raw_true_mesh, from_truth);
  // Measured 23.82 / 23.89 / 23.90 dB while refined normals were kept here;
  // since the photo check rejects them (pipeline/normal_stage.h: they cost
  // ~11 dB relit) 33.97 / 35.01 / 35.02 dB: with a material this accurate the
  // registered mesh's error shows, as on a finer material (64 texels and up
  // to 6 materials, truth capture 37.5 dB), where it costs 1.5 dB: its
  // 0.06 mm error flips pixel coverage along the held-out silhouettes; see
  // README. The true placement stays within 1 dB of the truth.
  EXPECT_GT(from_raw_true_mesh, from_truth - 1.0);
  EXPECT_GT(from_raw, from_truth - 1.5);
}

// A flash on the camera: one point light per photo at the given offset in
// the camera frame (no mirror balls needed).
TEST_F(Registration, FlashLightsFollowTheCamera) {
  const RawSet& raw = Raw();
  nlohmann::json desc = raw.desc;
  desc.erase("mirror_spheres");
  desc["lights"] = {{{"id", 1}, {"type", "flash"}, {"offset", {0.05, -0.02, 0.0}}, {"intensity", 2.0}}};
  for (auto& p : desc["photos"]) p["light"] = 1;
  const std::string desc_path = raw.dir + "/capture_flash.json";
  WriteFileAtomic(desc_path, desc.dump());
  const std::string out_dir = (fs::path(raw.dir).parent_path() / "capture_flash").string();
  QuickCapture(raw.dir, out_dir, desc_path);
  const Scene scene = LoadScene(out_dir + "/scene.json");
  ASSERT_EQ(scene.lights.size(), scene.images.size());
  for (const ImageEntry& e : scene.images) {
    const Light* l = nullptr;
    for (const Light& c : scene.lights) l = c.id == e.light ? &c : l;
    ASSERT_NE(l, nullptr);
    EXPECT_NEAR((e.cam_from_world * l->position - Vec3(0.05, -0.02, 0.0)).norm(), 0.0, 1e-9);
    EXPECT_EQ(l->intensity[0], 2.0);
  }
  fs::remove_all(out_dir);
}

// A flash on the camera whose intensity nobody wrote down: measured on the
// board's white paper (known albedo) in every photo it lit. Its own small raw
// set (4 photos, camera known), rendered with a flash of intensity 1.7.
// A small flash-lit raw set (4 photos, camera known, no held-out views) in
// TMPL/raw, run through `capture` into TMPL/capture; returns the report.
nlohmann::json FlashRawSetThroughCapture(const std::string& tmpl, const std::string& format,
                                         const BoardSpec& board = DefaultRawBoard(),
                                         const std::function<void(nlohmann::json*)>& edit = nullptr) {
  RawPhotoOptions o = RawOptionsWithBoard(board);
  o.num_images = 4;
  o.num_heldout = 0;
  o.num_calibration = 0;
  o.material.texture_size = 16;
  o.flash_offset = {0.06, -0.03, 0.0};
  o.lamp_intensity = 1.7;
  o.seed = 3;
  o.format = format;
  const RawPhotoTruth truth = SynthesizeRawPhotos(o, tmpl + "/raw");
  nlohmann::json desc = ReadJsonFile(tmpl + "/raw/capture.json");
  WriteColmapCameras({truth.camera}, tmpl + "/raw/cameras.txt");
  desc["camera"] = {{"cameras_txt", "cameras.txt"}};
  if (edit) edit(&desc);
  WriteFileAtomic(tmpl + "/raw/capture.json", desc.dump());
  return QuickCapture(tmpl + "/raw", tmpl + "/capture");
}

// Issue 25: a board whose only white paper is the narrow margin around its
// markers (marker 0.8 of the square, legacy layout, another dictionary) and
// nobody knows the paper's albedo: the flash is measured relative to the
// assumed albedo 0.8 (true 0.9), and the report says so.
TEST(RegistrationFlash, NarrowMarginLegacyBoardWithoutPaperAlbedo) {
  std::string tmpl = (fs::temp_directory_path() / "svbrdf_board_XXXXXX").string();
  ASSERT_TRUE(mkdtemp(tmpl.data()));
  BoardSpec board = DefaultRawBoard();
  board.cols = 10;
  board.marker = 0.028;
  board.dictionary = "DICT_5X5_100";
  board.legacy_layout = true;
  const auto no_albedo = [](nlohmann::json* d) {
    (*d)["board"].erase("white_albedo");
    (*d)["board"].erase("black_albedo");
  };
  const nlohmann::json report = FlashRawSetThroughCapture(tmpl, "png16", board, no_albedo);
  EXPECT_FALSE(report["paper_albedo"]["given"].get<bool>());
  EXPECT_NE(report["paper_albedo"]["note"].get<std::string>().find("relative"), std::string::npos);
  const Scene scene = LoadScene(tmpl + "/capture/scene.json");
  ASSERT_EQ(scene.images.size(), 4u);
  const double expected = 1.7 * 0.9 / 0.8;  // RawPhotoOptions::white_albedo 0.9 against the assumed 0.8
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(scene.lights[0].intensity[c] / expected, 1.0, 0.02) << c;
  std::printf("narrow-margin legacy board, paper albedo unknown: flash %.4f (expected %.4f) from %d samples\n",
              scene.lights[0].intensity[0], expected, report["lights"][0]["reference_samples"].get<int>());
  fs::remove_all(tmpl);
}

// No paper to measure on (a mirror ball claimed to cover the board): a clear
// error that names the light and says what to give; given, it is used.
TEST(RegistrationFlash, NoPaperAsksForTheIntensity) {
  std::string tmpl = (fs::temp_directory_path() / "svbrdf_nopaper_XXXXXX").string();
  ASSERT_TRUE(mkdtemp(tmpl.data()));
  const auto huge_ball = [](nlohmann::json* d) {
    (*d)["mirror_spheres"] = {{"radius", 1.0}, {"centres", {{0.2, 0.15, -1.0}}}};
  };
  try {
    FlashRawSetThroughCapture(tmpl, "png16", DefaultRawBoard(), huge_ball);
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("capture.json: light 1: no white board paper"), std::string::npos) << what;
    EXPECT_NE(what.find("Give the lamp's \"intensity\""), std::string::npos) << what;
    EXPECT_NE(what.find("near a mirror ball"), std::string::npos) << what;
  }
  EXPECT_FALSE(fs::exists(tmpl + "/capture"));
  fs::remove_all(tmpl);
  ASSERT_TRUE(fs::create_directories(tmpl));
  const nlohmann::json report = FlashRawSetThroughCapture(tmpl, "png16", DefaultRawBoard(), [&](nlohmann::json* d) {
    huge_ball(d);
    (*d)["lights"][0]["intensity"] = {1.5, 1.6, 1.7};
  });
  const Scene scene = LoadScene(tmpl + "/capture/scene.json");
  EXPECT_EQ(scene.lights[0].intensity[1], 1.6);
  EXPECT_FALSE(report["lights"][0]["intensity_measured"].get<bool>());
  fs::remove_all(tmpl);
}

TEST(RegistrationFlash, FlashIntensityFromTheBoardPaper) {
  std::string tmpl = (fs::temp_directory_path() / "svbrdf_flash_XXXXXX").string();
  ASSERT_TRUE(mkdtemp(tmpl.data()));
  const nlohmann::json report = FlashRawSetThroughCapture(tmpl, "png16");
  const Scene scene = LoadScene(tmpl + "/capture/scene.json");
  ASSERT_EQ(scene.lights.size(), 4u);
  for (const Light& l : scene.lights) {
    EXPECT_NEAR(l.intensity[0] / 1.7, 1.0, 0.02);  // issue 10: intensity within 2 %
    EXPECT_TRUE(report["lights"][0]["intensity_measured"].get<bool>());
  }
  std::printf("flash intensity from the board paper: %.4f (true 1.7, %+.2f %%) from %d samples\n",
              scene.lights[0].intensity[0], 100 * (scene.lights[0].intensity[0] / 1.7 - 1),
              report["lights"][0]["reference_samples"].get<int>());
  fs::remove_all(tmpl);
}

// 8-bit sRGB brackets (as a JPEG camera writes them) through `capture`: the
// response is recovered from the brackets, so the merged images match the
// true radiance up to one scale for all photos (issue 10: HDR linear within
// 1 %), and the flash intensity measured on the board paper carries the same
// scale (within 2 %).
TEST(RegistrationFlash, EightBitBracketsThroughCapture) {
  std::string tmpl = (fs::temp_directory_path() / "svbrdf_hdr8_XXXXXX").string();
  ASSERT_TRUE(mkdtemp(tmpl.data()));
  const nlohmann::json report = FlashRawSetThroughCapture(tmpl, "png8");
  EXPECT_NE(report["hdr"]["response"].get<std::string>(), "linear");
  const Scene scene = LoadScene(tmpl + "/capture/scene.json");
  ASSERT_EQ(scene.images.size(), 4u);
  // One scale k for all photos (merged = k * truth), then the RMS left.
  std::vector<std::pair<Image, Image>> pairs;
  double mt = 0, tt = 0;
  for (const ImageEntry& e : scene.images) {
    const std::string name = fs::path(e.file).stem().string();
    Image merged = ReadImage(tmpl + "/capture/" + e.file);
    Image sat = ReadImage(tmpl + "/capture/saturation/" + name + ".png");
    Image truth = ReadImage(tmpl + "/raw/truth/images/" + name + ".exr");
    ASSERT_EQ(merged.pixels.size(), truth.pixels.size());
    for (size_t i = 0; i < truth.pixels.size(); ++i) {
      if (sat.pixels[i / truth.channels] > 0 || truth.pixels[i] < 0.02) merged.pixels[i] = truth.pixels[i] = 0;
      mt += double(merged.pixels[i]) * truth.pixels[i];
      tt += double(truth.pixels[i]) * truth.pixels[i];
    }
    pairs.emplace_back(std::move(merged), std::move(truth));
  }
  const double k = mt / tt;
  double num = 0;
  for (const auto& [m, t] : pairs)
    for (size_t i = 0; i < t.pixels.size(); ++i) num += std::pow(m.pixels[i] - k * t.pixels[i], 2);
  const double rel = std::sqrt(num / (k * k * tt));
  const double intensity = scene.lights[0].intensity[0];
  std::printf("8-bit brackets through capture: %.3f %% RMS off linear (one scale %.4f for all photos); flash "
              "intensity %.4f = %.4f x scale (true 1.7)\n",
              100 * rel, k, intensity, intensity / k);
  EXPECT_LT(rel, 0.01);
  EXPECT_NEAR(intensity / k / 1.7, 1.0, 0.02);
  fs::remove_all(tmpl);
}

bool ColmapInstalled() {
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "");
  for (std::string d; std::getline(dirs, d, ':');)
    if (!d.empty() && fs::exists(fs::path(d) / "colmap")) return true;
  return false;
}

// COLMAP run by `capture` ("poses": "colmap") on a tiny raw set (8 photos of
// 640x480; smaller images gave COLMAP too few features: 1.5 deg / 13 mm at
// 320x240): the model placed by the board photos agrees with the true poses,
// and the scale from a known distance (two photos' centres, tape-measured)
// agrees with the board's.
TEST(RegistrationColmap, ColmapPosesPlacedAndScaled) {
  if (!ColmapInstalled()) GTEST_SKIP() << "the colmap CLI is not installed (scripts/setup.sh installs it)";
  std::string tmpl = (fs::temp_directory_path() / "svbrdf_colmap_test_XXXXXX").string();
  ASSERT_TRUE(mkdtemp(tmpl.data()));
  RawPhotoOptions o = RawOptionsWithBoard();
  o.num_images = 8;
  o.num_heldout = 0;
  o.num_calibration = 0;
  o.num_lamps = 2;
  o.width = 640, o.height = 480;
  o.material.texture_size = 16;
  const RawPhotoTruth truth = SynthesizeRawPhotos(o, tmpl + "/raw");
  nlohmann::json desc = ReadJsonFile(tmpl + "/raw/capture.json");
  WriteColmapCameras({truth.camera}, tmpl + "/raw/cameras.txt");
  desc["camera"] = {{"cameras_txt", "cameras.txt"}};
  desc["poses"] = "colmap";
  // The two photos farthest apart, their true distance as if measured.
  size_t a = 0, b = 1;
  double far = 0;
  for (size_t i = 0; i < truth.cam_from_world.size(); ++i)
    for (size_t j = i + 1; j < truth.cam_from_world.size(); ++j) {
      const double d = (truth.cam_from_world[i].CentreInWorld() - truth.cam_from_world[j].CentreInWorld()).norm();
      if (d > far) far = d, a = i, b = j;
    }
  desc["known_distance"] = {{"images", {desc["photos"][a]["files"][0], desc["photos"][b]["files"][0]}}, {"metres", far}};
  WriteFileAtomic(tmpl + "/raw/capture.json", desc.dump());
  // One thread: with COLMAP's multi-threaded matching and mapping the
  // worst pose came out at 0.86 deg once under load; single-threaded, 8
  // runs gave 0.12-0.70 deg (runs still differ): the bound below is 1 deg.
  // A wrong model (29 deg, 367 mm: seen twice) is now run again (below).
  const nlohmann::json report = QuickCapture(tmpl + "/raw", tmpl + "/capture", "", 1);
  const nlohmann::json& c = report["colmap"];
  const Scene scene = LoadScene(tmpl + "/capture/scene.json");
  EXPECT_EQ(c["registered_images"].get<int>(), 8);
  double worst_deg = 0, worst_mm = 0;
  for (const ImageEntry& e : scene.images) {
    const Rigid3& t = truth.cam_from_world[std::stoi(fs::path(e.file).stem().string())];
    worst_deg = std::max(worst_deg, AngleDeg(e.cam_from_world.rotation, t.rotation));
    worst_mm = std::max(worst_mm, 1e3 * (e.cam_from_world.CentreInWorld() - t.CentreInWorld()).norm());
  }
  const double scale_err = c["known_distance_scale"].get<double>() / c["scale"].get<double>() - 1;
  std::printf("COLMAP: %d images, %d points; its poses placed by the board vs the board poses: worst %.3f deg %.2f mm "
              "(centre RMS %.2f mm); known-distance scale vs board scale %+.3f %%\n",
              c["registered_images"].get<int>(), c["points"].get<int>(), c["vs_board_worst_deg"].get<double>(),
              c["vs_board_worst_mm"].get<double>(), c["centre_rms_mm"].get<double>(), 100 * scale_err);
  EXPECT_EQ(c["placed_by"], "board");
  // COLMAP's own poses, placed in metres. Its mapper is not deterministic
  // here (a run under ctest -j2 needed its retry and ended at 0.94 deg,
  // 5.2 mm; single runs 0.12-0.86 deg, 1.9-2.9 mm): bounds with room for
  // that scatter. scene.json keeps the board poses (checked below).
  EXPECT_LT(c["vs_board_worst_deg"].get<double>(), 1.5);
  EXPECT_LT(c["vs_board_worst_mm"].get<double>(), 8.0);
  EXPECT_LT(std::abs(scale_err), 0.005);  // issue 10 (brief): scale within 0.5 %
  EXPECT_LT(worst_deg, 0.1);  // scene.json keeps the board poses where the board is seen
  EXPECT_LT(worst_mm, 1.0);

  // A COLMAP model that disagrees with the board poses (the mapper's rare
  // wrong convergence, here faked: a wrapper turns one camera of the first
  // attempt's model by 90 deg about its x axis) is run again with another seed.
  const std::string state = tmpl + "/fake_colmap_seed", wrapper = tmpl + "/fake_colmap.sh";
  WriteFileAtomic(wrapper, "#!/bin/bash\n"
                           "out=''; seed=''; prev=''\n"
                           "for a in \"$@\"; do [ \"$prev\" = --output_path ] && out=$a; [ \"$prev\" = --random_seed ] && seed=$a; prev=$a; done\n"
                           "[ \"$1\" = mapper ] && echo \"$seed\" > '" + state + "'\n"
                           "colmap \"$@\" || exit $?\n"
                           "if [ \"$1\" = model_converter ] && [ \"$(cat '" + state + "')\" = 0 ]; then\n"
                           "  awk 'BEGIN{d=0;c=sqrt(0.5)} /^#/{print;next} {if(!d && NF==10){w=$2;x=$3;y=$4;z=$5;"
                           "$2=w*c-x*c;$3=w*c+x*c;$4=y*c+z*c;$5=z*c-y*c;d=1} print}' \"$out/images.txt\" > \"$out/x\" && "
                           "mv \"$out/x\" \"$out/images.txt\"\n"
                           "fi\n");
  fs::permissions(wrapper, fs::perms::owner_all);
  desc["colmap_executable"] = wrapper;
  WriteFileAtomic(tmpl + "/raw/capture.json", desc.dump());
  const nlohmann::json again = QuickCapture(tmpl + "/raw", tmpl + "/capture_again", "", 1);
  std::printf("faked wrong first model: %d attempts, worst %.3f deg\n", again["colmap"]["attempts"].get<int>(),
              again["colmap"]["vs_board_worst_deg"].get<double>());
  if (again.contains("warnings")) std::printf("%s\n", again["warnings"].dump(1).c_str());
  EXPECT_GE(again["colmap"]["attempts"].get<int>(), 2);  // 3 if the real second run went wrong too
  EXPECT_LT(again["colmap"]["vs_board_worst_deg"].get<double>(), 1.0);
  ASSERT_TRUE(again.contains("warnings"));
  EXPECT_NE(again["warnings"][0].get<std::string>().find("running it again"), std::string::npos);
  fs::remove_all(tmpl);
}

// GrabCut masks seeded by the rough mesh placement of capture.json (5 deg /
// 2 cm off, up to ~20 px here) against the true object masks. The undecided
// band must cover that error: with a 6 px band GrabCut reached IoU 0.77,
// 15 px 0.92, 25 px 0.94.
TEST_F(Registration, GrabCutMasksFromRoughPlacement) {
  const RawSet& raw = Raw();
  const Mesh mesh = LoadMesh(raw.dir + "/mesh.obj");
  const auto& pose_j = raw.desc["mesh"]["world_from_mesh"];
  Rigid3 rough;
  rough.rotation = Eigen::Quaterniond(pose_j["q"][0], pose_j["q"][1], pose_j["q"][2], pose_j["q"][3]);
  rough.translation = Vec3(pose_j["t"][0], pose_j["t"][1], pose_j["t"][2]);
  double iou_prior = 0, iou_cut = 0, worst = 1;
  const size_t n = raw.truth.cam_from_world.size();
  for (size_t i = 0; i < n; ++i) {
    const Image truth = ReadImage(raw.dir + "/" + raw.desc["photos"][i]["mask"].get<std::string>());
    const Image prior = RenderSilhouette(mesh, rough, raw.truth.camera, raw.truth.cam_from_world[i]);
    const Image cut = GrabCutMask(ReadImage(raw.bracket0[raw.num_calibration + i]), prior, 25);
    iou_prior += MaskIoU(prior, truth) / n;
    const double iou = MaskIoU(cut, truth);
    iou_cut += iou / n;
    worst = std::min(worst, iou);
  }
  std::printf("GrabCut: mean IoU with the true masks %.4f (rough mesh projection %.4f), worst view %.4f\n", iou_cut,
              iou_prior, worst);
  EXPECT_GT(iou_cut, iou_prior);
  EXPECT_GT(iou_cut, 0.92);
}

}  // namespace
}  // namespace svbrdf
