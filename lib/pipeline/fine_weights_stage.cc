#include "pipeline/fine_weights_stage.h"

#include <algorithm>

#include "atlas/surface_neighbours.h"
#include "cluster/clustering.h"
#include "cluster/confidence.h"
#include "cluster/weights.h"
#include "core/error.h"

namespace svbrdf {
namespace {

// Finer weights are tried only where the coarse atlas's held-out error per
// texel at region borders is this many times that inside the regions: where
// the borders hold no more error than the interiors (a truth drawn at the
// searched resolution), a finer atlas only spreads the samples thinner and
// its weights score worse (docs/measurements.md, "Fine weights").
constexpr double kMinBorderExcess = 2.0;

// The estimate's weight model (ChooseWeightModel's choice, from its record).
WeightModel ChosenWeightModel(const ReconstructOptions& o, const SvbrdfEstimate& est) {
  for (WeightModel m : CandidateWeightModels(o))
    if (m.radius == est.weight_radius && m.unit_sum_samples == est.weight_unit_sum) {
      m.per_channel = est.per_channel_weights;
      return m;
    }
  throw Error(Msg("fine weights: the estimate's weight model (radius ", est.weight_radius, ", unit sum ",
                  est.weight_unit_sum, ") is not among the candidates"));
}

// A clustering of `g`'s samples with the estimate's basis and these labels.
Clustering Fixed(const GatherResult& g, const ReconstructOptions& o, const SvbrdfEstimate& est,
                 const std::vector<int>& label) {
  Clustering cl(g.samples, g.atlas, o);
  for (size_t k = 0; k < est.basis.size(); ++k) cl.SetBasis(int(k), est.basis[k]);
  for (size_t t = 0; t < label.size() && t < cl.assign().size(); ++t) cl.assign()[t] = std::max(0, label[t]);
  return cl;
}

}  // namespace

FineWeightsReport RefineWeightsOnFinerAtlas(const Scene& scene, const GatherOptions& gather,
                                            const ReconstructOptions& o, bool normal_map, bool indirect_removed,
                                            GatherResult* g, SvbrdfEstimate* est) {
  FineWeightsReport r;
  r.coarse_size = g->atlas.width;
  if (g->made_uvs || normal_map || indirect_removed || est->basis.empty() || gather.texture_size == 0 ||
      o.SecondsLeft() <= 0)
    return r;
  // The coarse atlas's held-out error per texel, at region borders (a
  // neighbour of another label) against inside the regions: only where the
  // borders carry the error can finer weights lower it.
  const WeightModel m = ChosenWeightModel(o, *est);
  const std::vector<int> coarse_label = LargestWeightLabels(est->weights, int(est->basis.size()));
  Clustering coarse_cl = Fixed(*g, o, *est, coarse_label);
  std::vector<double> per_texel;
  r.heldout_rmse_coarse = coarse_cl.HeldoutRmse(m, &per_texel);
  double border_sse = 0, inside_sse = 0;
  int64_t border_n = 0, inside_n = 0;
  for (size_t t = 0; t < per_texel.size() && t < coarse_cl.neighbours().size(); ++t) {
    if (!(per_texel[t] > 0) || coarse_label[t] < 0) continue;
    bool border = false;
    for (int u : coarse_cl.neighbours()[t])
      border = border || (coarse_label[size_t(u)] >= 0 && coarse_label[size_t(u)] != coarse_label[t]);
    (border ? border_sse : inside_sse) += per_texel[t];
    ++(border ? border_n : inside_n);
  }
  r.border_excess = border_n && inside_n && inside_sse > 0 ? (border_sse / border_n) / (inside_sse / inside_n) : 0.0;
  if (r.border_excess < kMinBorderExcess) {
    r.line = Msg("fine weights: not tried (held-out error per texel at region borders ", r.border_excess,
                 " x that inside the regions)");
    return r;
  }
  GatherOptions fine_options = gather;
  fine_options.texture_size = 0;
  fine_options.progress = false;
  // At most twice as fine a side: further, a texel's few samples pin its
  // weights worse than the coarse texel's many, at a cost that grows with
  // the square of the side.
  fine_options.max_atlas_size = std::max(16, std::min(gather.max_atlas_size, 2 * g->atlas.width));
  GatherResult fine = Gather(scene, fine_options);
  r.fine_size = fine.atlas.width;
  if (fine.atlas.width <= g->atlas.width || fine.atlas.height <= g->atlas.height) return r;
  r.tried = true;

  // Fine texels take the label of the coarse texel their centre falls in.
  std::vector<int> fine_label(fine.atlas.texels.size(), -1);
  for (size_t t = 0; t < fine.atlas.texels.size(); ++t) {
    const Texel& tx = fine.atlas.texels[t];
    const int cx = std::min(g->atlas.width - 1, int((tx.x + 0.5) * g->atlas.width / fine.atlas.width));
    const int cy = std::min(g->atlas.height - 1, int((tx.y + 0.5) * g->atlas.height / fine.atlas.height));
    const int c = g->atlas.At(cx, cy);
    if (c >= 0) fine_label[t] = coarse_label[size_t(c)];
  }
  Clustering fine_cl = Fixed(fine, o, *est, fine_label);
  r.heldout_rmse_fine = fine_cl.HeldoutRmse(m);
  r.kept = r.heldout_rmse_fine < r.heldout_rmse_coarse;
  r.line = Msg("fine weights: ", fine.atlas.width, "^2 atlas instead of ", g->atlas.width,
               "^2 (border error ", r.border_excess, " x the interior's), held-out RMSE ", r.heldout_rmse_fine,
               " against ", r.heldout_rmse_coarse, ": ", r.kept ? "kept" : "not kept");
  if (!r.kept) return r;

  SvbrdfEstimate out = *est;
  fine_cl.LabelUnseenByAllSamples();
  fine_cl.FinalWeights(m, &out.weights, &out.residual);
  ConfidenceAndFill(fine.samples, fine.atlas, o, int(out.basis.size()), fine_cl.neighbours(), &out);
  *est = std::move(out);
  *g = std::move(fine);
  return r;
}

}  // namespace svbrdf
