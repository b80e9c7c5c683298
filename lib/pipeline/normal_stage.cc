#include "pipeline/normal_stage.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <utility>

#include "cluster/holdout.h"
#include "core/error.h"
#include "io/material.h"
#include "normals/basis_polish.h"
#include "normals/normal_map.h"
#include "raytrace/raytracer.h"
#include "relight/relight.h"
#include "relight/shader.h"

namespace svbrdf {

void NormalAlternationOptions::Check() const {
  if (bootstrap_rounds < 0) throw Error(Msg("normal refinement: bootstrap rounds = ", bootstrap_rounds, ": must be >= 0"));
  if (!(min_material_gain >= 0 && min_material_gain < 1))
    throw Error(Msg("normal refinement: bootstrap min material gain = ", min_material_gain, ": must be in [0, 1)"));
}

MaterialRoundDecision DecideMaterialRound(bool normals_kept, double round_rmse, double incumbent_rmse,
                                          double min_improvement) {
  MaterialRoundDecision d;
  d.keep = normals_kept && round_rmse <= incumbent_rmse;
  d.again = d.keep && round_rmse < (1.0 - min_improvement) * incumbent_rmse;
  return d;
}

bool SomeMaterialImproved(const NormalRefinement& nr, double min_gain) {
  for (size_t k = 0; k < nr.heldout_rmse_mesh_by_material.size() && k < nr.heldout_rmse_refined_by_material.size(); ++k) {
    const double mesh = nr.heldout_rmse_mesh_by_material[k], refined = nr.heldout_rmse_refined_by_material[k];
    if (mesh > 0 && refined * refined < (1.0 - min_gain) * mesh * mesh) return true;
  }
  return false;
}

namespace {

// The held-out photos a photo check scores against, read once for its renders.
struct CheckPhoto {
  size_t index;  // into scene.images
  Image photo, mask;
};

// Squared error of `material` relit against `photos`, over their masks.
double PhotoError(const Material& material, const Scene& scene, const std::vector<CheckPhoto>& photos, int threads) {
  RayTracer tracer(material.mesh);
  MaterialShader shader(material);
  RelightOptions ro;
  ro.progress = false;
  ro.threads = threads;
  double sse = 0;
  for (const CheckPhoto& p : photos) {
    const ImageEntry& e = scene.images[p.index];
    const Image& photo = p.photo;
    const Image& mask = p.mask;
    const RenderedView v = RenderView(tracer, shader, scene, p.index, ro);
    const double inv = e.exposure > 0 ? 1.0 / e.exposure : 1.0;
    for (int y = 0; y < photo.height; ++y)
      for (int x = 0; x < photo.width; ++x) {
        if (mask.width && mask.at(x, y, 0) < 0.5f) continue;
        for (int c = 0; c < 3; ++c) {
          const double d = (double(photo.at(x, y, c)) - v.color.at(x, y, c)) * inv;
          if (std::isfinite(d)) sse += d * d;
        }
      }
  }
  return sse;
}

}  // namespace

PhotoCheck CheckNormalMapOnPhotos(const Scene& scene, const GatherResult& g, const ReconstructOptions& eo,
                                  const SvbrdfEstimate& before, const SvbrdfEstimate& after, const NormalRefinement& nr,
                                  NormalMapSpace map_space, int max_photos) {
  PhotoCheck out;
  out.measured = true;
  const std::vector<char> held = HeldOutImages(int(scene.images.size()), eo.holdout_fraction, eo.seed);
  std::vector<CheckPhoto> images;
  for (size_t i = 0; i < held.size() && int(images.size()) < max_photos; ++i) {
    if (!held[i]) continue;
    const ImageEntry& e = scene.images[i];
    images.push_back({i, ReadImage(scene.Resolve(e.file), scene.images_color_space),
                      e.mask.empty() ? Image() : ReadImage(scene.Resolve(e.mask))});
  }
  out.photos = int(images.size());
  if (images.empty()) return out;
  Material without = ToMaterial(before, g.atlas, g.mesh);
  Material with = ToMaterial(after, g.atlas, g.mesh);
  // The map as reconstruct writes it: in a world-space map the texel
  // centre's normal holds across the texel, a tangent-space one turns with
  // the mesh (normal_map_space.h), and the photos see the difference.
  with.normal_map = NormalMapImage(g.atlas, nr.normal, map_space);
  with.normal_map_space = map_space;
  out.error_without_map = PhotoError(without, scene, images, eo.threads);
  out.error_with_map = PhotoError(with, scene, images, eo.threads);
  with.normal_map = Image();
  out.error_refined_no_map = PhotoError(with, scene, images, eo.threads);
  return out;
}

PhotoChoice ChooseOnPhotos(const PhotoCheck& pc, double min_improvement) {
  if (pc.photos == 0) return PhotoChoice::kRefinedWithMap;
  const bool map = pc.error_with_map <= pc.error_refined_no_map;
  const double best = map ? pc.error_with_map : pc.error_refined_no_map;
  if (!(best < (1.0 - min_improvement) * pc.error_without_map)) return PhotoChoice::kMeshNormals;
  return map ? PhotoChoice::kRefinedWithMap : PhotoChoice::kRefinedWithoutMap;
}

bool PhotoCheckPasses(const PhotoCheck& pc, double min_improvement) {
  return ChooseOnPhotos(pc, min_improvement) != PhotoChoice::kMeshNormals;
}

namespace {

// The normal decision's time as a share of the clustering's (see its use).
constexpr double kNormalDecisionShare = 0.35;

nlohmann::json NormalsJson(const NormalRefinement& nr, const SvbrdfEstimate& est) {
  nlohmann::json basis = nlohmann::json::array();
  for (const auto& b : est.basis) basis.push_back(BasisToJson(b));
  return {{"kept", nr.kept},
          {"basis", basis},
          {"clusters", est.basis.size()},
          {"heldout_rmse_mesh", nr.heldout_rmse_mesh},
          {"heldout_rmse_refined", nr.heldout_rmse_refined},
          {"decision_texels", nr.decision_texels},
          {"texels_refined", nr.texels_refined},
          {"noise_sigma", nr.noise_sigma},
          {"mean_tilt_deg", nr.mean_tilt_deg},
          {"median_tilt_deg", nr.median_tilt_deg},
          {"material_kept", std::vector<int>(nr.material_kept.begin(), nr.material_kept.end())},
          {"heldout_rmse_mesh_by_material", nr.heldout_rmse_mesh_by_material},
          {"heldout_rmse_refined_by_material", nr.heldout_rmse_refined_by_material}};
}

}  // namespace

void FollowMerge(int into, int from, const SvbrdfEstimate& merged, NormalRefinement* nr) {
  auto drop = [&](auto& v) {
    if (from < int(v.size())) v.erase(v.begin() + from);
  };
  if (into < int(nr->material_kept.size()) && from < int(nr->material_kept.size()))
    nr->material_kept[into] = nr->material_kept[into] || nr->material_kept[from];
  drop(nr->material_kept);
  drop(nr->heldout_rmse_mesh_by_material);
  drop(nr->heldout_rmse_refined_by_material);
  nr->weights = merged.weights;
}

bool RefinedMaterialIsAMirror(const SvbrdfEstimate& est, const NormalRefinement& nr) {
  if (!nr.kept) return false;
  for (size_t k = 0; k < est.basis.size() && k < nr.material_kept.size(); ++k)
    if (nr.material_kept[k] && est.basis[k].spec.family == Family::kMirror) return true;
  return false;
}

NormalRefinement RunNormalStage(const GatherResult& g, const ReconstructOptions& eo, const NormalOptions& no,
                                const NormalAlternationOptions& ao, double cluster_seconds, StageTimer* timer,
                                SvbrdfEstimate* est_io, nlohmann::json* rounds, const Scene* scene,
                                NormalMapSpace map_space, const MergeOptions& merge, MergeReport* merged,
                                PhotoCheck* output_check) {
  ao.Check();
  PhotoCheck check_of_output;  // the photo check below, while it still describes the output
  SvbrdfEstimate& est = *est_io;
  NormalRefinement nr;
  if (!no.Enabled()) return nr;
  // Anytime: the normal decision costs a fraction of the clustering's time;
  // not started without 0.35x left (above that fraction on the presets),
  // since a decision stopped midway keeps the mesh normals.
  if (eo.SecondsLeft() <= kNormalDecisionShare * cluster_seconds) {
    est.cut_by_deadline.push_back("normal refinement");
    return nr;
  }
  timer->Start("refine normals");
  nr = RefineNormals(g.samples, g.atlas, est, no);
  std::fprintf(stderr, "  %s\n", nr.Report().c_str());
  if (nr.cut_by_deadline) est.cut_by_deadline.push_back("normal refinement (not kept: no time to finish it)");
  rounds->push_back(NormalsJson(nr, est));
  const bool recluster_fits = eo.SecondsLeft() > cluster_seconds;
  if (nr.kept && no.recluster && !recluster_fits) est.cut_by_deadline.push_back("second clustering");
  bool reclustered = false;  // the second clustering's estimate replaced the first
  if (nr.kept && no.recluster && recluster_fits) {
    // Bumps that the mesh lacks shade the texels of one material
    // differently, which the clustering reads as different materials (or as
    // noise that hides real ones); with the normals known, a second
    // clustering on the reoriented samples sees the materials themselves.
    timer->Start("cluster again (refined normals)");
    SvbrdfEstimate est2 = EstimateSvbrdf(ReorientSamples(g.samples, nr.tilt), g.atlas, eo);
    timer->Start("refine normals again");
    NormalRefinement nr2 = RefineNormals(g.samples, g.atlas, est2, no, &nr.tilt);
    std::fprintf(stderr, "  again: %s\n", nr2.Report().c_str());
    rounds->push_back(NormalsJson(nr2, est2));
    // Held-out errors of both rounds are on the same photos and texels.
    const bool better = no.mode == "force" || (nr2.kept && nr2.heldout_rmse_refined < nr.heldout_rmse_refined);
    rounds->back()["chosen"] = better;
    if (better) est = std::move(est2), nr = std::move(nr2), reclustered = true;
  }
  if (scene && nr.kept && no.mode == "on") {
    timer->Start("normal map photo check");
    SvbrdfEstimate with = est;
    with.weights = nr.weights;
    const PhotoCheck pc = CheckNormalMapOnPhotos(*scene, g, eo, est, with, nr, map_space);
    const bool pass = PhotoCheckPasses(pc, no.min_improvement);
    std::fprintf(stderr, "  normal map on %d held-out photos: squared error %g without, %g with (%g refined without "
                 "the map): %s\n", pc.photos, pc.error_without_map, pc.error_with_map, pc.error_refined_no_map,
                 !pass ? "not kept (mesh normals)"
                 : pc.error_with_map <= pc.error_refined_no_map ? "kept"
                                                                : "kept for now (the refined materials and weights pay)");
    rounds->back()["photo_check"] = {{"photos", pc.photos}, {"error_without_map", pc.error_without_map},
                                     {"error_with_map", pc.error_with_map},
                                     {"error_refined_no_map", pc.error_refined_no_map}, {"kept", pass}};
    if (!pass) return NormalRefinement();
    if (!reclustered) check_of_output = pc;
  }
  // Normals <-> materials: materials fitted under the mesh normals are
  // biased where the surface is bumped (a metal's shifted highlights read
  // as a broader, dimmer lobe), and normals fitted with biased materials
  // fall short of the true tilts; refitting the materials on the samples
  // in the refined frames, then the normals from the refined ones, lets
  // both converge. A round is kept only when the held-out error (same
  // photos, same texels) drops: below the chosen normals' error, which
  // before any kept round is the mesh normals' (NormalRefinement).
  int material_rounds = no.material_rounds;
  const bool bootstrap = !nr.kept && no.mode == "on" && ao.bootstrap_rounds > 0 && !nr.cut_by_deadline &&
                         SomeMaterialImproved(nr, ao.min_material_gain);
  std::vector<Vec2> start;  // tilts the next round's materials are refitted in
  if (bootstrap) {
    if (eo.SecondsLeft() <= cluster_seconds) {
      est.cut_by_deadline.push_back("normals <-> materials bootstrap");
    } else {
      // Normals on every texel, whatever the decision said: the start of the
      // alternation, decided on at its end. Fitted on all photos, as the
      // material rounds' starts are (the decision's arms refit from them on
      // the training photos only).
      timer->Start("refine normals (bootstrap, every texel)");
      NormalOptions all = no;
      all.mode = "force";
      start = RefineNormals(g.samples, g.atlas, est, all).tilt;
      material_rounds = std::max(material_rounds, ao.bootstrap_rounds);
      std::fprintf(stderr, "  normals <-> materials: bootstrap from normals on every texel (%d rounds at most)\n",
                   material_rounds);
    }
  }
  if (nr.kept) start = nr.tilt;
  std::optional<SvbrdfEstimate> first_refit;  // the first round's refit, made by the merge test
  if (nr.kept && merge.enabled) {
    MergeReport m = MergeSameMaterials(g, eo, nr, merge, cluster_seconds, timer, &est, &nr);
    if (m.merges > 0) check_of_output = PhotoCheck();
    first_refit = std::exchange(m.refit_apart, std::nullopt);
    if (merged) *merged = std::move(m);
  }
  for (int round = 0; round < material_rounds && !start.empty(); ++round) {
    if (eo.SecondsLeft() <= cluster_seconds / 2) {
      est.cut_by_deadline.push_back("material refit");
      break;
    }
    timer->Start("refit materials (refined normals)");
    // With no merge, the merge test's refit apart is this round's refit
    // (start is the kept refinement's tilts, the materials unchanged).
    const bool reuse = round == 0 && first_refit.has_value();
    if (reuse) std::fprintf(stderr, "  material round 1: the merge test's refit of the materials apart reused\n");
    SvbrdfEstimate est2 =
        reuse ? std::move(*first_refit) : RefitSvbrdf(ReorientSamples(g.samples, start), g.atlas, eo, est);
    first_refit.reset();
    if (no.polish_basis && nr.kept) {
      timer->Start("polish basis with the tilts");
      for (const BasisPolishReport& r :
           PolishBasisWithTilts(g.samples, g.atlas, no, start, nr.material_kept, nr.noise_sigma, eo.fit.max_samples, &est2))
        std::fprintf(stderr, "  %s\n", Report(r, est2).c_str());
    }
    timer->Start("refine normals again");
    NormalRefinement nr2 = RefineNormals(g.samples, g.atlas, est2, no, &start);
    std::fprintf(stderr, "  material round %d: %s\n", round + 1, nr2.Report().c_str());
    rounds->push_back(NormalsJson(nr2, est2));
    rounds->back()["material_round"] = round + 1;
    // A round that is not worse is kept: its materials were fitted in the
    // frames of the normals that go with them (the previous ones in the
    // mesh's or an older round's frames). Another round runs only after a
    // clear gain (`min_improvement`): on the mixed preset a round slightly
    // below the incumbent, whose materials' errors did drop, would otherwise
    // be dropped for missing the bar.
    const double incumbent = nr.kept ? nr.heldout_rmse_refined : nr.heldout_rmse_mesh;
    const MaterialRoundDecision d = DecideMaterialRound(nr2.kept, nr2.heldout_rmse_refined, incumbent, no.min_improvement);
    rounds->back()["chosen"] = d.keep;
    if (!d.keep) break;
    est = std::move(est2), nr = std::move(nr2);
    check_of_output = PhotoCheck();
    start = nr.tilt;
    if (!d.again) break;
  }
  if (nr.kept) est.weights = nr.weights;
  if (output_check) *output_check = check_of_output;
  return nr;
}

}  // namespace svbrdf
