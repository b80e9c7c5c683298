#include <cstdio>
#include <map>
#include <memory>
#include <sstream>

#include "apps/svbrdf/commands.h"
#include "core/error.h"
#include "core/progress.h"
#include "io/output_folder.h"
#include "pipeline/reconstruction.h"

namespace svbrdf::cli {

void RegisterReconstruct(CLI::App& app, Runner* run) {
  auto job = std::make_shared<ReconstructionJob>();
  auto candidates = std::make_shared<std::string>();
  CLI::App* c = app.add_subcommand(
      "reconstruct",
      "Recover a spatially varying BRDF from a capture (scene.json): per-texel samples, Lensch-style\n"
      "progressive clustering with Ceres fits, model and cluster count chosen on held-out samples,\n"
      "NNLS mixing weights, per-texel normals (Lensch et al. 2003). Writes a material folder\n"
      "(material.json, mesh, EXR maps, normal.exr) and OUT/report/.\n"
      "Example: svbrdf reconstruct capture/scene.json --out material --max-clusters 6");
  c->add_option("scene", job->scene_path, "capture scene.json")->required();
  c->add_option("--out", job->out_dir, "output material folder")->required();
  c->add_option("--texture-size", job->gather.texture_size, "atlas resolution (square) of meshes with texture coordinates; 0: automatic, a texel of about --texel-footprint pixel footprints");
  c->add_option("--model", job->estimate.force_model, "force one model for every basis material (e.g. lafortune-2)");
  c->add_option("--models", *candidates, "comma-separated candidate models for model selection");
  c->add_option("--max-clusters", job->estimate.max_clusters, "upper bound on basis materials");
  c->add_option("--clusters", job->estimate.force_clusters, "force exactly this many basis materials");
  c->add_option("--min-improvement", job->estimate.min_improvement, "relative held-out error drop needed to keep a split");
  c->add_option("--min-split-coherence", job->estimate.min_split_coherence,
                "a split's halves must form regions: 1 - (neighbour pairs split) / (that share for random labels),\n"
                "in [0, 1] (0 = no such test)");
  c->add_option("--mix-radius", job->estimate.mix_radius,
                "the split search's measure mixes into a texel the materials of clusters within this many texels\n"
                "(1-8)");
  c->add_option("--max-failed-splits", job->estimate.max_failed_splits,
                "the split search stops after this many splits in a row that did not improve on the best state");
  c->add_option("--split-poor-clusters", job->estimate.split_poor_clusters,
                "before it stops, the split search tries once every cluster of the best state not tried since it was\n"
                "kept whose held-out RMSE exceeds 10 % of its signal RMS (a poorly explained cluster; true/false)");
  c->add_option("--lookaheads-per-state", job->estimate.lookaheads_per_state,
                "a failed split is followed by one more split of its state (a look-ahead) this many times per best\n"
                "state; later failures backtrack at once (0 = never look ahead)");
  c->add_option("--core-fit-rings", job->estimate.core_fit_rings,
                "final materials are fitted on their clusters' texels whose neighbours this many rings out share\n"
                "their cluster (blend zones at region borders left to the mixing weights; a cluster whose core\n"
                "fit is at a model bound is fitted on all its texels; 0 = every texel; max 8)");
  c->add_option("--robust", job->estimate.robust_scale, "Cauchy loss scale of cluster fits (-1 = automatic, 0 = least squares)");
  c->add_option("--fit-compression", job->estimate.fit.compression,
                "split-search fits weigh a sample's residual by 1/sqrt(1 + Y/(c x median Y)), Y its brightness\n"
                "(0 = linear residuals; model selection and final fits are always linear)");
  c->add_option("--selection-error", job->selection_error,
                "units of model selection's held-out errors: display (the photos' pixel values, clamped and\n"
                "sRGB-encoded, as evaluate scores) or linear (radiance per unit light)");
  c->add_option("--max-fit-samples", job->estimate.fit.max_samples, "samples per cluster fit");
  c->add_option("--threads", job->estimate.threads, "worker threads (0 = all cores)");
  c->add_option("--time-budget", job->time_budget_s,
                "anytime: best material within this many seconds (0 = no limit; gathering and one fit always run)");
  c->add_option("--texel-footprint", job->gather.texel_footprint,
                "meshes without UVs: chart-atlas texel size in pixel footprints at the median view");
  c->add_option("--max-atlas-size", job->gather.max_atlas_size, "meshes without UVs: chart-atlas side cap (texels)");
  c->add_option("--border-texel-max-offset", job->gather.border_texel_max_offset,
                "meshes without UVs: texels outside every chart triangle take samples only when the point they measure\n"
                "lies within this many texels of their centre (default 0: none; their weights are filled in)");
  c->add_flag("--border-texel-samples", job->gather.border_texel_samples,
              "meshes without UVs: sample texels outside every chart triangle too (at their clamped point)");
  c->add_option("--footprint-rays", job->gather.footprint_rays,
                "sample frames from the mean normal of n x n rays per pixel of each lookup (0 = texel-centre normal;\n"
                "2 suits photos that integrate the pixel, e.g. real cameras, on scans whose normal turns within a pixel)");
  c->add_option("--max-footprint-turn", job->gather.max_footprint_turn_deg,
                "reject samples whose pixel footprint spans more than this turn of the mesh normal (degrees; 0 = off)");
  c->add_option("--max-lookup-contrast", job->gather.max_lookup_contrast,
                "reject samples whose photo changes steeply within the bilinear lookup: (max - min) / (max + min)\n"
                "of its four pixels above this (1 = off)");
  c->add_option("--contrast-min-turn", job->gather.contrast_min_turn_deg,
                "--max-lookup-contrast rejects only where the pixel footprint spans at least this turn of the mesh\n"
                "normal (degrees; 0 = everywhere)");
  c->add_option("--footprint-subsamples", job->gather.footprint_subsamples,
                "n x n rays per pixel of each sample's lookup, their normals reduced to four weighted ones;\n"
                "predictions average the BRDF over them as the photo does (0 = off: the texel-centre normal)");
  c->add_option("--footprint-min-tilt", job->gather.footprint_min_tilt_deg,
                "--footprint-subsamples are kept when the median pixel normal's tilt is at least this (degrees)");
  c->add_option("--probe-rays", job->gather.probe_rays,
                "footprint probe: n x n rays per pixel of each lookup measure its foreign and unlit shares (0 = off; "
                "--fit-max-unlit-share and --fit-max-foreign-share use them)");
  c->add_option("--max-unlit-share", job->gather.max_unlit_share,
                "with --probe-rays: reject samples whose footprint is unlit beyond this share (1 = off)");
  c->add_option("--max-probe-foreign-share", job->gather.max_probe_foreign_share,
                "with --probe-rays: reject samples whose footprint sees another surface beyond this share (1 = off)");
  c->add_option("--fit-max-unlit-share", job->fit_max_unlit_share,
                "with --probe-rays: samples whose footprint is unlit beyond this share inform the split search only, "
                "not the fits and weights (1 = off)");
  c->add_option("--fit-max-foreign-share", job->fit_max_foreign_share,
                "with --probe-rays: samples whose footprint sees another surface beyond this share inform the split "
                "search only (1 = off)");
  c->add_option("--interreflection-bounces", job->interreflection.bounces,
                "indirect light removed from the samples before the fits: path-traced bounces over the mesh with a\n"
                "Lambertian estimate of the material (0 = off); the material records them and relight adds them back");
  c->add_option("--interreflection-paths", job->interreflection.paths, "--interreflection-bounces: paths per sample");
  c->add_flag("!--no-interreflection-refit", job->interreflection.refit,
              "skip the second pass: the indirect light traced again with the split search's materials as\n"
              "receivers (a glossy texel reflects what lies about its mirror direction) before the final fits");
  c->add_option("--interreflection-refit-paths", job->interreflection.refit_paths,
                "second pass: paths per sample");
  c->add_option("--seed", job->estimate.seed, "seed of hold-out split and subsampling");
  c->add_option("--normals", job->normals.mode,
                "per-texel normal refinement: on (kept only if the held-out error drops), off, force")
      ->check(CLI::IsMember({"on", "off", "force"}));
  c->add_option("--normal-prior", job->normals.prior_tilt, "prior std of tan(tilt) from the mesh normal (> 0)");
  c->add_option("--normal-smooth", job->normals.smooth_tilt,
                "prior std of tan(tilt) between adjacent texels' normals after the first pass (0 = pool the\n"
                "neighbours' samples in every pass)");
  c->add_option("--normal-passes", job->normals.iterations, "normal + weights passes of the refinement (>= 1)");
  c->add_flag("--recluster", job->normals.recluster,
              "when refined normals are kept: cluster again on the reoriented samples (about doubles the time)");
  c->add_option("--material-rounds", job->normals.material_rounds,
                "when refined normals are kept: refit the basis materials with them and refine again, up to this many times");
  c->add_option("--polish-basis", job->normals.polish_basis,
                "in each material round: fit the basis materials jointly with their interior texels' tilts (default 1)");
  c->add_option("--normal-bootstrap-rounds", job->alternation.bootstrap_rounds,
                "when refined normals lower some material's held-out error but are not kept: normals <-> materials\n"
                "rounds from normals on every texel, kept if the held-out error drops (0 = off)");
  c->add_option("--normal-map-space", job->normal_map_space,
                "space of the written normal map: tangent (the mesh's turn within a texel is kept) or world (the\n"
                "texel centre's normal holds across the texel; the format before material.json's normal_map_space)")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, NormalMapSpace>{{"tangent", NormalMapSpace::kTangent}, {"world", NormalMapSpace::kWorld}}));
  c->add_flag("--basis-refit,!--no-basis-refit", job->estimate.refit_basis_on_weights,
              "refit the basis materials given the mixing weights (kept where the held-out error of their interior "
              "texels falls)");
  c->add_flag("--prune,!--no-prune", job->estimate.prune_materials,
              "after the weight model is chosen: remove a basis material that the others, mixed by the weights, explain\n"
              "about as well (less than --prune-min-drop lower held-out error with it; on by default, --no-prune: off)");
  c->add_option("--prune-min-drop", job->estimate.prune_min_drop,
                "pruning: relative drop of the held-out error a material must bring to stay (default 0.1)");
  c->add_flag("--merge,!--no-merge", job->merge.enabled,
              "when refined normals are kept: merge basis materials that one material explains as well in the refined\n"
              "frames, before the material rounds (undoes splits the bumps caused; on by default, --no-merge: off)");
  c->add_flag("--mirrors,!--no-mirrors", job->mirror.enabled,
              "where interreflection was traced: try dark basis materials as mirrors (smooth conductors), fitted to\n"
              "what their mirror direction sees, kept by held-out error (on by default, --no-mirrors: off)");
  c->add_option("--mirror-lookup-rays", job->mirror.lookup_rays,
                "mirror stage: n x n rays through each pixel of a sample's photo lookup, each traced in its own mirror\n"
                "direction (the reflection integrated over the pixels); 0 (default): one direction per pixel, about\n"
                "its mean normal");
  c->add_flag("--fine-weights,!--no-fine-weights", job->fine_weights,
              "solve the mixing weights again near the region borders on a finer atlas (a texel of --fine-texel-footprint,\n"
              "at most twice the side) when the borders hold at least twice the held-out error per texel of the regions'\n"
              "insides, the basis fixed; kept by held-out error (on by default, --no-fine-weights: the maps stay at the\n"
              "search's atlas)");
  c->add_option("--fine-texel-footprint", job->fine.texel_footprint,
                "fine weights: texel size of the finer atlas in pixel footprints at the median view");
  c->add_option("--fine-band-rings", job->fine.band_rings,
                "fine weights: coarse texels this many rings or fewer from a region border are gathered again");
  c->add_option("--ps-normal-rounds", job->photometric_normal_rounds,
                "photometric captures with unknown normals: rounds of basis selection <-> per-pixel normal search\n"
                "(where the Lambertian start misfits, --ps-search-misfit; 0 = the Lambertian start alone)");
  c->add_option("--ps-shadow-rounds", job->photometric_shadow_rounds,
                "photometric captures with unknown normals: rounds of Lambertian normals fitted again without the photos\n"
                "their height field casts shadows in (0 = the interquartile start alone)");
  c->add_option("--ps-lobe-normals", job->photometric_lobe_normals,
                "photometric captures with unknown normals: where the Lambertian start fits its photos, search the\n"
                "normals under a diffuse (Lambert or under a smooth interface) + one specular lobe shared by the object\n"
                "(default 1)");
  c->add_option("--ps-max-basis", job->photometric.max_basis, "photometric captures: most basis BRDFs (Lambert included)");
  c->add_option("--ps-min-gain", job->photometric.min_gain,
                "photometric captures: relative cross-validated error drop an added basis BRDF must bring");
  c->add_option("--ps-prior-rows", job->photometric.prior_rows,
                "photometric captures: pull of each pixel's weights towards the object's median, in photos' worth");
  c->add_option("--ps-srgb-weight", job->photometric.srgb_weight_exponent,
                "photometric captures: exponent of the sRGB slope in the fit weights (0 = linear, 1 = PSNR's units)");
  c->add_option("--ps-min-cos", job->photometric.min_cos,
                "photometric captures: photos lighting a pixel at a cosine below this are left out of its fit");
  c->add_option("--ps-search-misfit", job->photometric.search_misfit,
                "photometric captures with unknown normals: search the normals under the fitted basis where the\n"
                "Lambertian start misfits its inlier photos by more than this relative RMS (0 = everywhere)");
  c->add_option("--ps-residual-window", job->photometric.residual_window,
                "photometric captures: what the model leaves in the photos is interpolated between the nearest lights,\n"
                "scaled per pixel by the share that carries to a left-out light, pooled over (2 r + 1)^2 pixels\n"
                "(kept when the leave-one-light-out error drops; -1 = off)");
  c->add_option("--for", job->render_target,
                "fit only models the export target renders exactly: mitsuba (lambert, Smith Cook-Torrance, conductors)\n"
                "or gltf (the glTF metallic-roughness BRDF); any = every candidate (default)")
      ->check(CLI::IsMember({"any", "mitsuba", "gltf"}));
  c->add_flag("!--no-report", job->report, "skip pictures and summary");
  c->callback([job, candidates, run] {
    *run = [job, candidates] {
      if (!candidates->empty()) {
        job->estimate.candidate_models.clear();
        std::stringstream ss(*candidates);
        for (std::string m; std::getline(ss, m, ',');) job->estimate.candidate_models.push_back(m);
      }
      job->gather.threads = job->estimate.threads;
      job->estimate.fit.threads = job->estimate.threads;
      job->estimate.fit.seed = job->estimate.seed;
      // The whole folder (material and report) appears only when complete.
      OutputFolder out(job->out_dir);
      ReconstructionJob in_tmp = *job;
      in_tmp.time_spent_before_s = ProcessAgeSeconds();  // the budget counts the program's start-up
      in_tmp.out_dir = out.path();
      const auto summary = RunReconstruction(in_tmp);
      out.Commit();
      std::printf("material: %s/material.json (%d basis materials)\n", job->out_dir.c_str(), int(summary["clusters"]));
      if (job->report) std::printf("report:   %s/report/ (summary.json, cluster_map.png, *_relit.png)\n", job->out_dir.c_str());
      return 0;
    };
  });
}

}  // namespace svbrdf::cli
