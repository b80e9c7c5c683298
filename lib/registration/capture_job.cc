#include "registration/capture_job.h"

#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <unistd.h>

#include "calib/board.h"
#include "calib/colmap_text.h"
#include "calib/hdr.h"
#include "calib/intrinsics.h"
#include "calib/light_probe.h"
#include "calib/pnp.h"
#include "calib/segment.h"
#include "core/error.h"
#include "io/exif.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "io/output_folder.h"
#include "io/scene.h"
#include "registration/board_bundle.h"
#include "registration/colmap_sfm.h"
#include "registration/lamp_position.h"
#include "registration/silhouette.h"
#include "registration/white_paper.h"
#include "raytrace/raytracer.h"

namespace svbrdf {

namespace fs = std::filesystem;

// Diffuse albedo taken for the board's paper when the description does not
// give it: matte white office paper reflects roughly 0.8 diffusely. Only the
// scale of intensities and albedos depends on it, never their ratios.
constexpr double kAssumedPaperAlbedo = 0.8;

void CaptureJob::Check() const {
  if (photos_dir.empty() || out_dir.empty()) throw Error("capture: photos folder and --out are required");
  if (!fs::is_directory(photos_dir)) throw Error(Msg("capture: ", photos_dir, " is not a folder"));
  if (silhouette_iterations < 1) throw Error("capture: silhouette iterations must be >= 1");
}

namespace {

template <class T>
T Field(const nlohmann::json& j, const char* key, const std::string& context) {
  if (!j.is_object() || !j.contains(key)) throw Error(Msg(context, ": missing field '", key, "'"));
  try {
    return j.at(key).get<T>();
  } catch (const std::exception& e) {
    throw Error(Msg(context, ": field '", key, "': ", e.what()));
  }
}

KnownDistance KnownDistanceFromJson(const nlohmann::json& j, const std::string& context) {
  KnownDistance k;
  k.metres = Field<double>(j, "metres", context);
  if (j.contains("images")) {
    const auto names = Field<std::vector<std::string>>(j, "images", context);
    if (names.size() != 2) throw Error(Msg(context, ": images: expected two photo files"));
    k.image_a = ColmapImageName(names[0]), k.image_b = ColmapImageName(names[1]);
  } else if (j.contains("point_ids")) {
    const auto ids = Field<std::vector<long>>(j, "point_ids", context);
    if (ids.size() != 2) throw Error(Msg(context, ": point_ids: expected two ids of points3D.txt"));
    k.point_a = ids[0], k.point_b = ids[1];
  } else {
    for (const auto& p : Field<std::vector<std::vector<double>>>(j, "points", context)) {
      if (p.size() != 3) throw Error(Msg(context, ": points: expected [[x, y, z], [x, y, z]]"));
      k.points.push_back(Vec3(p[0], p[1], p[2]));
    }
    if (k.points.size() != 2) throw Error(Msg(context, ": points: expected two points"));
  }
  if (!(k.metres > 0)) throw Error(Msg(context, ": metres must be > 0"));
  return k;
}

Rigid3 PoseFromJson(const nlohmann::json& j, const std::string& context) {
  const auto q = Field<std::vector<double>>(j, "q", context), t = Field<std::vector<double>>(j, "t", context);
  if (q.size() != 4 || t.size() != 3) throw Error(Msg(context, ": expected q (4 numbers) and t (3 numbers)"));
  Rigid3 p;
  p.rotation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
  p.translation = Vec3(t[0], t[1], t[2]);
  return p;
}

nlohmann::json PoseJson(const Rigid3& p) {
  const auto& q = p.rotation;
  return {{"q", {q.w(), q.x(), q.y(), q.z()}}, {"t", {p.translation.x(), p.translation.y(), p.translation.z()}}};
}

BoardSpec BoardFromJson(const nlohmann::json& j, const std::string& ctx) {
  BoardSpec b;
  b.pattern = BoardPatternFromName(Field<std::string>(j, "pattern", ctx));
  b.cols = Field<int>(j, "cols", ctx);
  b.rows = Field<int>(j, "rows", ctx);
  b.square = Field<double>(j, "square", ctx);
  if (j.contains("marker")) b.marker = Field<double>(j, "marker", ctx);
  if (j.contains("dictionary")) b.dictionary = Field<std::string>(j, "dictionary", ctx);
  if (j.contains("layout")) {
    const std::string layout = Field<std::string>(j, "layout", ctx);
    if (layout != "new" && layout != "legacy")
      throw Error(Msg(ctx, ": layout: \"", layout, "\" unknown; expected \"new\" (OpenCV >= 4.6, the default) or \"legacy\""));
    b.legacy_layout = layout == "legacy";
  }
  b.Check();
  return b;
}

// A lamp's intensity as given: W/sr, a number (white) or [r, g, b].
std::optional<Rgb> IntensityFromJson(const nlohmann::json& lj, const std::string& context) {
  if (!lj.contains("intensity")) return std::nullopt;
  const nlohmann::json& v = lj.at("intensity");
  Rgb I;
  if (v.is_number()) {
    I = Rgb::Constant(v.get<double>());
  } else if (v.is_array() && v.size() == 3 && v[0].is_number() && v[1].is_number() && v[2].is_number()) {
    I = Rgb(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
  } else {
    throw Error(Msg(context, ": intensity must be a number or [r, g, b] (W/sr)"));
  }
  if (!(I.minCoeff() >= 0 && I.maxCoeff() > 0 && I.allFinite()))
    throw Error(Msg(context, ": intensity must be >= 0 per channel and > 0 in one"));
  return I;
}

Image DilateMask(const Image& mask, int radius) {
  Image out = mask;
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) {
      if (mask.at(x, y, 0) <= 0.5f) continue;
      for (int dy = -radius; dy <= radius; ++dy)
        for (int dx = -radius; dx <= radius; ++dx) {
          const int u = x + dx, v = y + dy;
          if (u >= 0 && v >= 0 && u < mask.width && v < mask.height) out.at(u, v, 0) = 1.0f;
        }
    }
  return out;
}

struct Photo {
  std::vector<std::string> files;
  std::vector<double> exposures;
  int light = 0;
  std::string mask;
  HdrResult hdr;
  bool posed = false;
  std::string why;
  Rigid3 cam_from_world;
  double rms_px = 0;
};

}  // namespace

nlohmann::json RunCapture(const CaptureJob& job) {
  job.Check();
  StageTimer timer;
  const std::string desc_path = job.description.empty() ? (fs::path(job.photos_dir) / "capture.json").string()
                                                        : job.description;
  const nlohmann::json desc = ReadJsonFile(desc_path);
  const std::string ctx = desc_path;
  if (Field<std::string>(desc, "format", ctx) != "svbrdf-capture-description/1")
    throw Error(Msg(ctx, ": format must be \"svbrdf-capture-description/1\""));
  auto path = [&](const std::string& rel) { return (fs::path(job.photos_dir) / rel).string(); };
  const nlohmann::json& board_j = Field<nlohmann::json>(desc, "board", ctx);
  const BoardSpec board = BoardFromJson(board_j, ctx + ": board");
  // The paper's albedo sets the absolute scale of measured lamp intensities;
  // without it they are relative (kAssumedPaperAlbedo, stated in the report).
  const bool paper_albedo_known = board_j.contains("white_albedo");
  const double white = paper_albedo_known ? Field<double>(board_j, "white_albedo", ctx + ": board") : kAssumedPaperAlbedo;
  if (!(white > 0 && white <= 1)) throw Error(Msg(ctx, ": board: white_albedo must be in (0, 1]"));
  // "linear": 16-bit linear PNG/TIFF or EXR brackets. "srgb" / "nonlinear":
  // 8-bit brackets through an unknown camera response (JPEG), recovered
  // from the brackets themselves; the merged radiance is then known up to
  // one scale, which the lamp and flash intensities (measured on the board's
  // known albedo) absorb.
  const std::string color_space = Field<std::string>(desc, "images_color_space", ctx);
  if (color_space != "linear" && color_space != "srgb" && color_space != "nonlinear")
    throw Error(Msg(ctx, ": images_color_space: \"", color_space,
                    "\" unknown; expected \"linear\" (16-bit/EXR) or \"srgb\"/\"nonlinear\" (8-bit brackets)"));
  const bool recover_response = color_space != "linear";

  std::vector<Photo> photos;
  const auto photos_j = Field<nlohmann::json>(desc, "photos", ctx);
  if (!photos_j.is_array() || photos_j.empty()) throw Error(Msg(ctx, ": photos must be a non-empty array"));
  for (size_t i = 0; i < photos_j.size(); ++i) {
    const std::string pc = Msg(ctx, ": photos[", i, "]");
    Photo p;
    p.files = Field<std::vector<std::string>>(photos_j[i], "files", pc);
    if (photos_j[i].contains("exposures")) {
      p.exposures = Field<std::vector<double>>(photos_j[i], "exposures", pc);
    } else {  // from EXIF: exposure time x ISO / f-number^2 of each bracket
      for (const auto& f : p.files) p.exposures.push_back(ReadExifExposure(path(f)).Relative());
    }
    p.light = Field<int>(photos_j[i], "light", pc);
    if (photos_j[i].contains("mask")) p.mask = Field<std::string>(photos_j[i], "mask", pc);
    if (p.files.empty() || p.files.size() != p.exposures.size())
      throw Error(Msg(pc, ": files and exposures must be non-empty and of equal length"));
    photos.push_back(p);
  }
  nlohmann::json report = {{"description", desc_path}};

  // 1. HDR: merge brackets, saturation where every bracket clips. 8-bit
  // brackets: one response for the camera, recovered from the photo with
  // the most brackets.
  timer.Start("hdr");
  CameraResponse response;
  const ResponseOptions response_options;
  if (recover_response) {
    size_t richest = 0;
    for (size_t i = 0; i < photos.size(); ++i)
      if (photos[i].files.size() > photos[richest].files.size()) richest = i;
    if (photos[richest].files.size() < 2)
      throw Error(Msg(ctx, ": images_color_space \"", color_space,
                      "\" needs at least one photo with 2 or more exposure brackets to recover the camera response"));
    std::vector<Image> shots;
    for (const auto& f : photos[richest].files) shots.push_back(ReadImage(path(f)));
    response = RecoverResponse(shots, photos[richest].exposures, response_options);
    report["hdr"] = {{"response", "recovered: Debevec-Malik, then a polynomial of degree " +
                                      std::to_string(response_options.polynomial_degree)},
                     {"from_photo", richest}};
  } else {
    report["hdr"] = {{"response", "linear"}};
  }
  {
    Progress progress("merge brackets", long(photos.size()), job.progress);
    ParallelFor(long(photos.size()), job.threads, [&](long i) {
      std::vector<Image> shots;
      for (const auto& f : photos[i].files) shots.push_back(ReadImage(path(f)));
      photos[i].hdr = recover_response ? MergeWithResponse(shots, photos[i].exposures, response, response_options)
                                       : MergeLinear(shots, photos[i].exposures, HdrOptions{});
      progress.Tick();
    });
  }
  timer.Stop();

  // 2. Intrinsics and board poses. Detection on the longest exposure.
  timer.Start("calibrate + poses");
  std::vector<std::string> detect_paths;
  if (desc.contains("calibration_photos"))
    for (const auto& f : Field<std::vector<std::string>>(desc, "calibration_photos", ctx)) detect_paths.push_back(path(f));
  const size_t first_photo = detect_paths.size();
  for (const Photo& p : photos) {
    const size_t longest = std::max_element(p.exposures.begin(), p.exposures.end()) - p.exposures.begin();
    detect_paths.push_back(path(p.files[longest]));
  }
  const nlohmann::json& cam_j = Field<nlohmann::json>(desc, "camera", ctx);
  CalibrateOptions co;
  co.board = board;
  co.progress = job.progress;
  if (cam_j.contains("model")) co.model = CameraModelFromName(Field<std::string>(cam_j, "model", ctx + ": camera"), ctx);
  const bool calibrate = cam_j.value("calibrate", false);
  CalibrationResult cal;
  if (calibrate) {
    cal = CalibrateIntrinsics(detect_paths, co);
  } else {
    // Known camera: detections only, poses by PnP against it.
    const auto cams = ReadColmapCameras(path(Field<std::string>(cam_j, "cameras_txt", ctx + ": camera")));
    cal.camera = cams[0];
    for (const auto& p : detect_paths) {
      ViewCalibration v;
      v.name = fs::path(p).filename().string();
      const BoardDetection d = DetectBoard(ReadImage(p), board);
      v.used = d.found && int(d.points.size()) >= co.min_points;
      v.why = d.found ? (v.used ? "" : "too few board points") : d.why;
      v.ids = d.ids;
      v.points = d.points;
      cal.views.push_back(v);
    }
  }
  std::vector<Rigid3> poses;
  std::vector<BoardObservations> obs;
  std::vector<int> view_index;
  for (size_t k = 0; k < cal.views.size(); ++k) {
    if (!cal.views[k].used) continue;
    BoardDetection d;
    d.ids = cal.views[k].ids;
    d.points = cal.views[k].points;
    poses.push_back(SolveBoardPose(cal.camera, board, d, cal.views[k].name));
    obs.push_back({d.ids, d.points});
    view_index.push_back(int(k));
  }
  BundleOptions bo;
  bo.refine_intrinsics = calibrate;
  const BundleResult ba = AdjustBoardBundle(cal.camera, poses, obs, board.ObjectPoints(), bo);
  const Camera camera = ba.camera;
  nlohmann::json views_j = nlohmann::json::array();
  for (size_t k = 0; k < cal.views.size(); ++k) {
    nlohmann::json v = {{"image", cal.views[k].name}, {"used", cal.views[k].used}};
    if (!cal.views[k].used) v["rejected_because"] = cal.views[k].why;
    views_j.push_back(v);
  }
  for (size_t n = 0; n < view_index.size(); ++n) {
    views_j[view_index[n]]["rms_px"] = ba.view_rms_px[n];
    if (view_index[n] < int(first_photo)) continue;
    Photo& p = photos[view_index[n] - first_photo];
    p.posed = true;
    p.cam_from_world = ba.cam_from_board[n];
    p.rms_px = ba.view_rms_px[n];
  }
  for (size_t i = 0; i < photos.size(); ++i)
    if (!photos[i].posed) photos[i].why = cal.views[first_photo + i].why;
  report["camera"] = {{"model", CameraModelName(camera.model)}, {"params", camera.params},
                      {"calibrated_here", calibrate}, {"calibration_rms_px", cal.rms}};
  report["bundle"] = {{"rms_px_before", ba.initial_rms_px}, {"rms_px", ba.rms_px}, {"views", views_j}};
  timer.Stop();

  // 2b. Optional: structure from motion with COLMAP (camera fixed), placed in
  // the board frame by the photos that show the board; poses the photos that
  // do not.
  const std::string pose_mode = desc.value("poses", std::string("board"));
  if (pose_mode == "colmap") {
    timer.Start("colmap");
    std::string ws = (fs::temp_directory_path() / "svbrdf_colmap_XXXXXX").string();
    if (!mkdtemp(ws.data())) throw Error("capture: cannot create a temporary COLMAP workspace");
    const std::vector<std::string> photo_paths(detect_paths.begin() + first_photo, detect_paths.end());
    ColmapSfmOptions co_sfm;
    // COLMAP's threads too (its -1 is all cores, ours 0).
    co_sfm.threads = job.threads > 0 ? job.threads : -1;
    if (desc.contains("colmap_executable")) co_sfm.colmap = Field<std::string>(desc, "colmap_executable", ctx);
    std::map<std::string, Rigid3> known;
    for (size_t i = 0; i < photos.size(); ++i)
      if (photos[i].posed) known[ColmapImageName(photo_paths[i])] = photos[i].cam_from_world;
    std::optional<ColmapToBoard> by_distance;
    const bool by_board = known.size() >= 3 || !desc.contains("known_distance");
    if (!by_board) {  // board poses (fewer than 3) are in another frame
      for (Photo& p : photos) p.posed = false;
      known.clear();
    }
    // COLMAP's mapper sometimes converges to a wrong model (seen in the
    // COLMAP e2e test's runs: poses far from the board poses, which
    // otherwise agree closely). Where the board
    // gives poses to compare with, a model that disagrees by more than
    // kMaxBoardDisagreementDeg is run again with another RANSAC seed, up to
    // kColmapAttempts times; the last one is kept with a warning.
    constexpr double kMaxBoardDisagreementDeg = 5.0;
    constexpr int kColmapAttempts = 3;
    std::optional<KnownDistance> known_distance;
    if (desc.contains("known_distance"))
      known_distance = KnownDistanceFromJson(desc["known_distance"], ctx + ": known_distance");
    ColmapModel model;
    ColmapToBoard align;
    double worst_deg = 0, worst_mm = 0;
    int attempts = 0;
    for (int attempt = 0; attempt < kColmapAttempts; ++attempt) {
      attempts = attempt + 1;
      co_sfm.random_seed = attempt;
      fs::remove_all(ws);
      fs::create_directories(ws);
      model = RunColmapSfm(photo_paths, camera, ws, co_sfm);  // throws naming the log (kept)
      // Placed by the photos that show the board (3 or more); else scaled by
      // a known distance (orientation and origin then stay COLMAP's, and every
      // photo takes its COLMAP pose); with both, the known distance is a check.
      if (known_distance) by_distance = ScaleColmapByKnownDistance(model, *known_distance);
      align = by_board ? AlignColmapToBoard(model, known) : *by_distance;
      // Agreement of the two pose sources where both exist.
      worst_deg = 0, worst_mm = 0;
      for (const ColmapImage& im : model.images) {
        const auto it = known.find(im.name);
        if (it == known.end()) continue;
        const Rigid3 p = align.CamFromBoard(im.cam_from_world);
        worst_deg = std::max(worst_deg, Eigen::AngleAxisd(p.rotation * it->second.rotation.conjugate()).angle() * 180 / kPi);
        worst_mm = std::max(worst_mm, 1e3 * (p.CentreInWorld() - it->second.CentreInWorld()).norm());
      }
      if (known.empty() || worst_deg <= kMaxBoardDisagreementDeg) break;
      const std::string line = Msg("COLMAP attempt ", attempts, " (seed ", attempt, "): its poses disagree with the board's by ",
                                   worst_deg, " deg, ", worst_mm, " mm",
                                   attempts < kColmapAttempts ? "; running it again" : "; kept (check the photos' overlap)");
      if (job.progress) std::fprintf(stderr, "  %s\n", line.c_str());
      report["warnings"].push_back(line);
    }
    int newly_posed = 0;
    for (const ColmapImage& im : model.images)
      for (size_t i = 0; i < photos.size(); ++i)
        if (!photos[i].posed && ColmapImageName(photo_paths[i]) == im.name) {
          photos[i].posed = true;
          photos[i].cam_from_world = align.CamFromBoard(im.cam_from_world);
          ++newly_posed;
        }
    report["colmap"] = {{"registered_images", model.images.size()}, {"points", model.points.size()},
                        {"placed_by_board_photos", align.matched}, {"scale", align.scale},
                        {"centre_rms_mm", 1e3 * align.centre_rms_m}, {"photos_posed_only_by_colmap", newly_posed},
                        {"vs_board_worst_deg", worst_deg}, {"vs_board_worst_mm", worst_mm},
                        {"placed_by", by_board ? "board" : "known_distance"}, {"attempts", attempts}};
    if (by_distance) report["colmap"]["known_distance_scale"] = by_distance->scale;
    fs::remove_all(ws);
    timer.Stop();
  } else if (pose_mode != "board") {
    throw Error(Msg(ctx, ": poses: expected \"board\" or \"colmap\", got \"", pose_mode, "\""));
  }
  std::vector<size_t> posed;
  for (size_t i = 0; i < photos.size(); ++i)
    if (photos[i].posed) posed.push_back(i);
  if (posed.size() < 3) throw Error(Msg("capture: only ", posed.size(), " photos show the board; need 3"));

  // 3. Mesh registration by silhouettes.
  timer.Start("registration");
  const nlohmann::json& mesh_j = Field<nlohmann::json>(desc, "mesh", ctx);
  const std::string mesh_file = path(Field<std::string>(mesh_j, "file", ctx + ": mesh"));
  Mesh mesh = LoadMesh(mesh_file);
  const Rigid3 rough = PoseFromJson(Field<nlohmann::json>(mesh_j, "world_from_mesh", ctx + ": mesh"), ctx + ": mesh.world_from_mesh");
  const std::string mask_mode = desc.value("masks", std::string("given"));
  if (mask_mode != "given" && mask_mode != "grabcut")
    throw Error(Msg(ctx, ": masks: expected \"given\" or \"grabcut\", got \"", mask_mode, "\""));
  const bool grabcut = mask_mode == "grabcut";
  std::vector<SilhouetteView> sviews;
  for (size_t i : posed) {
    SilhouetteView v{camera, photos[i].cam_from_world, Image()};
    if (!grabcut) {
      if (photos[i].mask.empty()) throw Error(Msg(ctx, ": photos[", i, "]: masks are \"given\" but the photo has no mask"));
      v.mask = ReadImage(path(photos[i].mask));
    }
    sviews.push_back(std::move(v));
  }
  // GrabCut seeded by the mesh at `placement`; the undecided band covers
  // the placement's error: 4 % of the image diagonal for the rough one (cm:
  // tens of pixels), 1 % once registered.
  const double diagonal = std::hypot(camera.width, camera.height);
  auto grabcut_masks = [&](const Rigid3& placement, int margin) {
    ParallelFor(long(posed.size()), job.threads, [&](long k) {
      const Photo& ph = photos[posed[k]];
      sviews[k].mask = GrabCutMask(ph.hdr.radiance, RenderSilhouette(mesh, placement, camera, ph.cam_from_world), margin);
    });
  };
  if (grabcut) grabcut_masks(rough, std::max(6, int(0.04 * diagonal)));
  SilhouetteOptions so;
  so.outer_iterations = job.silhouette_iterations;
  so.threads = job.threads;
  so.progress = job.progress;
  SilhouetteResult reg = AlignSilhouettes(mesh, rough, sviews, so);
  auto iou_json = [&](const SilhouetteResult& r) {
    nlohmann::json iou = nlohmann::json::array();
    for (size_t k = 0; k < posed.size(); ++k)
      iou.push_back({{"photo", posed[k]}, {"before", r.iou_before[k]}, {"after", r.iou_after[k]}});
    return iou;
  };
  report["registration"] = {{"masks", mask_mode}};
  if (grabcut) {
    // Second pass: GrabCut seeded by the registered mesh, whose band can be
    // narrow now (the first pass's wide band lets board texture and the
    // dim background in), then the registration again from there.
    report["registration"]["first_pass"] = {{"world_from_mesh", PoseJson(reg.world_from_object)},
                                            {"mask_iou", iou_json(reg)}};
    grabcut_masks(reg.world_from_object, std::max(4, int(0.01 * diagonal)));
    reg = AlignSilhouettes(mesh, reg.world_from_object, sviews, so);
  }
  // mask_iou: each photo's mask (given, or GrabCut's) against the
  // registered mesh's silhouette, before and after registration.
  report["registration"]["world_from_mesh"] = PoseJson(reg.world_from_object);
  report["registration"]["contour_distance_px"] = reg.mean_distance_px;
  report["registration"]["mask_iou"] = iou_json(reg);
  // The registered mesh in the world frame with its own normals turned with
  // it (recomputing could change their weighting), and its silhouettes.
  Mesh world_mesh = mesh;
  for (Vec3& p : world_mesh.positions) p = reg.world_from_object * p;
  for (Vec3& n : world_mesh.normals) n = reg.world_from_object.rotation * n;
  std::vector<Image> silhouettes;
  for (size_t k = 0; k < posed.size(); ++k)
    silhouettes.push_back(RenderSilhouette(mesh, reg.world_from_object, camera, photos[posed[k]].cam_from_world));
  // The capture's masks: the given ones; with GrabCut, the registered
  // mesh's silhouette (GrabCut's edges follow colour, the mesh's the object).
  if (grabcut)
    for (size_t k = 0; k < posed.size(); ++k) sviews[k].mask = silhouettes[k];
  timer.Stop();

  // 4. Lights: mirror-sphere highlights -> position; board albedo -> intensity.
  timer.Start("lights");
  std::vector<MirrorSphere> spheres;  // optional when every light is a flash
  if (desc.contains("mirror_spheres")) {
    const nlohmann::json& ms = Field<nlohmann::json>(desc, "mirror_spheres", ctx);
    const double radius = Field<double>(ms, "radius", ctx + ": mirror_spheres");
    for (const auto& c : Field<std::vector<std::vector<double>>>(ms, "centres", ctx + ": mirror_spheres")) {
      if (c.size() != 3) throw Error(Msg(ctx, ": mirror_spheres.centres: expected [x, y, z]"));
      spheres.push_back({Vec3(c[0], c[1], c[2]), radius});
    }
  }
  // The white paper as a diffuse reference; its texture fine enough that a
  // pixel's footprint spans several texels.
  const BoardTexture tex = DrawBoard(board, 64);
  const RayTracer occluder(world_mesh);
  // The object's pixels: its mask and its registered silhouette, widened by
  // the blur of its edge.
  std::vector<Image> object_pixels;
  for (size_t k = 0; k < posed.size(); ++k) {
    Image m = silhouettes[k];
    for (size_t p = 0; p < m.pixels.size(); ++p) m.pixels[p] = std::max(m.pixels[p], sviews[k].mask.pixels[p]);
    object_pixels.push_back(DilateMask(m, 2));
  }
  PaperCounts paper_counts;
  auto white_samples = [&](size_t k, const Vec3& light_at, std::vector<DiffuseSample>* samples) {
    const Photo& ph = photos[posed[k]];
    const PaperView view{&camera, ph.cam_from_world, &ph.hdr.radiance, &ph.hdr.saturated, &object_pixels[k]};
    paper_counts += SampleWhitePaper(tex, view, spheres, &occluder, light_at, white, /*stride=*/2, samples);
  };
  auto no_paper = [&](int id, size_t photos_lit) {
    return Error(Msg(ctx, ": light ", id, ": no white board paper to measure its intensity in its ", photos_lit,
                     " photos (pixels that see only paper: ", paper_counts.white, "; covered by the object ",
                     paper_counts.hidden, ", in a shadow ", paper_counts.shadowed, ", near a mirror ball ",
                     paper_counts.near_ball, ", saturated ", paper_counts.saturated,
                     "). Give the lamp's \"intensity\" in W/sr (a number or [r, g, b]) for light ", id,
                     ", or show more of the board's white paper lit by it"));
  };
  std::vector<Light> lights;
  nlohmann::json lights_report = nlohmann::json::array();
  std::map<size_t, int> flash_of_photo;  // photo -> its flash light id
  for (const auto& lj : Field<nlohmann::json>(desc, "lights", ctx)) {
    Light light;
    light.id = Field<int>(lj, "id", ctx + ": lights[]");
    const std::string lctx = Msg(ctx, ": light ", light.id);
    const std::string kind = Field<std::string>(lj, "type", lctx);
    const std::optional<Rgb> given = IntensityFromJson(lj, lctx);
    std::vector<size_t> lit;  // posed photos it lights
    for (size_t k = 0; k < posed.size(); ++k)
      if (photos[posed[k]].light == light.id) lit.push_back(k);
    paper_counts = PaperCounts{};
    if (kind == "flash") {
      // A flash moves with the camera: one point light per photo at the
      // given offset in the camera frame (metres, x right, y down, z forward).
      const auto off = Field<std::vector<double>>(lj, "offset", lctx);
      if (off.size() != 3) throw Error(Msg(lctx, ": offset must be [x, y, z] metres"));
      const Vec3 offset(off[0], off[1], off[2]);
      // Intensity: given, or from the white paper of every photo it lit
      // (one flash, the same output in every photo: the median over all).
      Rgb intensity = given.value_or(Rgb::Zero());
      size_t reference_samples = 0;
      if (!given) {
        std::vector<Rgb> estimates;
        for (size_t k : lit) {
          std::vector<DiffuseSample> samples;
          const Vec3 at = photos[posed[k]].cam_from_world.Inverse() * offset;
          white_samples(k, at, &samples);
          AppendIntensityEstimates(samples, at, &estimates);
        }
        if (estimates.empty()) throw no_paper(light.id, lit.size());
        reference_samples = estimates.size();
        intensity = MedianIntensity(estimates);
      }
      for (size_t k : lit) {
        const size_t i = posed[k];
        Light f;
        f.id = 1000000 + int(i);  // ids of per-photo flashes; the photo is renumbered to it below
        f.type = LightType::kPoint;
        f.position = photos[i].cam_from_world.Inverse() * offset;
        f.intensity = intensity;
        flash_of_photo[i] = f.id;
        lights.push_back(f);
        lights_report.push_back({{"id", f.id}, {"flash_of_photo", i},
                                 {"position", {f.position.x(), f.position.y(), f.position.z()}},
                                 {"intensity", {intensity[0], intensity[1], intensity[2]}},
                                 {"intensity_measured", !given}, {"reference_samples", reference_samples}});
      }
      continue;
    }
    if (kind != "point")
      throw Error(Msg(lctx, ": type must be \"point\" (calibrated by mirror balls) or \"flash\""));
    std::vector<Ray3> rays;
    std::vector<HighlightObservation> highlights;
    for (size_t k : lit) {
      const size_t i = posed[k];
      for (size_t s = 0; s < spheres.size(); ++s) {
        Vec2 px;
        Ray3 ray;
        if (FindHighlight(photos[i].hdr.radiance, camera, photos[i].cam_from_world, spheres[s], &px) &&
            ReflectedRay(camera, photos[i].cam_from_world, spheres[s], px, &ray)) {
          rays.push_back(ray);
          highlights.push_back({&camera, photos[i].cam_from_world, int(s), px});
        }
      }
    }
    if (rays.size() < 2)
      throw Error(Msg(lctx, ": only ", rays.size(), " mirror-ball highlights found in its ", lit.size(),
                      " photos; need 2 (give \"mirror_spheres\" and show a ball in at least two photos)"));
    // Rays intersected in 3-D for a start, then refined in the images.
    double ray_rms = 0;
    const Vec3 from_rays = NearestPointToRays(rays, &ray_rms);
    const LampRefineResult refined =
        RefineLampPositionMultiStart(highlights, spheres, rays, from_rays, LampRefineOptions{});
    light.position = refined.position;
    light.type = LightType::kPoint;
    // The paper's shading fixes the lamp's distance, which the highlights
    // of nearby balls leave loose (lamp_position.h); twice, so that the
    // shadows are tested from the refined lamp.
    std::vector<DiffuseSample> samples;
    for (size_t k : lit) white_samples(k, light.position, &samples);
    nlohmann::json paper_fit;
    constexpr size_t kMinPaperForPosition = 200;
    for (int round = 0; round < 2 && samples.size() >= kMinPaperForPosition; ++round) {
      const LampPaperResult lp = RefineLampWithPaper(highlights, spheres, samples, light.position, LampPaperOptions{});
      light.position = lp.position;
      paper_fit = {{"highlight_rms_px", lp.highlight_rms_px}, {"paper_rms_relative", lp.paper_rms_relative},
                   {"ambient_share", lp.ambient_share}};
      samples.clear();
      paper_counts = PaperCounts{};
      for (size_t k : lit) white_samples(k, light.position, &samples);
      // Intensity from the lamp's share of the paper's light.
      if (round == 1)
        for (DiffuseSample& d : samples) d.value *= std::max(0.0, 1.0 - lp.ambient / std::max(1e-300, d.value.mean()));
    }
    std::optional<Rgb> measured;
    std::vector<Rgb> estimates;
    AppendIntensityEstimates(samples, light.position, &estimates);
    if (!estimates.empty()) measured = MedianIntensity(estimates);
    if (!given && !measured) throw no_paper(light.id, lit.size());
    light.intensity = given ? *given : *measured;
    lights.push_back(light);
    nlohmann::json lr = {{"id", light.id}, {"position", {light.position.x(), light.position.y(), light.position.z()}},
                         {"rays", rays.size()}, {"ray_rms_mm", 1e3 * ray_rms},
                         {"position_from_rays", {from_rays.x(), from_rays.y(), from_rays.z()}},
                         {"highlight_rms_px", {refined.initial_rms_px, refined.rms_px}},
                         {"highlights_rejected", refined.rejected},
                         {"position_from_highlights", {refined.position.x(), refined.position.y(), refined.position.z()}},
                         {"intensity", {light.intensity[0], light.intensity[1], light.intensity[2]}},
                         {"intensity_measured", !given}, {"reference_samples", estimates.size()},
                         {"paper_pixels", {{"white", paper_counts.white}, {"hidden", paper_counts.hidden},
                                           {"shadowed", paper_counts.shadowed}, {"near_ball", paper_counts.near_ball},
                                           {"saturated", paper_counts.saturated}}}};
    // A given intensity is checked against the paper where there is some.
    if (given && measured) lr["intensity_from_paper"] = {(*measured)[0], (*measured)[1], (*measured)[2]};
    if (!paper_fit.is_null()) lr["refined_on_paper_shading"] = paper_fit;
    lights_report.push_back(lr);
  }
  report["paper_albedo"] = paper_albedo_known
                               ? nlohmann::json{{"value", white}, {"given", true}}
                               : nlohmann::json{{"value", white}, {"given", false},
                                                {"note", Msg("white_albedo not given: measured lamp intensities assume the "
                                                             "paper's albedo is ", kAssumedPaperAlbedo,
                                                             ", so they and the material's albedos are relative to it")}};
  report["lights"] = lights_report;
  timer.Stop();

  // 5. Write the capture.
  timer.Start("write");
  OutputFolder out(job.out_dir);  // complete or absent, also on errors and signals
  const fs::path tmp = out.path();
  for (const char* d : {"images", "masks", "saturation", "report"}) fs::create_directories(tmp / d);
  SaveObj(world_mesh, (tmp / "mesh.obj").string(), /*write_normals=*/true);
  Scene scene;
  scene.dir = tmp.string();
  scene.mesh = "mesh.obj";
  scene.cameras = {camera};
  scene.cameras[0].id = 1;
  scene.lights = lights;
  for (size_t k = 0; k < posed.size(); ++k) {
    const size_t i = posed[k];
    char name[32];
    std::snprintf(name, sizeof name, "%04zu", i);
    ImageEntry e;
    e.file = Msg("images/", name, ".exr");
    e.mask = Msg("masks/", name, ".png");
    e.camera = 1;
    e.light = flash_of_photo.count(i) ? flash_of_photo.at(i) : photos[i].light;
    e.cam_from_world = photos[i].cam_from_world;
    e.exposure = 1.0;  // merged radiance is value / exposure
    WriteImage((tmp / e.file).string(), photos[i].hdr.radiance, PixelFormat::kFloat);
    // Saturated pixels carry no information: they leave the mask.
    Image mask = sviews[k].mask;
    for (size_t p = 0; p < mask.pixels.size(); ++p)
      mask.pixels[p] = (mask.pixels[p] > 0.5f && photos[i].hdr.saturated.pixels[p] == 0) ? 1.0f : 0.0f;
    WriteImage((tmp / e.mask).string(), mask, PixelFormat::kUInt8);
    WriteImage((tmp / "saturation" / (std::string(name) + ".png")).string(), photos[i].hdr.saturated, PixelFormat::kUInt8);
    scene.images.push_back(e);
  }
  nlohmann::json dropped = nlohmann::json::array();
  for (size_t i = 0; i < photos.size(); ++i)
    if (!photos[i].posed) dropped.push_back({{"photo", i}, {"why", photos[i].why}});
  report["dropped_photos"] = dropped;
  SaveScene(scene, (tmp / "scene.json").string());
  timer.Stop();
  nlohmann::json stages = nlohmann::json::object();
  for (const auto& s : timer.stages()) stages[s.name] = s.seconds;
  report["seconds"] = stages;
  WriteFileAtomic((tmp / "report" / "capture_report.json").string(), report.dump(2) + "\n");
  out.Commit();
  if (job.progress) std::fprintf(stderr, "%s", timer.Report().c_str());
  return report;
}

}  // namespace svbrdf
