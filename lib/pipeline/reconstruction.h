// The `reconstruct` job end to end: read a capture, gather per-texel
// samples, estimate the SVBRDF (progressive clustering, model selection,
// NNLS weights), refine per-texel normals (lib/normals), write the material folder and a report with pictures and a
// summary JSON. Per-stage timings and peak memory are recorded.
#pragma once
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "cluster/reconstruct.h"
#include "gather/gather.h"
#include "pipeline/fine_weights_stage.h"
#include "indirect/interreflection.h"
#include "io/material.h"
#include "io/scene.h"
#include "normals/refine.h"
#include "photometric/dictionary_fit.h"
#include "pipeline/merge_stage.h"
#include "pipeline/mirror_stage.h"
#include "pipeline/normal_stage.h"

namespace svbrdf {

struct ReconstructionJob {
  std::string scene_path;
  std::string out_dir;
  GatherOptions gather;
  ReconstructOptions estimate;
  NormalOptions normals;  // hold-out split, seed and threads are taken from `estimate`
  NormalAlternationOptions alternation;  // normals <-> materials bootstrap (normal_stage.h)
  MergeOptions merge;                    // same-family materials merged in the refined frames (merge_stage.h)
  MirrorOptions mirror;                  // smooth conductors recognised by what they reflect (mirror_stage.h)
  // Space of the written normal map (io/normal_map_space.h); the photo check
  // renders the map in it. World is the format before "normal_map_space".
  NormalMapSpace normal_map_space = NormalMapSpace::kTangent;
  bool report = true;  // pictures and summary under out_dir/report
  // The mixing weights solved again near the material borders on a finer
  // atlas, with the basis fixed, and kept by held-out error
  // (fine_weights_stage.h); false: the maps stay at the search's atlas.
  bool fine_weights = true;
  FineWeightsOptions fine;
  // "mitsuba" or "gltf": only models that renderer reproduces exactly
  // (export/render_target.h), so that the export renders like the
  // reconstruction; "" or "any": every candidate.
  std::string render_target;
  // Anytime (seconds, 0 = none): the best material found within this wall
  // time from the start, always a complete folder. Gathering and one cluster
  // fit always run; then the clustering stops early, model selection and
  // normal refinement are skipped when they would not finish in time, and a
  // reserve (5 %, at least 0.3 s) is kept for writing.
  double time_budget_s = 0;
  // Seconds already spent when RunReconstruction starts that count against
  // the budget (the CLI passes the program's start-up: ProcessAgeSeconds).
  double time_spent_before_s = 0;
  // Samples whose pixel footprint (GatherOptions::probe_rays) is unlit
  // beyond `fit_max_unlit_share` or on another surface (an occluding edge,
  // the background) beyond `fit_max_foreign_share` inform the split search
  // but not the fits, weights and normal stages after it (EstimateSvbrdf's
  // fit_samples): no material explains a shadow's or another surface's
  // radiance (docs/method/reconstruction.md, "The pixel footprint"; results
  // on the Mitsuba captures: bench_results/independent.md). 1 = keep them
  // everywhere.
  double fit_max_unlit_share = 0.1;
  double fit_max_foreign_share = 0.01;
  // Photometric captures (one fixed orthographic view, directional lights;
  // lib/photometric): the per-pixel dictionary fit, and how many rounds of
  // basis selection <-> per-pixel normal search follow the robust Lambertian
  // normals when the normals are unknown (0: none). The search runs only
  // where the Lambertian start misfits its photos
  // (DictionaryFitOptions::search_misfit): on DiLiGenT's diffuse-glossy
  // objects it moves the normals away from the scans'.
  DictionaryFitOptions photometric;
  // Indirect light removed from the samples before the fits
  // (indirect/interreflection.h); seed and threads from `estimate`.
  InterreflectionOptions interreflection;
  int photometric_normal_rounds = 1;
  // Photometric captures with unknown normals: rounds of Lambertian normals
  // -> height field -> cast shadows -> Lambertian normals without the
  // shadowed photos, before the search (0: the interquartile start alone).
  int photometric_shadow_rounds = 1;
  // Photometric captures with unknown normals: where the Lambertian start
  // fits its photos, search the normals under Lambert + one lobe shape for
  // the object (RefineNormalsUnderOneLobe).
  bool photometric_lobe_normals = true;
  // Units of model selection's errors: "display" (each photo's pixel values,
  // clamped and sRGB-encoded, as held-out photos are scored; stats.h
  // DisplayScale) or "linear" (reflected radiance per unit light).
  std::string selection_error = "display";
  // Called on the gathered samples before the estimate (bench tools: e.g.
  // an oracle that drops samples by their disagreement with a known truth).
  std::function<void(GatherResult&)> after_gather;
};

// Returns the summary (also written to out_dir/report/summary.json).
nlohmann::json RunReconstruction(const ReconstructionJob& job);

// Report pictures of image entry `index` of `scene`: dir/<tag>_photo.png,
// _relit.png (relit with `material`) and _error.png; returns their PSNR.
nlohmann::json WriteTwin(const Material& material, const Scene& scene, size_t index, const std::string& dir,
                         const std::string& tag);

}  // namespace svbrdf
