#include "pipeline/photometric_stage.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "core/error.h"
#include "evaluate/metrics.h"
#include "export/render_target.h"
#include "io/material.h"
#include "photometric/dictionary_fit.h"
#include "photometric/observations.h"
#include "photometric/pixel_mesh.h"
#include "photometric/ps_folder.h"
#include "photometric/transfer.h"
#include "pipeline/report_html.h"

namespace svbrdf {

namespace fs = std::filesystem;

namespace {

Vec3 PixelNormal(const Image& n, int x, int y) { return Vec3(n.at(x, y, 0), n.at(x, y, 1), n.at(x, y, 2)); }

// Mean and median angle (degrees) between two camera-frame normal images over
// the region pixels where `truth` is set.
nlohmann::json AngularError(const Image& estimate, const Image& truth, const Image& region) {
  std::vector<double> deg;
  for (int y = 0; y < region.height; ++y)
    for (int x = 0; x < region.width; ++x) {
      const Vec3 t = PixelNormal(truth, x, y);
      if (region.at(x, y, 0) < 0.5f || t.norm() < 0.5) continue;
      const Vec3 e = PixelNormal(estimate, x, y).normalized();
      deg.push_back(std::acos(std::clamp(e.dot(t.normalized()), -1.0, 1.0)) * 180 / kPi);
    }
  if (deg.empty()) return nullptr;
  double sum = 0;
  for (double d : deg) sum += d;
  std::nth_element(deg.begin(), deg.begin() + deg.size() / 2, deg.end());
  return {{"mean_deg", sum / deg.size()}, {"median_deg", deg[deg.size() / 2]}, {"pixels", deg.size()}};
}

// Per-pixel depth image (camera z) from the observations' mesh hits.
std::vector<double> HitDepth(const PsObservations& obs) {
  std::vector<double> d(size_t(obs.width) * obs.height, 0.0);
  for (long p = 0; p < obs.P(); ++p) d[obs.pixel[p]] = obs.depth[p];
  return d;
}

double MeanDepth(const PsObservations& obs) {
  double s = 0;
  for (double d : obs.depth) s += d;
  return s / std::max<size_t>(1, obs.depth.size());
}

// Normals filled outside the pixels that had photos (nearest such pixel).
Image FillNormals(const PsObservations& obs, Image normals) {
  FillFromNearest(obs.valid, &normals);
  return normals;
}

// Integrates `normals` into the height field the pixel mesh is built on
// (depth out) and returns the photos each pixel lies in the cast shadow of
// that surface in.
//
// Poisson integration, not the bilateral one: normals estimated from the
// photos are wrong in places (metals under the Lambertian start, cast
// shadows, interreflection), and a discontinuity-preserving integration turns
// such errors into cliffs whose false shadows leave good photos out of the
// fits; a scan's normals (import-ps --normals) are integrated bilaterally.
std::vector<uint8_t> HeightFieldShadows(const PsObservations& obs, const Image& normals, double base_depth,
                                        int threads, std::vector<double>* depth) {
  NormalIntegrationOptions poisson;
  poisson.bilateral_iterations = 0;
  *depth = IntegrateNormals(normals, obs.region, obs.cam.MetresPerPixel(base_depth), poisson);
  const Mesh height_field = PixelGridMesh(obs.cam, obs.cam_from_world, obs.region, *depth, base_depth, normals);
  return CastShadows(obs, height_field, threads);
}

Image NormalsPicture(const Image& n_cam, const Image& region) {
  Image rgb(n_cam.width, n_cam.height, 3);
  for (int y = 0; y < rgb.height; ++y)
    for (int x = 0; x < rgb.width; ++x)
      if (region.at(x, y, 0) > 0.5f) {
        const Vec3 n = FlipYZ(PixelNormal(n_cam, x, y));  // shown in the usual frame: y up, z towards the camera
        for (int c = 0; c < 3; ++c) rgb.at(x, y, c) = float(0.5 * (n[c] + 1));
      }
  return rgb;
}

}  // namespace

nlohmann::json RunPhotometricReconstruction(const ReconstructionJob& job, const Scene& scene, StageTimer* timer) {
  DictionaryFitOptions fo = job.photometric;
  fo.threads = job.estimate.threads;
  const RenderTarget target = ParseRenderTarget(job.render_target);
  if (target == RenderTarget::kGltf)
    throw Error("reconstruct --for gltf: photometric captures fit a per-pixel mixture of dictionary BRDFs, "
                "which glTF cannot hold; use --for mitsuba or no --for");
  if (target != RenderTarget::kAny) fo.allow_model = [target](const ModelSpec& s) { return RendersExactly(s, target); };
  fo.Check();
  if (job.photometric_normal_rounds < 0 || job.photometric_normal_rounds > 10)
    throw Error(Msg("reconstruct: photometric normal rounds must be in [0, 10], got ", job.photometric_normal_rounds));
  if (job.photometric_shadow_rounds < 0 || job.photometric_shadow_rounds > 10)
    throw Error(Msg("reconstruct: photometric shadow rounds must be in [0, 10], got ", job.photometric_shadow_rounds));
  std::fprintf(stderr, "photometric capture: one fixed orthographic view, %zu directional lights: per-pixel fit\n",
               scene.images.size());
  timer->Start("read photos");
  const Mesh capture_mesh = LoadMesh(scene.Resolve(scene.mesh));
  capture_mesh.Validate(scene.Resolve(scene.mesh));
  const PsObservations obs = LoadObservations(scene, capture_mesh, fo.srgb_weight_exponent, fo.threads, true);
  std::fprintf(stderr, "  %d object pixels x %d photos\n", obs.P(), obs.lights);
  nlohmann::json summary;
  summary["pipeline"] = "photometric";
  summary["pixels"] = obs.P();
  summary["photos"] = obs.lights;

  // Ground truth for the report only, never for the fit.
  Image truth;
  if (scene.ground_truth.is_object() && scene.ground_truth.contains("normals_camera"))
    truth = ReadCameraNormals(scene.Resolve(scene.ground_truth["normals_camera"].get<std::string>()), obs.width,
                              obs.height);

  Image normals;
  std::vector<uint8_t> shadowed;
  std::vector<double> depth;
  double base_depth = 0;
  BasisSelection sel;
  nlohmann::json normal_info;
  if (scene.mesh_normals_known) {
    timer->Start("shadows");
    normals = FillNormals(obs, MeshNormalsCamera(obs, capture_mesh));
    shadowed = CastShadows(obs, capture_mesh, fo.threads);
    depth = HitDepth(obs);
    normal_info["source"] = "capture mesh";
  } else {
    timer->Start("lambertian normals");
    Image determined, misfit;
    // Pixels the photos do not determine (dark or mirror-like in nearly
    // every photo) take the membrane of their determined surroundings
    // instead of facing the camera. (A pixel without valid photos is never
    // determined.)
    auto lambertian = [&](const std::vector<uint8_t>& cast_shadows) {
      normals = LambertianNormals(obs, cast_shadows, fo.threads, &determined, &misfit);
      FillNormalsSmoothly(determined, obs.region, &normals);
      normals = FillNormals(obs, normals);
    };
    lambertian({});
    if (truth.width) {
      normal_info["lambertian_start"] = AngularError(normals, truth, obs.region);
      std::fprintf(stderr, "  Lambertian start: normals %.2f deg from the truth\n",
                   double(normal_info["lambertian_start"]["mean_deg"]));
    }
    base_depth = MeanDepth(obs);
    // The interquartile photos leave out a pixel's darkest quarter, but in a
    // concavity more than a quarter of the lights can be hidden: the start's
    // height field says which, and the Lambertian fit is solved again
    // without them.
    for (int round = 0; round < job.photometric_shadow_rounds; ++round) {
      timer->Start("height field + shadows");
      shadowed = HeightFieldShadows(obs, normals, base_depth, fo.threads, &depth);
      timer->Start("lambertian normals");
      lambertian(shadowed);
      if (truth.width) {
        normal_info["shadow_rounds"].push_back(AngularError(normals, truth, obs.region));
        std::fprintf(stderr, "  Lambertian without the height field's cast shadows (round %d): normals %.2f deg from "
                     "the truth\n", round + 1, double(normal_info["shadow_rounds"].back()["mean_deg"]));
      }
    }
    const long undetermined = std::count_if(obs.pixel.begin(), obs.pixel.end(),
                                            [&](int px) { return determined.pixels[px] <= 0.5f; });
    normal_info["undetermined_pixels"] = undetermined;
    std::fprintf(stderr, "  Lambertian start: %ld of %d pixels not determined by the photos (%.1f %%): filled from "
                 "their surroundings\n", undetermined, obs.P(), 100.0 * undetermined / std::max(1, obs.P()));
    // Where the Lambertian start misfits its inlier photos (metals,
    // lobe-dominated paint) the normals are searched under the fitted basis;
    // the window median keeps isolated pixels (edges, noise) out.
    Image search = RegionMedian(misfit, obs.region, 7);
    long searched = 0;
    for (long p = 0; p < obs.P(); ++p) {
      float& s = search.pixels[obs.pixel[p]];
      s = fo.search_misfit == 0 || s > fo.search_misfit ? 1.0f : 0.0f;
      searched += s > 0.5f;
    }
    normal_info["searched_pixels"] = job.photometric_normal_rounds > 0 ? searched : 0;
    std::fprintf(stderr, "  Lambertian start misfits its photos (relative RMS > %g) on %ld of %d pixels (%.1f %%)%s\n",
                 fo.search_misfit, searched, obs.P(), 100.0 * searched / std::max(1, obs.P()),
                 searched > 0 && job.photometric_normal_rounds > 0 ? ": their normals are searched under the basis" : "");
    for (int round = 0; round < job.photometric_normal_rounds && searched > 0; ++round) {
      timer->Start("height field + shadows");
      shadowed = HeightFieldShadows(obs, normals, base_depth, fo.threads, &depth);
      timer->Start("basis selection");
      sel = SelectBasis(obs, normals, shadowed, fo);
      timer->Start("normal refinement");
      normals = FillNormals(obs, RefineNormals(obs, sel.basis, normals, shadowed, fo, &search));
      if (truth.width) {
        normal_info["rounds"].push_back(AngularError(normals, truth, obs.region));
        std::fprintf(stderr, "  round %d: %zu basis BRDFs, normals %.2f deg from the truth\n", round + 1,
                     sel.basis.size(), double(normal_info["rounds"].back()["mean_deg"]));
      }
    }
    if (job.photometric_lobe_normals) {
      // Where the start fits its photos (the pixels the search above left
      // alone), the normals under one lobe shape for the object
      // (RefineNormalsUnderOneLobe). After the search, so that the metals'
      // search starts from the Lambertian start's height field.
      timer->Start("one-lobe normals");
      Image elsewhere(obs.width, obs.height, 1);
      for (long p = 0; p < obs.P(); ++p)
        elsewhere.pixels[obs.pixel[p]] = search.pixels[obs.pixel[p]] > 0.5f ? 0.0f : 1.0f;
      std::string lobe;
      normals = FillNormals(obs, RefineNormalsUnderOneLobe(obs, normals, shadowed, fo, elsewhere, &lobe));
      normal_info["one_lobe"] = lobe;
      if (truth.width) {
        normal_info["one_lobe_error"] = AngularError(normals, truth, obs.region);
        std::fprintf(stderr, "  one-lobe normals (diffuse + %s) where the start fits: normals %.2f deg from the truth\n",
                     lobe.c_str(), double(normal_info["one_lobe_error"]["mean_deg"]));
      } else {
        std::fprintf(stderr, "  one-lobe normals (diffuse + %s) where the start fits\n", lobe.c_str());
      }
    }
    timer->Start("height field + shadows");
    shadowed = HeightFieldShadows(obs, normals, base_depth, fo.threads, &depth);
    normal_info["source"] = "estimated from the photos";
  }
  if (truth.width) normal_info["error"] = AngularError(normals, truth, obs.region);
  if (truth.width) normal_info["mean_angular_error_deg"] = normal_info["error"]["mean_deg"];

  timer->Start("basis selection");
  sel = SelectBasis(obs, normals, shadowed, fo);
  for (const std::string& line : sel.log) std::fprintf(stderr, "  %s\n", line.c_str());
  timer->Start("weights");
  Material material;
  material.width = obs.width, material.height = obs.height;
  material.basis = sel.basis;
  Image confidence;
  SolveWeights(obs, sel.basis, normals, shadowed, fo, &material.weights, &confidence);
  for (Image& w : material.weights) FillFromNearest(obs.valid, &w);
  material.confidence = confidence;
  timer->Start("light transfer");
  // No renderer but ours reads light_transfer: an export target leaves it out.
  const TransferFit transfer = target == RenderTarget::kAny
                                   ? FitTransfer(obs, sel.basis, material.weights, normals, shadowed, fo)
                                   : TransferFit{};
  std::fprintf(stderr, "  light transfer beyond the BRDF: cross-validated error %.4g -> %.4g: %s\n",
               transfer.cv_error_without, transfer.cv_error_with,
               transfer.kept ? Msg("kept, ", transfer.terms, " terms").c_str() : "not kept");
  summary["render_target"] = RenderTargetName(target);
  summary["light_transfer"] = {{"cv_error_without", transfer.cv_error_without},
                               {"cv_error_with", transfer.cv_error_with},
                               {"terms", transfer.terms},
                               {"kept", transfer.kept}};
  for (const auto& [terms, e] : transfer.cv_error_by_terms)
    summary["light_transfer"]["cv_error_by_terms"].push_back({{"terms", terms}, {"error", e}});
  material.light_transfer = transfer.maps;
  for (Image& t : material.light_transfer) FillFromNearest(obs.valid, &t);
  if (target == RenderTarget::kAny && fo.residual_window >= 0) {
    timer->Start("light residuals");
    ResidualField residuals = FitResidualField(obs, sel.basis, material.weights, material.light_transfer,
                                                     normals, shadowed, fo);
    double share = 0;
    for (long p = 0; p < obs.P(); ++p) share += residuals.share.pixels[obs.pixel[p]];
    share /= std::max(1, obs.P());
    std::fprintf(stderr, "  light residuals interpolated between the %d nearest lights: leave-one-light-out error %.4g "
                 "-> %.4g (mean carry-over share %.3f): %s\n", kLightResidualNeighbours, residuals.loo_error_without,
                 residuals.loo_error_with, share, residuals.kept ? "kept" : "not kept");
    summary["light_residuals"] = {{"loo_error_without", residuals.loo_error_without},
                                  {"loo_error_with", residuals.loo_error_with},
                                  {"mean_share", share},
                                  {"window", fo.residual_window},
                                  {"kept", residuals.kept}};
    if (residuals.kept) {
      material.light_residual_directions = std::move(residuals.directions);
      material.light_residuals = std::move(residuals.maps);
    }
  }
  material.texture_filter = TextureFilter::kNearest;
  const Rigid3 world_from_cam = obs.cam_from_world.Inverse();
  material.normal_map = Image(obs.width, obs.height, 3);
  material.material_id = Image(obs.width, obs.height, 1);
  for (int y = 0; y < obs.height; ++y)
    for (int x = 0; x < obs.width; ++x) {
      const Vec3 n = world_from_cam.rotation * PixelNormal(normals, x, y).normalized();
      for (int c = 0; c < 3; ++c) material.normal_map.at(x, y, c) = std::isfinite(n[c]) ? float(n[c]) : 0.0f;
      int best = 0;
      for (size_t k = 1; k < material.weights.size(); ++k)
        if (material.weights[k].at(x, y, 1) > material.weights[best].at(x, y, 1)) best = int(k);
      material.material_id.at(x, y, 0) = float(best);
    }
  material.mesh = PixelGridMesh(obs.cam, obs.cam_from_world, obs.region, depth, base_depth, normals);
  material.extra = {{"pipeline", "photometric (per-pixel dictionary fit)"},
                    {"normals", normal_info.value("source", "")},
                    {"texel", "one per photo pixel"}};

  timer->Start("write");
  SaveMaterial(material, job.out_dir);
  std::vector<Image>().swap(material.light_residuals);  // written; the report reads the folder back
  Image camera_normals(obs.width, obs.height, 3);
  for (int y = 0; y < obs.height; ++y)
    for (int x = 0; x < obs.width; ++x)
      if (obs.region.at(x, y, 0) > 0.5f) {
        const Vec3 n = FlipYZ(PixelNormal(normals, x, y).normalized());
        for (int c = 0; c < 3; ++c) camera_normals.at(x, y, c) = float(n[c]);
      }
  WriteImage(job.out_dir + "/normals_camera.exr", camera_normals, PixelFormat::kFloat);

  summary["clusters"] = int(sel.basis.size());
  for (const auto& b : sel.basis) summary["basis"].push_back(BasisToJson(b));
  summary["basis_selection"] = sel.log;
  summary["cross_validated_error"] = sel.cv_error;
  summary["normals"] = normal_info;
  long shadowed_count = 0;
  for (uint8_t s : shadowed) shadowed_count += s;
  summary["cast_shadow_share"] = shadowed.empty() ? 0.0 : double(shadowed_count) / shadowed.size();
  if (job.report) {
    timer->Start("report");
    const std::string dir = job.out_dir + "/report";
    fs::create_directories(dir);
    WriteImage(dir + "/normals.png", NormalsPicture(normals, obs.region), PixelFormat::kUInt8, ColorSpace::kLinear);
    WriteImage(dir + "/diffuse.png", material.weights[0], PixelFormat::kUInt8, ColorSpace::kSRGB);
    if (truth.width) {
      Image err(obs.width, obs.height, 1);
      for (int y = 0; y < obs.height; ++y)
        for (int x = 0; x < obs.width; ++x) {
          const Vec3 t = PixelNormal(truth, x, y);
          if (obs.region.at(x, y, 0) < 0.5f || t.norm() < 0.5) continue;
          const double a = std::acos(std::clamp(PixelNormal(normals, x, y).normalized().dot(t.normalized()), -1.0, 1.0));
          err.at(x, y, 0) = float(std::min(1.0, a * 180 / kPi / 20));  // 0..20 degrees
        }
      WriteImage(dir + "/normals_error.png", err, PixelFormat::kUInt8, ColorSpace::kLinear);
    }
    const Material written = LoadMaterial(job.out_dir);
    const std::string held = (fs::path(scene.dir) / "heldout" / "scene.json").string();
    if (fs::exists(held)) {
      const Scene hs = LoadScene(held);
      summary["twin"] = WriteTwin(written, hs, 0, dir, "heldout");
      summary["twin"]["kind"] = "held-out view";
    } else {
      summary["twin"] = WriteTwin(written, scene, 0, dir, "input");
      summary["twin"]["kind"] = "input view (the capture has no held-out views)";
    }
  }
  timer->Stop();
  AddStageTimes(*timer, &summary);
  summary["total_s"] = timer->Total();
  summary["peak_memory_mb"] = PeakMemoryMB();
  if (job.report) WriteFileAtomic(job.out_dir + "/report/summary.json", summary.dump(2) + "\n");
  std::fprintf(stderr, "%s", timer->Report().c_str());
  return summary;
}

}  // namespace svbrdf
