#include "pipeline/fine_weights_stage.h"

#include <algorithm>
#include <cmath>
#include <numeric>

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
// its weights score worse (docs/measurements.md, "Fine weights"). The
// ratio of means or that of medians (whichever is larger) counts: a metal's
// highlight texels can hold most of the interior's mean error and hide
// borders that most texels show worse (docs/measurements.md, "Seeds
// 49-60"); where the stage is tried, the held-out photos decide.
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

// Continuous texel coordinates in `atlas` (texture coordinates of `mesh`)
// of the surface point that `tx` (a texel of an atlas of the same
// triangles) stands for.
Vec2 TexelCoordsIn(const Mesh& mesh, const Atlas& atlas, const Texel& tx) {
  return UvToTexel(TexelUv(mesh, tx), atlas.width, atlas.height);
}

// The texel of `atlas` under continuous texel coordinates p, or the nearest
// covered one within a texel (atlas borders); -1 if none.
int TexelAt(const Atlas& atlas, const Vec2& p) {
  const int x = int(std::floor(p.x())), y = int(std::floor(p.y()));
  int best = -1;
  double best_d = 1e300;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int u = x + dx, v = y + dy;
      if (u < 0 || v < 0 || u >= atlas.width || v >= atlas.height || atlas.At(u, v) < 0) continue;
      const double d = (Vec2(u + 0.5, v + 0.5) - p).squaredNorm();
      if (d < best_d) best_d = d, best = atlas.At(u, v);
    }
  return best;
}

// Per-texel values (`stride` floats per texel of `atlas`) at continuous
// texel coordinates p, bilinear as a map lookup reads them, over the
// covered texels of the lookup only; the nearest texel's where none is.
void BilinearAt(const Atlas& atlas, const std::vector<float>& values, int stride, const Vec2& p, float* out) {
  const double fx = p.x() - 0.5, fy = p.y() - 0.5;
  const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
  const double ax = fx - x0, ay = fy - y0;
  std::fill(out, out + stride, 0.0f);
  double total = 0;
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const int u = x0 + dx, v = y0 + dy;
      if (u < 0 || v < 0 || u >= atlas.width || v >= atlas.height || atlas.At(u, v) < 0) continue;
      const double w = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
      if (!(w > 0)) continue;
      const float* src = &values[size_t(atlas.At(u, v)) * stride];
      for (int j = 0; j < stride; ++j) out[j] += float(w * src[j]);
      total += w;
    }
  if (total > 0) {
    for (int j = 0; j < stride; ++j) out[j] = float(out[j] / total);
    return;
  }
  const int t = TexelAt(atlas, p);
  if (t >= 0) std::copy(&values[size_t(t) * stride], &values[size_t(t + 1) * stride], out);
}

// The fits' view of the band's samples: a band sample is kept only where
// its coarse texel (`coarse_of`, per fine texel; -1: none) has a sample in
// the same photo (one the fits kept: the footprint filter,
// ReconstructionJob::fit_max_unlit_share, judged the coarse texel's pixel
// footprint, so the band inherits it without a probe of its own, which
// would be most of its gather's cost), and loses that sample's indirect
// light (FineWeightsInputs::raw_y). Returns how many samples were dropped.
int64_t PrepareBandSamples(const SampleSet& cs, const FineWeightsInputs& in, const std::vector<int>& coarse_of,
                           GatherResult* fine) {
  SampleSet& s = fine->samples;
  std::vector<char> keep(size_t(s.size()), 1);
  for (int t = 0; t < s.num_texels; ++t) {
    const int c = coarse_of[size_t(t)];
    for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) {
      int64_t j = -1;  // the coarse texel's sample in the same photo
      if (c >= 0 && c < cs.num_texels)
        for (int64_t q = cs.texel_begin[c]; q < cs.texel_begin[c + 1] && j < 0; ++q)
          if (cs.image[q] == s.image[i]) j = q;
      if (j < 0) {
        keep[i] = 0;
        continue;
      }
      if (in.raw_y)  // the indirect light removed from the coarse sample: its raw value less what the fits saw
        for (int ch = 0; ch < 3; ++ch) s.y[ch][i] = std::max(0.0f, s.y[ch][i] - ((*in.raw_y)[ch][j] - cs.y[ch][j]));
    }
  }
  const int64_t dropped = std::count(keep.begin(), keep.end(), char(0));
  if (dropped > 0) s = KeepSamples(s, keep);
  fine->probes.clear();
  return dropped;
}

// Weights of `cl` (model m) fitted on its training samples only, and their
// held-out RMSE (HeldoutRmse(m)) with its per-texel squared errors.
std::vector<float> TrainingWeights(const Clustering& cl, const WeightModel& m, double* heldout_rmse,
                                   std::vector<double>* per_texel) {
  int64_t n = 0;
  std::vector<float> first, weights;
  if (m.smooth) cl.MixtureError(m, false, false, &n, &first, nullptr);
  const double sse = cl.MixtureError(m, false, false, &n, &weights, nullptr, per_texel, m.smooth ? &first : nullptr);
  *heldout_rmse = n ? std::sqrt(sse / n) : 0.0;
  return weights;
}

}  // namespace

void FineWeightsOptions::Check() const {
  if (!(texel_footprint > 0))
    throw Error(Msg("reconstruct: --fine-texel-footprint must be > 0 pixel footprints, got ", texel_footprint));
  if (band_rings < 1) throw Error(Msg("reconstruct: --fine-band-rings must be >= 1, got ", band_rings));
}

FineWeightsReport RefineWeightsOnFinerAtlas(const Scene& scene, const GatherOptions& gather,
                                            const FineWeightsOptions& fo, const ReconstructOptions& o,
                                            const FineWeightsInputs& in, GatherResult* g, SvbrdfEstimate* est) {
  fo.Check();
  FineWeightsReport r;
  r.coarse_size = g->atlas.width;
  if (in.normal_map || in.indirect_unknown || est->basis.empty() || o.SecondsLeft() <= 0) return r;
  if (in.raw_y && in.raw_y->at(0).size() != size_t(g->samples.size()))
    throw Error(Msg("internal: fine weights: ", in.raw_y->at(0).size(), " raw values for ", g->samples.size(),
                    " samples"));
  const int K = int(est->basis.size());
  // The coarse atlas's held-out error per texel, at region borders (a
  // neighbour of another label) against inside the regions: only where the
  // borders carry the error can finer weights lower it.
  const WeightModel m = ChosenWeightModel(o, *est);
  const std::vector<int> coarse_label = LargestWeightLabels(est->weights, K);
  Clustering coarse_cl = Fixed(*g, o, *est, coarse_label);
  std::vector<double> per_texel;
  double coarse_rmse = 0;
  const std::vector<float> coarse_train = TrainingWeights(coarse_cl, m, &coarse_rmse, &per_texel);
  std::vector<double> border_errors, inside_errors;
  for (size_t t = 0; t < per_texel.size() && t < coarse_cl.neighbours().size(); ++t) {
    if (!(per_texel[t] > 0) || coarse_label[t] < 0) continue;
    bool border = false;
    for (int u : coarse_cl.neighbours()[t])
      border = border || (coarse_label[size_t(u)] >= 0 && coarse_label[size_t(u)] != coarse_label[t]);
    (border ? border_errors : inside_errors).push_back(per_texel[t]);
  }
  const double border_sse = std::accumulate(border_errors.begin(), border_errors.end(), 0.0);
  const double inside_sse = std::accumulate(inside_errors.begin(), inside_errors.end(), 0.0);
  const double border_n = double(border_errors.size()), inside_n = double(inside_errors.size());
  r.border_excess = border_n && inside_n && inside_sse > 0 ? (border_sse / border_n) / (inside_sse / inside_n) : 0.0;
  // The same ratio of medians (kMinBorderExcess says why).
  const double inside_median = Median(inside_errors);
  r.border_excess_median = inside_median > 0 ? Median(border_errors) / inside_median : 0.0;
  if (r.border_excess < kMinBorderExcess && r.border_excess_median < kMinBorderExcess) {
    r.line = Msg("fine weights: not tried (held-out error per texel at region borders ", r.border_excess,
                 " x that inside the regions, median ", r.border_excess_median, " x; held-out RMSE ", coarse_rmse, ")");
    return r;
  }
  // The band the fine atlas samples: coarse texels within fo.band_rings of a
  // region border. Inside the regions the coarse weights are as good as
  // finer ones (one material), and the gather's cost grows with the texels.
  const std::vector<char> core = CoreTexels(coarse_cl.neighbours(), coarse_label, fo.band_rings);
  GatherOptions fine_options = gather;
  fine_options.texture_size = 0;
  fine_options.texel_footprint = fo.texel_footprint;
  fine_options.progress = false;
  // At most twice as fine a side: the cost grows with the square of the side.
  fine_options.max_atlas_size = std::max(16, std::min(gather.max_atlas_size, 2 * g->atlas.width));
  // The coarse gather's decision on the footprint sub-samples holds for the
  // same surface (and they cost a third of a gather where they are dropped).
  if (!g->stats.footprint_kept) fine_options.footprint_subsamples = 0;
  else fine_options.footprint_min_tilt_deg = 0;
  fine_options.probe_rays = 0;  // PrepareBandSamples: the coarse texels' filter
  const Mesh& coarse_mesh = g->mesh;
  const Atlas& coarse_atlas = g->atlas;
  fine_options.sample_texel = [&](const Texel& tx) {
    const int c = TexelAt(coarse_atlas, TexelCoordsIn(coarse_mesh, coarse_atlas, tx));
    return c >= 0 && size_t(c) < core.size() && !core[size_t(c)];
  };
  GatherResult fine = Gather(scene, fine_options);
  r.fine_size = fine.atlas.width;
  if (fine.atlas.width <= g->atlas.width || fine.atlas.height <= g->atlas.height) return r;
  if (fine.mesh.faces.size() != coarse_mesh.faces.size())
    throw Error(Msg("fine weights: the fine atlas's mesh has ", fine.mesh.faces.size(), " triangles, the coarse one ",
                    coarse_mesh.faces.size()));
  r.tried = true;

  // Per fine texel: its coarse texel coordinates and texel, and the band's
  // texels take the label of the coarse texel they fall in.
  const size_t nf = fine.atlas.texels.size();
  std::vector<Vec2> at_coarse(nf);
  std::vector<int> coarse_of(nf, -1), fine_label(nf, -1);
  std::vector<char> in_band(nf, 0);
  for (size_t t = 0; t < nf; ++t) {
    at_coarse[t] = TexelCoordsIn(coarse_mesh, coarse_atlas, fine.atlas.texels[t]);
    const int c = coarse_of[t] = TexelAt(coarse_atlas, at_coarse[t]);
    if (c < 0) continue;
    fine_label[t] = coarse_label[size_t(c)];
    in_band[t] = !core[size_t(c)];
  }
  r.dropped = PrepareBandSamples(g->samples, in, coarse_of, &fine);
  Clustering fine_cl = Fixed(fine, o, *est, fine_label);
  // Both on the band's held-out samples: the fine weights, and the coarse
  // ones (fitted on the same training photos) as a map lookup reads them.
  const int stride = K * 3;
  std::vector<float> coarse_on_fine(nf * stride, 0.0f);
  for (size_t t = 0; t < nf; ++t)
    if (in_band[t]) BilinearAt(coarse_atlas, coarse_train, stride, at_coarse[t], &coarse_on_fine[t * stride]);
  int64_t n = 0;
  const double coarse_sse = fine_cl.HeldoutSse(coarse_on_fine, &n);
  r.heldout_rmse_coarse = n ? std::sqrt(coarse_sse / n) : 0.0;
  r.heldout_rmse_fine = fine_cl.HeldoutRmse(m);
  r.kept = n > 0 && r.heldout_rmse_fine < r.heldout_rmse_coarse;
  r.line = Msg("fine weights: ", fine.atlas.width, "^2 atlas instead of ", g->atlas.width, "^2 within ",
               fo.band_rings, " texels of the region borders (border error ", r.border_excess,
               " x the interior's, median ", r.border_excess_median, " x; ",
               std::count(in_band.begin(), in_band.end(), char(1)), " of ", nf, " fine texels",
               in.raw_y ? ", indirect light of the coarse texels removed" : "", "; ", r.dropped,
               " samples dropped: their coarse texel has none in that photo",
               "), held-out RMSE there ", r.heldout_rmse_fine, " against ", r.heldout_rmse_coarse, ": ",
               r.kept ? "kept" : "not kept");
  if (!r.kept) return r;

  SvbrdfEstimate out = *est;
  fine_cl.LabelUnseenByAllSamples();
  fine_cl.FinalWeights(m, &out.weights, &out.residual);
  ConfidenceAndFill(fine.samples, fine.atlas, o, K, fine_cl.neighbours(), &out);
  // Outside the band (and where the band has no samples of its own), the
  // coarse estimate as a map lookup reads it.
  for (size_t t = 0; t < nf; ++t) {
    if (in_band[t] && fine.samples.texel_begin[t + 1] > fine.samples.texel_begin[t]) continue;
    BilinearAt(coarse_atlas, est->weights, stride, at_coarse[t], &out.weights[t * stride]);
    const int c = coarse_of[t];
    if (c < 0 || size_t(c) >= est->confidence.size() || size_t(c) >= est->residual.size()) continue;
    out.confidence[t] = est->confidence[size_t(c)];
    out.residual[t] = est->residual[size_t(c)];
  }
  out.label = FilledWeightLabels(out.weights, K);  // as ConfidenceAndFill labels them
  out.texels_without_samples = est->texels_without_samples;
  out.texels_filled = est->texels_filled;
  *est = std::move(out);
  fine.stats = g->stats;  // what the fits saw
  *g = std::move(fine);
  return r;
}

}  // namespace svbrdf
