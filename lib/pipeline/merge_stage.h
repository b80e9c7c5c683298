// The merge stage of `reconstruct` (after the normal refinement): basis
// materials that the clustering split under the mesh normals but that are
// one material in the refined normals' frames are merged again (whatever
// models they were given: the second copper cluster may get a lobe).
//
// Why: under a bump map the mesh normals misplace a glossy material's
// highlights texel by texel, and the split search (which runs before the
// normals exist) can take the shifted highlights for two materials (the
// mixed preset's copper can come out as two conductor clusters). Once the
// samples are re-expressed in the refined frames (ReorientSamples), the two
// halves are fitted by one
// material about as well, and a split that no longer pays is undone with
// the split search's own bar (ReconstructOptions::min_improvement).
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "cluster/reconstruct.h"
#include "core/progress.h"
#include "gather/gather.h"
#include "normals/refine.h"

namespace svbrdf {

struct MergeOptions {
  // Whether the stage runs (CLI --merge / --no-merge; on by default). It
  // runs only when refined normals were kept, on the first kept refinement
  // (RunNormalStage, before the material rounds): after the rounds it
  // would merge two distinct clusters of the small bumped test capture
  // (BumpMapped.SmallCaptureFindsTheThreeMaterials) and miss the mixed
  // preset's copper split, whose second cluster a round can turn into a
  // lobe. Captures without such a split are left unchanged.
  bool enabled = true;
  void Check() const {}
};

struct MergeReport {
  int merges = 0;
  std::vector<std::string> lines;  // one per tested pair: held-out RMSE apart and merged
  // When a pair was refitted but not merged: the estimate refitted apart,
  // which is the first material round's refit (the same samples in the same
  // refined frames, the same materials), so that round need not fit it again.
  std::optional<SvbrdfEstimate> refit_apart;
};

// One pair's test on the samples of its two clusters' texels, as the final
// weights scale them: each material and the union (with either material's
// model, the better one kept) fitted on the training photos' samples; per
// texel, a non-negative weight of its own cluster's material (apart) or of
// the union's (merged) solved on its training samples and scored on its
// held-out photos' samples (`held_image`: per image, 1 if held out).
struct MergeTest {
  bool tested = false;  // false: a cluster without training or held-out samples
  double apart_rmse = 0, merged_rmse = 0;
  std::string merged_model;
};
MergeTest TestMerge(const SampleSet& samples, const std::vector<int>& label, const std::vector<BasisMaterial>& basis,
                    int i, int j, const std::vector<char>& held_image, const FitOptions& fo);
// The same with the two materials apart already fitted (FitMaterialApart of
// i and of j on the same samples and labels).
MergeTest TestMerge(const SampleSet& samples, const std::vector<int>& label, const std::vector<BasisMaterial>& basis,
                    int i, int j, const std::vector<char>& held_image, const FitOptions& fo,
                    const BasisMaterial& apart_i, const BasisMaterial& apart_j);
// Material k of `basis` fitted again (from its parameters) on the training
// samples of the texels labelled k; nothing when there are none.
std::optional<BasisMaterial> FitMaterialApart(const SampleSet& samples, const std::vector<int>& label,
                                              const std::vector<BasisMaterial>& basis, int k,
                                              const std::vector<char>& held_image, const FitOptions& fo);

// Merges pairs of `est`'s basis materials while some pair passes: its
// materials apart are not better than merged by `eo.min_improvement`
// (MergePays) on the samples re-expressed in the refined frames of `nr`,
// first in TestMerge (every pair; the best-passing one, lowest merged /
// apart RMSE, goes on), then on the whole estimate refitted apart and merged
// (RefitSvbrdf: model choice, weights with their priors). `est` is replaced
// by the merged refit.
// `follow`: the refinement whose per-material entries and weights follow
// each merge (FollowMerge, normal_stage.h); may be null.
MergeReport MergeSameMaterials(const GatherResult& g, const ReconstructOptions& eo, const NormalRefinement& nr,
                               const MergeOptions& mo, double cluster_seconds, StageTimer* timer, SvbrdfEstimate* est,
                               NormalRefinement* follow = nullptr);

// The estimate with basis material `from` joined to `into` (labels moved,
// higher indices shifted down; weights dropped: the refit solves them).
SvbrdfEstimate WithMaterialsMerged(const SvbrdfEstimate& est, int into, int from);

// `label` with -1 on texels that have an 8-neighbour of another label (the
// texels TestMerge screens are the region-interior ones).
std::vector<int> InteriorLabels(const Atlas& atlas, const std::vector<int>& label);

// Whether a merge is kept: the materials apart are not lower by `min_improvement`.
bool MergePays(double merged_rmse, double apart_rmse, double min_improvement);

}  // namespace svbrdf
