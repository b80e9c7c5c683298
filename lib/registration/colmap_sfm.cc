#include "registration/colmap_sfm.h"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "calib/board.h"
#include "core/error.h"
#include "io/image.h"

namespace svbrdf {

namespace fs = std::filesystem;

void ColmapSfmOptions::Check() const {
  if (colmap.empty()) throw Error("colmap: executable name is empty");
  if (max_image_size < 64) throw Error("colmap: max_image_size must be >= 64");
}

namespace {

std::string Quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

void RunStep(const std::string& step, const std::string& args, const std::string& workspace, const ColmapSfmOptions& o) {
  const std::string log = (fs::path(workspace) / (step + ".log")).string();
  // Headless: COLMAP links Qt even for command-line steps.
  const std::string cmd = "QT_QPA_PLATFORM=offscreen " + Quote(o.colmap) + " " + step + " " + args + " > " + Quote(log) + " 2>&1";
  const int rc = std::system(cmd.c_str());
  if (rc != 0) throw Error(Msg("colmap ", step, " failed (exit status ", rc, "); see ", log));
}

}  // namespace

std::string ColmapImageName(const std::string& path) { return fs::path(path).stem().string() + ".png"; }

ColmapModel RunColmapSfm(const std::vector<std::string>& paths, const Camera& camera, const std::string& workspace,
                         const ColmapSfmOptions& o) {
  o.Check();
  if (paths.size() < 2) throw Error("colmap: need at least 2 images");
  const fs::path ws(workspace), images = ws / "images", sparse = ws / "sparse", text = ws / "text";
  fs::create_directories(images);
  fs::create_directories(sparse);
  fs::create_directories(text);
  // COLMAP reads 8-bit images (it rejected our 16-bit linear PNGs: "Failed to
  // read image file format"): tone-mapped grey copies, as SIFT sees grey anyway.
  for (const auto& p : paths) {
    const fs::path copy = images / ColmapImageName(p);
    if (fs::exists(copy)) throw Error(Msg("colmap: two images named ", copy.filename().string()));
    const Image img = ReadImage(p);
    WriteImage(copy.string(), ToDisplayGrey(img, IsHighDynamicRange(img)), PixelFormat::kUInt8,
               ColorSpace::kLinear);
  }
  std::string params;
  for (size_t i = 0; i < camera.params.size(); ++i) params += Msg(i ? "," : "", camera.params[i]);
  const std::string db = Quote((ws / "database.db").string());
  RunStep("feature_extractor",
          Msg("--database_path ", db, " --image_path ", Quote(images.string()), " --ImageReader.single_camera 1",
              " --ImageReader.camera_model ", CameraModelName(camera.model), " --ImageReader.camera_params ", params,
              " --SiftExtraction.use_gpu 0 --SiftExtraction.max_image_size ", o.max_image_size,
              " --SiftExtraction.num_threads ", o.threads),
          workspace, o);
  RunStep("exhaustive_matcher", Msg("--database_path ", db, " --SiftMatching.use_gpu 0 --SiftMatching.num_threads ", o.threads,
                                     " --random_seed ", o.random_seed),
          workspace, o);
  RunStep("mapper",
          Msg("--database_path ", db, " --image_path ", Quote(images.string()), " --output_path ", Quote(sparse.string()),
              " --Mapper.ba_refine_focal_length 0 --Mapper.ba_refine_principal_point 0",
              " --Mapper.ba_refine_extra_params 0 --Mapper.num_threads ", o.threads, " --random_seed ", o.random_seed),
          workspace, o);
  // The largest of the reconstructions (sparse/0, sparse/1, ...).
  fs::path best;
  size_t best_size = 0;
  for (const auto& d : fs::directory_iterator(sparse)) {
    if (!fs::exists(d.path() / "images.bin")) continue;
    const size_t size = fs::file_size(d.path() / "images.bin");
    if (size > best_size) best = d.path(), best_size = size;
  }
  if (best.empty()) throw Error(Msg("colmap mapper: no reconstruction in ", sparse.string(), "; see ", (ws / "mapper.log").string()));
  RunStep("model_converter",
          Msg("--input_path ", Quote(best.string()), " --output_path ", Quote(text.string()), " --output_type TXT"),
          workspace, o);
  return ReadColmapText(text.string());
}

Rigid3 ColmapToBoard::CamFromBoard(const Rigid3& cam_from_colmap) const {
  // x_colmap = rotation^-1 (x_board - translation) / scale; the camera frame
  // is rescaled by the same factor so the pose stays rigid.
  Rigid3 p;
  p.rotation = (cam_from_colmap.rotation * rotation.conjugate()).normalized();
  p.translation = scale * cam_from_colmap.translation - p.rotation * translation;
  return p;
}

ColmapToBoard AlignColmapToBoard(const ColmapModel& model, const std::map<std::string, Rigid3>& cam_from_board) {
  std::vector<Vec3> src, dst;
  for (const ColmapImage& im : model.images) {
    const auto it = cam_from_board.find(im.name);
    if (it == cam_from_board.end()) continue;
    src.push_back(im.cam_from_world.CentreInWorld());
    dst.push_back(it->second.CentreInWorld());
  }
  if (src.size() < 3)
    throw Error(Msg("colmap: only ", src.size(), " images have both a COLMAP pose and a board pose; need 3 to place the model"));
  Eigen::Matrix3Xd a(3, src.size()), b(3, dst.size());
  for (size_t i = 0; i < src.size(); ++i) a.col(i) = src[i], b.col(i) = dst[i];
  const Eigen::Matrix4d T = Eigen::umeyama(a, b, true);  // Umeyama 1991: least-squares similarity
  ColmapToBoard r;
  r.scale = T.block<3, 3>(0, 0).col(0).norm();
  r.rotation = Eigen::Quaterniond(Mat3(T.block<3, 3>(0, 0) / r.scale)).normalized();
  r.translation = T.block<3, 1>(0, 3);
  r.matched = int(src.size());
  double sum = 0;
  for (size_t i = 0; i < src.size(); ++i) sum += (r.scale * (r.rotation * src[i]) + r.translation - dst[i]).squaredNorm();
  r.centre_rms_m = std::sqrt(sum / src.size());
  return r;
}

ColmapToBoard ScaleColmapByDistance(const ColmapModel& model, const std::string& a, const std::string& b, double metres) {
  const ColmapImage *ia = nullptr, *ib = nullptr;
  for (const ColmapImage& im : model.images) {
    if (im.name == a) ia = &im;
    if (im.name == b) ib = &im;
  }
  if (!ia || !ib) throw Error(Msg("colmap: image ", ia ? b : a, " is not in the reconstruction"));
  if (!(metres > 0)) throw Error("colmap: the known distance must be > 0 metres");
  const double d = (ia->cam_from_world.CentreInWorld() - ib->cam_from_world.CentreInWorld()).norm();
  if (!(d > 0)) throw Error(Msg("colmap: images ", a, " and ", b, " share their centre; cannot scale"));
  ColmapToBoard r;
  r.scale = metres / d;
  r.matched = 2;
  return r;
}

ColmapToBoard ScaleColmapByKnownDistance(const ColmapModel& model, const KnownDistance& k) {
  if (!(k.metres > 0)) throw Error("colmap: the known distance must be > 0 metres");
  if (!k.image_a.empty() || !k.image_b.empty()) return ScaleColmapByDistance(model, k.image_a, k.image_b, k.metres);
  Vec3 a, b;
  if (k.point_a >= 0 || k.point_b >= 0) {
    for (long id : {k.point_a, k.point_b})
      if (!model.points.count(id)) throw Error(Msg("colmap: 3-D point ", id, " of the known distance is not in the model"));
    a = model.points.at(k.point_a).xyz, b = model.points.at(k.point_b).xyz;
  } else if (k.points.size() == 2) {
    a = k.points[0], b = k.points[1];
  } else {
    throw Error("colmap: a known distance needs two images, two point ids or two points");
  }
  const double d = (a - b).norm();
  if (!(d > 0)) throw Error("colmap: the two points of the known distance coincide; cannot scale");
  ColmapToBoard r;
  r.scale = k.metres / d;
  r.matched = 0;
  return r;
}

}  // namespace svbrdf
