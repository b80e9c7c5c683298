#include "pipeline/reconstruction.h"

#include <cstdio>
#include <filesystem>

#include "core/error.h"
#include "core/progress.h"
#include "evaluate/metrics.h"
#include "io/material.h"
#include "io/scene.h"
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

// A photo next to its relit twin and their difference, written as PNGs.
nlohmann::json WriteTwin(const Material& material, const Scene& scene, size_t index, const std::string& dir,
                         const std::string& tag) {
  const ImageEntry& e = scene.images[index];
  RayTracer tracer(material.mesh);
  MaterialShader shader(material);
  RelightOptions ro;
  ro.progress = false;
  RenderedView v = RenderView(tracer, shader, scene, index, ro);
  const Image photo = ReadImage(scene.Resolve(e.file), scene.images_color_space);
  Image mask;
  if (!e.mask.empty()) mask = ReadImage(scene.Resolve(e.mask));
  const ImageMetrics m = CompareImages(photo, v.color, e.mask.empty() ? nullptr : &mask, e.exposure);
  WriteImage(dir + "/" + tag + "_photo.png", photo, PixelFormat::kUInt8, ColorSpace::kSRGB);
  WriteImage(dir + "/" + tag + "_relit.png", v.color, PixelFormat::kUInt8, ColorSpace::kSRGB);
  WriteImage(dir + "/" + tag + "_error.png", ErrorMap(photo, v.color, 0.05 * e.exposure), PixelFormat::kUInt8,
             ColorSpace::kLinear);
  return {{"view", e.file}, {"psnr_srgb", m.psnr_srgb}, {"rel_rmse_linear", m.rel_rmse_linear}};
}

}  // namespace

nlohmann::json RunReconstruction(const ReconstructionJob& job) {
  StageTimer timer;
  timer.Start("load capture");
  const Scene scene = LoadScene(job.scene_path);
  if (scene.images.empty()) throw Error(Msg(job.scene_path, ": images: the capture has no photos"));

  timer.Start("gather samples");
  GatherResult g = Gather(scene, job.gather);
  std::fprintf(stderr, "  %s\n", g.stats.Report().c_str());

  timer.Start("fit + cluster");
  ReconstructOptions eo = job.estimate;
  const SvbrdfEstimate est = EstimateSvbrdf(g.samples, g.atlas, eo);

  timer.Start("write material");
  Material material = ToMaterial(est, g.atlas, g.mesh);
  material.extra = {{"source", "svbrdf reconstruct"}, {"scene", job.scene_path}};
  SaveMaterial(material, job.out_dir);
  material = LoadMaterial(job.out_dir);  // what relight will see

  nlohmann::json summary;
  summary["scene"] = job.scene_path;
  summary["texels"] = g.atlas.texels.size();
  summary["texture_size"] = g.atlas.width;
  summary["made_uvs"] = g.made_uvs;
  summary["samples"] = {{"kept", g.stats.kept},          {"candidates", g.stats.candidates},
                        {"outside_image", g.stats.outside_image}, {"back_facing", g.stats.back_facing},
                        {"occluded", g.stats.occluded},  {"outside_mask", g.stats.outside_mask},
                        {"unlit", g.stats.unlit},        {"shadowed", g.stats.shadowed},
                        {"saturated", g.stats.saturated}};
  summary["clusters"] = est.basis.size();
  summary["weights"] = est.per_channel_weights ? "per_channel" : "scalar";
  summary["heldout_rmse"] = est.heldout_rmse;
  for (const auto& b : est.basis) summary["basis"].push_back(BasisToJson(b));
  for (const auto& h : est.history)
    summary["cluster_history"].push_back(
        {{"clusters", h.clusters}, {"train_rmse", h.train_rmse}, {"heldout_rmse", h.heldout_rmse}, {"accepted", h.accepted}});
  for (const auto& m : est.model_choices)
    summary["model_selection"].push_back({{"cluster", m.cluster}, {"model", m.label}, {"heldout_rmse", m.heldout_rmse},
                                          {"params", m.num_params}, {"chosen", m.chosen}});

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
  for (const auto& st : timer.stages()) summary["timings_s"][st.name] = st.seconds;
  summary["total_s"] = timer.Total();
  summary["peak_memory_mb"] = PeakMemoryMB();
  if (job.report) WriteFileAtomic(job.out_dir + "/report/summary.json", summary.dump(2));
  if (job.report) WriteReportHtml(summary, job.out_dir + "/report");
  std::fprintf(stderr, "%s", timer.Report().c_str());
  return summary;
}

}  // namespace svbrdf
