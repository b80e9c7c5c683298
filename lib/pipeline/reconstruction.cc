#include "pipeline/reconstruction.h"

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "atlas/surface_neighbours.h"
#include "cluster/stats.h"
#include "cluster/weights.h"
#include "core/error.h"
#include "core/progress.h"
#include "evaluate/metrics.h"
#include "export/render_target.h"
#include "io/material.h"
#include "io/scene.h"
#include "normals/normal_map.h"
#include "pipeline/fine_weights_stage.h"
#include "pipeline/interreflection_stage.h"
#include "pipeline/normal_stage.h"
#include "pipeline/photometric_stage.h"
#include "photometric/observations.h"
#include "pipeline/report_html.h"
#include "relight/relight.h"

namespace svbrdf {

namespace fs = std::filesystem;

namespace {

// Per-texel values into a texture-sized single-channel image (0 elsewhere).
Image TexelMap(const Atlas& atlas, const std::vector<float>& values) {
  Image img(atlas.width, atlas.height, 1, 0.0f);
  for (size_t t = 0; t < atlas.texels.size(); ++t) img.at(atlas.texels[t].x, atlas.texels[t].y, 0) = values[t];
  return img;
}


// The normal map as colours (xyz -> rgb = (n + 1) / 2) and, when the capture
// has a ground-truth material on the same texture coordinates, the angle
// between refined and true normals (0..20 degrees ramp) next to the angle
// between mesh and true normals.
nlohmann::json WriteNormalPictures(const Scene& scene, const GatherResult& g, const NormalRefinement& nr,
                                   const std::string& dir) {
  Image rgb = NormalMapImage(g.atlas, nr.normal, NormalMapSpace::kWorld);
  for (float& v : rgb.pixels) v = 0.5f * (v + 1.0f);
  WriteImage(dir + "/normals.png", rgb, PixelFormat::kUInt8, ColorSpace::kLinear);
  nlohmann::json out = {{"normal_map", "normals.png"}};
  const std::string gt_dir = scene.ground_truth.is_object() ? scene.ground_truth.value("material", "") : "";
  if (gt_dir.empty() || g.made_uvs || !fs::exists(fs::path(scene.Resolve(gt_dir)) / "material.json")) return out;
  const Material truth = LoadMaterial(scene.Resolve(gt_dir));
  std::vector<Vec3> mesh_normals;
  for (const Texel& tx : g.atlas.texels) mesh_normals.push_back(tx.normal);
  const NormalErrors refined = CompareNormals(g.atlas, nr.normal, truth);
  const NormalErrors mesh = CompareNormals(g.atlas, mesh_normals, truth);
  std::vector<float> deg(refined.degrees.begin(), refined.degrees.end());
  WriteImage(dir + "/normal_error.png", ColorRamp(TexelMap(g.atlas, deg), 0, 20), PixelFormat::kUInt8,
             ColorSpace::kLinear);
  deg.assign(mesh.degrees.begin(), mesh.degrees.end());
  WriteImage(dir + "/normal_error_mesh.png", ColorRamp(TexelMap(g.atlas, deg), 0, 20), PixelFormat::kUInt8,
             ColorSpace::kLinear);
  std::fprintf(stderr, "  normal error vs ground truth: refined mean %.2f median %.2f deg, mesh mean %.2f median %.2f deg\n",
               refined.mean_deg, refined.median_deg, mesh.mean_deg, mesh.median_deg);
  out["error_vs_truth_deg"] = {{"refined_mean", refined.mean_deg}, {"refined_median", refined.median_deg},
                               {"mesh_mean", mesh.mean_deg},       {"mesh_median", mesh.median_deg},
                               {"picture", "normal_error.png"},     {"picture_mesh", "normal_error_mesh.png"}};
  for (size_t k = 0; k < refined.mean_by_material.size(); ++k) {
    std::fprintf(stderr, "    true material %zu: refined mean %.2f median %.2f deg, mesh mean %.2f median %.2f deg\n", k,
                 refined.mean_by_material[k], refined.median_by_material[k], mesh.mean_by_material[k],
                 mesh.median_by_material[k]);
    out["error_vs_truth_deg"]["by_true_material"].push_back(
        {{"refined_mean", refined.mean_by_material[k]}, {"refined_median", refined.median_by_material[k]},
         {"mesh_mean", mesh.mean_by_material[k]}, {"mesh_median", mesh.median_by_material[k]}});
  }
  return out;
}

}  // namespace

nlohmann::json WriteTwin(const Material& material, const Scene& scene, size_t index, const std::string& dir,
                         const std::string& tag) {
  const ImageEntry& e = scene.images[index];
  RayTracer tracer(material.mesh);
  MaterialShader shader(material);
  // A report picture, not the score (`svbrdf evaluate` on a `relight`
  // folder is): 4 x 4 jittered samples per pixel and one indirect path each
  // cost a fraction of the pixel-integrating default's adaptive rounds,
  // which took 2-9 s of a 15-45 s reconstruction.
  RelightOptions ro;
  ro.samples_per_pixel = 4;
  ro.bounce_samples = 1;
  ro.progress = false;
  ro.bounces = MaterialBounces(material);
  RenderedView v = RenderView(tracer, shader, scene, index, ro);
  const Image photo = ReadImage(scene.Resolve(e.file), scene.images_color_space);
  Image mask;
  if (!e.mask.empty()) mask = ReadImage(scene.Resolve(e.mask));
  const ImageMetrics m = CompareImages(photo, v.color, e.mask.empty() ? nullptr : &mask, e.exposure);
  WriteImage(dir + "/" + tag + "_photo.png", photo, PixelFormat::kUInt8, ColorSpace::kSRGB);
  WriteImage(dir + "/" + tag + "_relit.png", v.color, PixelFormat::kUInt8, ColorSpace::kSRGB);
  WriteImage(dir + "/" + tag + "_error.png", ErrorMap(photo, v.color, 0.05 * e.exposure), PixelFormat::kUInt8,
             ColorSpace::kLinear);
  return {{"view", e.file}, {"psnr_srgb", m.psnr_srgb}, {"rel_rmse_linear", m.rel_rmse_linear},
          {"relight", ro.SamplingDescription()}};
}

namespace {

// Per image, the pixel value per unit sample value (samples.h: y_c = value_c
// / exposure x mean_c(E) / E_c): the exposure times the light's colour, its
// channels over their mean.
DisplayScale DisplayScaleOf(const Scene& scene) {
  DisplayScale out;
  for (const ImageEntry& e : scene.images) {
    const Light& l = scene.LightById(e.light);
    Rgb colour = Rgb::Ones();
    if (l.type == LightType::kDirectional) colour = l.irradiance;
    else if (l.type != LightType::kGoniometric) colour = l.intensity;
    if (!(colour.mean() > 0)) colour = Rgb::Ones();
    out.push_back(e.exposure * colour / colour.mean());
  }
  return out;
}

}  // namespace

nlohmann::json RunReconstruction(const ReconstructionJob& job) {
  StageTimer timer;
  // Options before any work: a value out of range is named at once, not
  // after the gathering.
  job.estimate.Check();
  job.fine.Check();
  job.mirror.Check();
  if (!(job.time_budget_s >= 0 && std::isfinite(job.time_budget_s)))
    throw Error(Msg("reconstruct: --time-budget must be >= 0 seconds, got ", job.time_budget_s));
  if (!(job.time_spent_before_s >= 0 && std::isfinite(job.time_spent_before_s)))
    throw Error(Msg("reconstruct: time spent before the start must be >= 0 seconds, got ", job.time_spent_before_s));
  const auto start = std::chrono::steady_clock::now() - std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                            std::chrono::duration<double>(job.time_spent_before_s));
  for (const auto& [name, v] : {std::pair{"--fit-max-unlit-share", job.fit_max_unlit_share},
                                std::pair{"--fit-max-foreign-share", job.fit_max_foreign_share}})
    if (!(v >= 0 && v <= 1)) throw Error(Msg("reconstruct: ", name, " must be in [0, 1], got ", v));
  if (job.selection_error != "display" && job.selection_error != "linear")
    throw Error(Msg("reconstruct: --selection-error must be display or linear, got \"", job.selection_error, "\""));
  const RenderTarget target = ParseRenderTarget(job.render_target);
  if (target != RenderTarget::kAny && !job.estimate.force_model.empty() &&
      !RendersExactly(ModelSpec::FromLabel(job.estimate.force_model), target))
    throw Error(Msg("reconstruct: --model ", job.estimate.force_model, " has no exact ", RenderTargetName(target),
                    " form; drop --model or --for ", RenderTargetName(target)));
  timer.Start("load capture");
  const Scene scene = LoadScene(job.scene_path);
  if (scene.images.empty()) throw Error(Msg(job.scene_path, ": images: the capture has no photos"));
  // One fixed orthographic view under directional lights: per pixel.
  if (IsPhotometricCapture(scene)) return RunPhotometricReconstruction(job, scene, &timer);

  timer.Start("gather samples");
  GatherResult g = Gather(scene, job.gather);
  if (job.after_gather) job.after_gather(g);
  std::fprintf(stderr, "  %s\n", g.stats.Report().c_str());
  InterreflectionReport interreflection;
  InterreflectionOptions io = job.interreflection;
  io.seed = job.estimate.seed;
  io.threads = job.estimate.threads;
  io.progress = io.progress && job.estimate.progress;
  std::array<std::vector<float>, 3> raw_y;  // for the second pass (interreflection_stage.h)
  if (job.interreflection.bounces > 0) {
    timer.Start("interreflection");
    if (io.refit) raw_y = {g.samples.y[0], g.samples.y[1], g.samples.y[2]};
    interreflection = RemoveInterreflection(scene, &g, io);
    std::fprintf(stderr, "  %s\n", interreflection.Summary().c_str());
  }

  timer.Start("fit + cluster");
  ReconstructOptions eo = job.estimate;
  eo.candidate_models = CandidatesFor(target, eo.candidate_models);
  if (job.selection_error == "display") eo.display_scale = DisplayScaleOf(scene);
  if (target != RenderTarget::kAny)
    std::fprintf(stderr, "  --for %s: candidate models %s\n", RenderTargetName(target).c_str(),
                 nlohmann::json(eo.candidate_models).dump().c_str());
  if (job.time_budget_s > 0)
    eo.deadline = start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(job.time_budget_s - std::max(0.3, 0.05 * job.time_budget_s)));
  const auto cluster_start = std::chrono::steady_clock::now();
  // The fits see only samples whose footprint is on the lit surface; the
  // split search sees all (ReconstructionJob::fit_max_unlit_share).
  std::vector<char> fit_keep(g.probes.size(), 1);
  int64_t dropped = 0;
  for (size_t s = 0; s < g.probes.size(); ++s) {
    fit_keep[s] = g.probes[s].unlit <= job.fit_max_unlit_share && g.probes[s].foreign <= job.fit_max_foreign_share;
    dropped += !fit_keep[s];
  }
  // With the interreflection's second pass (interreflection_stage.h) the
  // search runs on the first pass's samples, the indirect light is traced
  // again with its materials, and steps 3-6 fit the samples without it.
  const bool second_pass = io.refit && interreflection.removed_share > 0;
  const bool subset = dropped > 0 && dropped < g.samples.size();
  SvbrdfEstimate est;
  if (subset) {
    SampleSet fit = KeepSamples(g.samples, fit_keep);
    std::fprintf(stderr, "  footprint probe: %lld of %lld samples partly unlit or on another surface: split search only\n",
                 static_cast<long long>(dropped), static_cast<long long>(g.samples.size()));
    est = second_pass ? SearchSvbrdf(g.samples, g.atlas, eo) : EstimateSvbrdf(g.samples, g.atlas, eo, &fit);
    // The stages below (normals, merge, report) work on the fit samples.
    g.samples = std::move(fit);
    std::vector<SampleProbe> kept;
    for (size_t s = 0; s < g.probes.size(); ++s)
      if (fit_keep[s]) kept.push_back(g.probes[s]);
    g.probes = std::move(kept);
  } else {
    est = second_pass ? SearchSvbrdf(g.samples, g.atlas, eo) : EstimateSvbrdf(g.samples, g.atlas, eo);
  }
  nlohmann::json interreflection_pass2;
  if (second_pass) {
    if (subset)
      for (auto& y : raw_y) {
        std::vector<float> sub;
        sub.reserve(g.samples.size());
        for (size_t i = 0; i < y.size(); ++i)
          if (fit_keep[i]) sub.push_back(y[i]);
        y = std::move(sub);
      }
    timer.Start("interreflection, 2nd pass");
    const InterreflectionPass2Report r = RemoveInterreflectionWithSearchMaterials(scene, raw_y, io, interreflection, &g, est);
    std::fprintf(stderr, "  %s\n", r.Summary().c_str());
    interreflection_pass2 = {{"changed_share", r.changed_share}, {"max_material_change", r.max_change}};
    timer.Start("fit + cluster");
    est = FinishEstimateOnNewSamples(g.samples, g.atlas, eo, est);
  }
  const double cluster_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - cluster_start).count();

  NormalOptions no = job.normals;
  no.holdout_fraction = eo.holdout_fraction;
  no.seed = eo.seed;
  no.threads = eo.threads;
  no.progress = no.progress && eo.progress;
  no.deadline = eo.deadline;
  nlohmann::json normals_rounds = nlohmann::json::array();
  const SvbrdfEstimate est_mesh_normals = no.mode == "on" ? est : SvbrdfEstimate();
  MergeReport merge;  // the merge stage runs inside the normal stage, before its material rounds
  PhotoCheck stage_check;  // measured when the stage's own photo check still describes its output
  NormalRefinement nr = RunNormalStage(g, eo, no, job.alternation, cluster_seconds, &timer, &est, &normals_rounds,
                                       &scene, job.normal_map_space, job.merge, &merge, &stage_check);
  nlohmann::json photo_check;
  // The output falls back to the clustering's estimate with mesh normals
  // (no merge, no refinement).
  auto back_to_mesh_normals = [&] {
    est = est_mesh_normals;
    merge.merges = 0;
    nr = NormalRefinement();
  };
  // The region-interior smoothing that the held-out samples chose for the
  // estimate's weights, on the output's weights (the normal stage and the
  // fine weights solve them unsmoothed).
  auto smooth_output_weights = [&] {
    SmoothInteriorWeights(SurfaceNeighbours(g.atlas), int(est.basis.size()), est.weight_smoothing, &est.weights);
  };
  if (nr.kept && no.mode == "on") {
    // The map as relight uses it, on held-out photos (normal_stage.h), after
    // the material rounds too (the stage checked the first refinement).
    // When nothing changed since the stage's check (no merge, no material
    // round kept), its three renders are these: not rendered again.
    if (!stage_check.measured) timer.Start("normal map photo check");
    const PhotoCheck pc = stage_check.measured
                              ? stage_check
                              : CheckNormalMapOnPhotos(scene, g, eo, est_mesh_normals, est, nr, job.normal_map_space);
    // Three renders: the refined materials and weights may pay where their
    // map does not (normal_stage.h: the bunny scan).
    const PhotoChoice choice = ChooseOnPhotos(pc, no.min_improvement);
    const char* what = choice == PhotoChoice::kRefinedWithMap      ? "kept"
                       : choice == PhotoChoice::kRefinedWithoutMap ? "not kept (refined materials and weights, mesh normals)"
                                                                   : "not kept (mesh normals, clustering's estimate)";
    std::fprintf(stderr, "  normal map on %d held-out photos: squared error %g without, %g with (%g refined without the "
                 "map): %s\n", pc.photos, pc.error_without_map, pc.error_with_map, pc.error_refined_no_map, what);
    photo_check = {{"photos", pc.photos}, {"error_without_map", pc.error_without_map},
                   {"error_with_map", pc.error_with_map}, {"error_refined_no_map", pc.error_refined_no_map},
                   {"kept", choice == PhotoChoice::kRefinedWithMap},
                   {"refined_materials_kept", choice != PhotoChoice::kMeshNormals},
                   {"reused_stage_check", stage_check.measured}};
    if (choice == PhotoChoice::kMeshNormals) back_to_mesh_normals();
    else if (choice != PhotoChoice::kRefinedWithMap) nr = NormalRefinement();
  }
  smooth_output_weights();  // re-solved with the refined normals when those were kept

  // A mirror shows what it reflects: only where the object sees itself
  // (interreflection traced) is there anything to fit it to. Past the
  // deadline too: a mirror fitted as a glossy material is a wrong answer,
  // not a rougher one, and the stage costs a small fraction of the fits.
  MirrorReport mirrors;
  if (interreflection.removed_share > 0 && job.mirror.enabled) {
    timer.Start("mirrors");
    MirrorOptions mo = job.mirror;
    mo.bounces = std::max(0, interreflection.bounces - 1);
    const bool raw_match = raw_y[0].size() == size_t(g.samples.size());
    auto fit_mirrors = [&] {
      mirrors = FitMirrors(scene, g, eo, mo, &est, raw_match ? &raw_y : nullptr);
      for (const std::string& l : mirrors.lines) std::fprintf(stderr, "  mirror stage: %s\n", l.c_str());
    };
    fit_mirrors();
    // Refined normals kept for a material that turned out a mirror were
    // fitted to explain what the mirror explains (its reflections, read as
    // tilts), and so were the weights solved with them: the mirror fitted
    // on those weights takes a far lower F0 (a Mitsuba torus of polished
    // aluminium; reverting the mirror texels' normals alone recovers only
    // part of it, docs/measurements.md). The refinement is void: the
    // clustering's estimate with mesh normals, and mirrors fitted to it.
    if (no.mode == "on" && RefinedMaterialIsAMirror(est, nr)) {
      back_to_mesh_normals();
      smooth_output_weights();
      photo_check["kept"] = photo_check["refined_materials_kept"] = false;
      photo_check["void_for_a_mirror"] = true;
      std::fprintf(stderr, "  mirror stage: refined normals were kept for a mirror's texels: not kept (mesh normals, "
                   "the clustering's estimate), mirrors fitted again\n");
      fit_mirrors();
    }
  }

  FineWeightsReport fine_weights;
  if (job.fine_weights) {
    timer.Start("fine weights");
    FineWeightsInputs in;
    in.normal_map = nr.kept;
    if (interreflection.removed_share > 0) {
      in.indirect_unknown = mirrors.replaced > 0 || raw_y[0].size() != size_t(g.samples.size());
      if (!in.indirect_unknown) in.raw_y = &raw_y;
    }
    fine_weights = RefineWeightsOnFinerAtlas(scene, job.gather, job.fine, eo, in, &g, &est);
    if (!fine_weights.line.empty()) std::fprintf(stderr, "  %s\n", fine_weights.line.c_str());
    if (fine_weights.kept) smooth_output_weights();
  }

  timer.Start("write material");
  Material material = ToMaterial(est, g.atlas, g.mesh);
  if (nr.kept) {
    material.normal_map = NormalMapImage(g.atlas, nr.normal, job.normal_map_space);
    material.normal_map_space = job.normal_map_space;
  }
  material.extra = {{"source", "svbrdf reconstruct"}, {"scene", job.scene_path}};
  // Fitted to direct light: renders add the indirect light that was removed
  // (none on an object that sees nothing of itself).
  if (interreflection.removed_share > 0) SetMaterialBounces(&material, interreflection.bounces);
  SaveMaterial(material, job.out_dir);
  material = LoadMaterial(job.out_dir);  // what relight will see

  nlohmann::json summary;
  summary["scene"] = job.scene_path;
  summary["texels"] = g.atlas.texels.size();
  summary["texture_size"] = g.atlas.width;
  summary["made_uvs"] = g.made_uvs;
  summary["samples"] = {{"kept", g.stats.kept},          {"candidates", g.stats.candidates},
                        {"outside_image", g.stats.outside_image}, {"back_facing", g.stats.back_facing},
                        {"border_texel", g.stats.border_texel},
                        {"occluded", g.stats.occluded},  {"outside_mask", g.stats.outside_mask},
                        {"unlit", g.stats.unlit},        {"shadowed", g.stats.shadowed},
                        {"saturated", g.stats.saturated}, {"invalid_pixel", g.stats.invalid}};
  summary["warnings"] = g.stats.warnings;
  summary["interreflection"] = {{"bounces", interreflection.bounces},
                                {"removed_share", interreflection.removed_share},
                                {"samples_over_5pc", interreflection.samples_over_5pc},
                                {"max_share", interreflection.max_share},
                                {"second_pass", interreflection_pass2}};
  summary["clusters"] = est.basis.size();
  summary["render_target"] = RenderTargetName(target);
  summary["candidate_models"] = eo.candidate_models;
  summary["merge"] = {{"merges", merge.merges}, {"tried", merge.lines}};
  summary["mirrors"] = {{"replaced", mirrors.replaced}, {"tried", mirrors.lines}};
  summary["fine_weights"] = {{"tried", fine_weights.tried}, {"kept", fine_weights.kept},
                             {"coarse_size", fine_weights.coarse_size}, {"fine_size", fine_weights.fine_size},
                             {"heldout_rmse_coarse", fine_weights.heldout_rmse_coarse},
                             {"heldout_rmse_fine", fine_weights.heldout_rmse_fine},
                             {"border_excess", fine_weights.border_excess},
                             {"border_excess_median", fine_weights.border_excess_median}};
  summary["weights"] = est.per_channel_weights ? "per_channel" : "scalar";
  summary["weight_radius"] = est.weight_radius;
  summary["weight_unit_sum"] = est.weight_unit_sum;
  summary["heldout_rmse"] = est.heldout_rmse;
  summary["texels_without_samples"] = est.texels_without_samples;
  summary["texels_filled_from_neighbours"] = est.texels_filled;
  if (job.time_budget_s > 0) {
    summary["time_budget_s"] = job.time_budget_s;
    summary["cut_by_time_budget"] = est.cut_by_deadline;
  }
  for (const auto& b : est.basis) summary["basis"].push_back(BasisToJson(b));
  for (const auto& h : est.history)
    summary["cluster_history"].push_back(
        {{"clusters", h.clusters}, {"train_rmse", h.train_rmse}, {"heldout_rmse", h.heldout_rmse}, {"accepted", h.accepted}});
  summary["states_revisited"] = est.states_revisited;
  summary["blend_splits"] = est.blend_splits;
  summary["holes_relabelled"] = est.holes_relabelled;
  summary["pruned_materials"] = nlohmann::json::array();
  for (const auto& p : est.pruned)
    summary["pruned_materials"].push_back({{"model", p.label}, {"texels", p.texels}, {"heldout_drop", p.drop}, {"z", p.z}});
  for (const auto& q : est.cluster_quality)
    summary["cluster_quality"].push_back({{"cluster", q.cluster}, {"texels", q.texels}, {"heldout_rmse", q.heldout_rmse},
                                          {"signal_rms", q.signal_rms}, {"poorly_explained", q.poorly_explained}});
  if (no.Enabled()) summary["normals"] = {{"mode", no.mode}, {"kept", nr.kept}, {"rounds", normals_rounds}};
  if (!photo_check.is_null()) summary["normals"]["photo_check"] = photo_check;
  for (const auto& m : est.model_choices)
    summary["model_selection"].push_back({{"cluster", m.cluster}, {"model", m.label}, {"heldout_rmse", m.heldout_rmse},
                                          {"params", m.num_params}, {"chosen", m.chosen}, {"finalist", m.finalist}});

  if (job.report) {
    timer.Start("report");
    const std::string dir = job.out_dir + "/report";
    fs::create_directories(dir);
    WriteImage(dir + "/cluster_map.png", LabelMap(material.material_id), PixelFormat::kUInt8, ColorSpace::kLinear);
    WriteImage(dir + "/confidence.png", ColorRamp(material.confidence, 0, 1), PixelFormat::kUInt8, ColorSpace::kLinear);
    float max_res = 1e-6f;
    for (float r : est.residual) max_res = std::max(max_res, r);
    WriteImage(dir + "/residual.png", ColorRamp(TexelMap(g.atlas, est.residual), 0, max_res), PixelFormat::kUInt8,
               ColorSpace::kLinear);
    for (size_t k = 0; k < material.weights.size(); ++k)
      WriteImage(Msg(dir, "/weights_m", k, ".png"), material.weights[k], PixelFormat::kUInt8, ColorSpace::kLinear);
    if (nr.kept) summary["normals"]["pictures"] = WriteNormalPictures(scene, g, nr, dir);
    // A held-out photo (from the capture's held-out views when it has them)
    // next to its relit twin; otherwise the first input photo.
    const std::string heldout = scene.ground_truth.is_object() ? scene.ground_truth.value("heldout_scene", "") : "";
    if (!heldout.empty() && fs::exists(scene.Resolve(heldout))) {
      const Scene hs = LoadScene(scene.Resolve(heldout));
      summary["twin"] = WriteTwin(material, hs, 0, dir, "heldout");
      summary["twin"]["kind"] = "held-out view";
    } else {
      summary["twin"] = WriteTwin(material, scene, 0, dir, "input");
      summary["twin"]["kind"] = "input view (the capture has no held-out views)";
    }
  }
  timer.Stop();
  AddStageTimes(timer, &summary);
  summary["total_s"] = timer.Total();
  summary["peak_memory_mb"] = PeakMemoryMB();
  if (job.report) WriteFileAtomic(job.out_dir + "/report/summary.json", summary.dump(2));
  if (job.report) WriteReportHtml(summary, job.out_dir + "/report");
  std::fprintf(stderr, "%s", timer.Report().c_str());
  return summary;
}

}  // namespace svbrdf
