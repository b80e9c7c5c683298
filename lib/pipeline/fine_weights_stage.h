// The fine-weights stage of `reconstruct` (after the mirrors, before the
// material is written): the mixing weights are solved again on a finer
// atlas near the material borders, with the basis materials, the weight
// model and the region labels of the estimate fixed.
//
// Why: the basis materials and their number come from a search whose path
// depends on the texel count (a finer atlas of the same surface sends it
// elsewhere: docs/measurements.md, "UV atlases"), while the material borders
// are drawn by the weights alone, at the atlas's resolution (a texel of two
// pixel footprints blurs a sharp or noisy border over two pixels and more).
// Here the search keeps its atlas, and only the texels within a few rings
// of a region border are gathered again on a finer one (a texel of
// `texel_footprint` pixel footprints, at most twice the coarse side: for
// meshes with texture coordinates the automatic UV atlas, for those without
// a chart atlas of that texel); the rest of the fine atlas reads the coarse
// weights as a map lookup would. Kept when the band's held-out error
// (weights fitted on the training photos) is lower than the coarse
// weights' on the same samples.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "cluster/reconstruct.h"
#include "gather/gather.h"
#include "io/scene.h"

namespace svbrdf {

struct FineWeightsOptions {
  // Fine texel size in pixel footprints at the median view (the coarse
  // atlas's is GatherOptions::texel_footprint).                       > 0
  double texel_footprint = 1.0;
  // Coarse texels this many rings or fewer from a region border are gathered
  // again on the fine atlas.                                         >= 1
  int band_rings = 4;
  void Check() const;
};

struct FineWeightsReport {
  bool tried = false, kept = false;
  int coarse_size = 0, fine_size = 0;
  // Held-out RMSE on the band's held-out samples: fine weights, and the
  // coarse ones read at the fine texels (both fitted on the training photos).
  double heldout_rmse_coarse = 0, heldout_rmse_fine = 0;
  // Held-out error per texel at the coarse atlas's region borders over that
  // inside the regions (the stage is tried above kMinBorderExcess).
  double border_excess = 0;
  double border_excess_median = 0;  // the same, medians of the per-texel errors
  int64_t dropped = 0;  // band samples dropped: their coarse texel has no sample in that photo
  std::string line;  // for the log
};

// What the fine gather's samples take from the stages before it.
struct FineWeightsInputs {
  bool normal_map = false;  // refined normals were kept (on the coarse atlas): the stage is skipped
  // Indirect light was removed but not recorded per sample (no second
  // pass's raw values, or the mirror stage replaced materials): skipped.
  bool indirect_unknown = false;
  // Per sample of the coarse gather (g's order) and channel, its value
  // before indirect light was removed (indirect/interreflection.h; g's
  // values are after); null: none removed. A band sample loses the indirect
  // light of its coarse texel's sample in the same photo (indirect light
  // changes little across a texel).
  const std::array<std::vector<float>, 3>* raw_y = nullptr;
};

// Replaces *g (atlas, mesh and samples; its stats stay the coarse gather's)
// and est->weights / label / confidence / residual by the fine atlas's when
// that is kept. Skipped (report.tried false) as `in` says, and when the
// fine atlas is not finer than the coarse.
FineWeightsReport RefineWeightsOnFinerAtlas(const Scene& scene, const GatherOptions& gather,
                                            const FineWeightsOptions& fo, const ReconstructOptions& o,
                                            const FineWeightsInputs& in, GatherResult* g, SvbrdfEstimate* est);

}  // namespace svbrdf
