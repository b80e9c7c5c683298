// The fine-weights stage of `reconstruct` (after the mirrors, before the
// material is written): for a mesh with its own texture coordinates, the
// mixing weights are solved again on a finer atlas, with the basis
// materials, the weight model and the region labels of the estimate fixed.
//
// Why: the basis materials and their number come from a search whose path
// depends on the texel count (a finer atlas of the same surface sends it
// elsewhere: docs/measurements.md, "UV atlases"), while the material borders
// are drawn by the weights alone, at the atlas's resolution (a UV sphere at
// 320x240 and the default 128^2 blurs its borders over ~4 pixels). Here the
// search keeps its atlas and only the weights get the automatic one
// (GatherOptions::texture_size 0: a texel of `texel_footprint` pixel
// footprints, at most twice the coarse side), kept when its held-out error
// (weights fitted on the training
// photos) is lower than the coarse atlas's under the same basis and weight
// model.
#pragma once
#include <string>

#include "cluster/reconstruct.h"
#include "gather/gather.h"
#include "io/scene.h"

namespace svbrdf {

struct FineWeightsReport {
  bool tried = false, kept = false;
  int coarse_size = 0, fine_size = 0;
  double heldout_rmse_coarse = 0, heldout_rmse_fine = 0;
  // Held-out error per texel at the coarse atlas's region borders over that
  // inside the regions (the stage is tried above kMinBorderExcess).
  double border_excess = 0;
  std::string line;  // for the log
};

// Replaces *g (samples, atlas) and est->weights / label / confidence /
// residual by the fine atlas's when that is kept. Skipped (report.tried
// false) for meshes without texture coordinates (their chart atlas is
// already sized so), with a normal map (refined on the coarse atlas) or
// indirect light removed (its samples were traced on the coarse atlas),
// and when the automatic size is not finer than the coarse one.
FineWeightsReport RefineWeightsOnFinerAtlas(const Scene& scene, const GatherOptions& gather,
                                            const ReconstructOptions& o, bool normal_map, bool indirect_removed,
                                            GatherResult* g, SvbrdfEstimate* est);

}  // namespace svbrdf
