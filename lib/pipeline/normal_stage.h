// The normal-refinement stage of `reconstruct` (after the clustering):
// per-texel normals against the basis materials (lib/normals), optionally a
// second clustering on the reoriented samples, and the normals <-> materials
// alternation of Lensch et al. 2003 (materials refitted on the samples in the
// refined normals' frames, normals refined again from the refitted ones),
// every round kept only when the held-out error does not rise.
#pragma once
#include <nlohmann/json.hpp>

#include "cluster/reconstruct.h"
#include "core/progress.h"
#include "gather/gather.h"
#include "io/normal_map_space.h"
#include "io/scene.h"
#include "normals/refine.h"
#include "pipeline/merge_stage.h"

namespace svbrdf {

struct NormalAlternationOptions {
  // Bootstrap of the alternation when the first refinement is not kept but
  // lowers some basis material's held-out error (by min_material_gain
  // below). Materials fitted under the mesh normals of a bumped
  // surface are biased, a glossy one most (its shifted highlights read as a
  // broader, dimmer lobe, or a Cook-Torrance pinned at its bounds), and
  // normals refined against that lobe stay near the mesh normal, so its
  // texels' held-out error rises and, since they hold most of the error, the
  // whole refinement is rejected, although the other materials' errors drop
  // (the bump-mapped default capture's glossy blue;
  // bench_results/bump_default.md). Then: normals on every texel regardless
  // of the decision, materials refitted on the samples in their frames, normals
  // refined again and decided on the held-out photos against the mesh
  // normals with the clustering's materials; up to this many rounds while
  // the held-out error drops. 0 = off. Captures whose refinement lowers no
  // material's error (no bumps: the default and standard presets) never
  // start it. When it was written, 2 rounds paid on default_bump
  // (bench_results/bump_default.md). Off by default since the tilt fit
  // solves the mixing weights with the tilts (lib/normals/joint_cost.h):
  // there the first refinement is kept and the rounds follow it without a
  // bootstrap, and on the Mitsuba benchmarks it started only on spheres
  // whose mesh normals are exact (a sharp lobe's few texels gain with
  // tilts) and was never kept, at 6-10 s a scene (docs/measurements.md).
  // `--normal-bootstrap-rounds 2` starts it.
  int bootstrap_rounds = 0;
  // The bootstrap starts only when some material's held-out squared error
  // drops by this share with the first refinement's normals: under bumps
  // the drop is far above it; on captures without a bump map (the
  // scanned-bunny test, the five-material sphere) it stays far below, and
  // there a bootstrap round was always rejected and only cost CPU
  // (bench_results/bump_default.md).
  double min_material_gain = 0.25;
  void Check() const;
};

// Runs the stage on `est` (replaced by the refitted estimate when a round is
// kept; its weights by the refinement's when normals are kept). Appends one
// entry per refinement to `rounds` (summary.json "normals.rounds").
// With `scene`, a first refinement that is kept must pass the photo check
// (CheckNormalMapOnPhotos) before the material rounds start, else the stage
// ends with the mesh normals (saves the rounds' time where the map loses).
// With `merge` enabled, the merge stage (merge_stage.h) runs on the first
// kept refinement, before the material rounds (its report in `merged`), so
// that the rounds refit and refine the merged materials: run after the
// rounds instead, a round can turn one of two clusters of the same material
// (the mixed preset's copper) into a lobe that the merge screen no longer
// matches, and the split stays.
// `output_check`: the stage's photo check of its first refinement when
// that is still what the stage returns (no second clustering chosen, no
// merge, no material round kept), so the pipeline's final check need not
// render the same three materials again; otherwise left unmeasured.
struct PhotoCheck;
NormalRefinement RunNormalStage(const GatherResult& g, const ReconstructOptions& eo, const NormalOptions& no,
                                const NormalAlternationOptions& ao, double cluster_seconds, StageTimer* timer,
                                SvbrdfEstimate* est, nlohmann::json* rounds, const Scene* scene = nullptr,
                                NormalMapSpace map_space = NormalMapSpace::kTangent,
                                const MergeOptions& merge = MergeOptions(), MergeReport* merged = nullptr,
                                PhotoCheck* output_check = nullptr);

// After `from` was merged into `into` (WithMaterialsMerged): the refinement's
// per-material entries follow (into kept when either was), its weights are
// the merged estimate's.
void FollowMerge(int into, int from, const SvbrdfEstimate& merged, NormalRefinement* nr);

// A material the refinement kept refined normals for (nr.material_kept) is
// a mirror in `est` (after the mirror stage, pipeline/mirror_stage.h). The
// refinement is then void (reconstruction.cc): the mirror was fitted about
// the samples' own frames, the mesh's, while the tilts were fitted to the
// material it replaced and absorbed the reflections it now explains.
bool RefinedMaterialIsAMirror(const SvbrdfEstimate& est, const NormalRefinement& nr);

// The photo check of a kept refinement: the clustering's estimate `before`
// (mesh normals), the stage's `after` with its normal map (in `map_space`,
// as reconstruct writes it) and `after` without the map, each rendered as
// relight renders it, against up to `max_photos` of the held-out photos
// (HeldOutImages of `eo`); squared error over the photos' masks, linear
// radiance. Why: the sample-level decision scores samples at texel centres,
// and relight shades every point between them. A world-space map holds the
// texel centre's normal across the texel, so on a scan whose normal turns
// within a texel even a map of the mesh normals costs (the Mitsuba bunny
// with a world map of tilt 0; bench_results/bump_default.md). A
// tangent-space map keeps that turn, but the refined tilts still fit
// samples that average the photo over a turning footprint; on the bunny the
// refined materials and weights gain while their map loses, which only the
// third render shows.
struct PhotoCheck {
  double error_without_map = 0;  // `before`
  double error_with_map = 0;     // `after` with its map
  double error_refined_no_map = 0;  // `after` without the map
  int photos = 0;
  bool measured = false;  // set by CheckNormalMapOnPhotos
};
PhotoCheck CheckNormalMapOnPhotos(const Scene& scene, const GatherResult& g, const ReconstructOptions& eo,
                                  const SvbrdfEstimate& before, const SvbrdfEstimate& after, const NormalRefinement& nr,
                                  NormalMapSpace map_space = NormalMapSpace::kTangent, int max_photos = 4);
// The refinement is kept (its material rounds run) when the map, or the
// refined materials and weights without it, lower that error by
// `min_improvement` (relative), or there are no photos; ChooseOnPhotos
// decides among the three after the rounds. Requiring the map itself to
// pay would drop refined materials that pay where their map does not (a
// clean Mitsuba bunny; bench_results/independent.md).
bool PhotoCheckPasses(const PhotoCheck& pc, double min_improvement);
// The final choice among the three (reconstruct, after the material rounds):
// the lower of `after` with and without its map if it is `min_improvement`
// below `before`, else `before`; the map on ties. No photos: with the map.
enum class PhotoChoice { kMeshNormals, kRefinedWithoutMap, kRefinedWithMap };
PhotoChoice ChooseOnPhotos(const PhotoCheck& pc, double min_improvement);

// After a material round (materials refitted in the previous normals'
// frames, normals refined again) with held-out error `round_rmse` against
// the chosen state's `incumbent_rmse`: whether the round is kept (its
// normals were kept and the error is not higher: its materials go with its
// normals) and whether another round runs (a drop by `min_improvement`).
struct MaterialRoundDecision {
  bool keep = false;
  bool again = false;
};
MaterialRoundDecision DecideMaterialRound(bool normals_kept, double round_rmse, double incumbent_rmse,
                                          double min_improvement);

// Whether some basis material's decision error drops by `min_gain`
// (relative, on squared errors) with refined normals.
bool SomeMaterialImproved(const NormalRefinement& nr, double min_gain);

}  // namespace svbrdf
