// Per-texel normal refinement after the clustering, in the style of Lensch et
// al. 2003 ("Image-based reconstruction of spatially varying materials",
// ACM TOG 22(2), sec. 6: the basis materials are known, so a texel's samples
// determine its normal): the mesh normal is only the smooth, coarse geometry;
// bumps, scratches and mis-registered facets tilt the true shading normal, and
// a tilted normal moves highlights and shading that no mixing weight can move.
//
// Per texel with at least `min_samples` samples, counting its 8 neighbours'
// at `neighbour_weight` (others keep the mesh normal):
//  1. Normal: minimise over (a, b) (tangent-plane parametrisation, normal_cost.h)
//        sum_i v_i rho(|pred_i(a, b) - y_i|^2) + (sigma / tau)^2 (a^2 + b^2)
//     by Levenberg-Marquardt (tilt_solver.h, Jet derivatives), each source's
//     mixing weights solved at every trial tilt (joint_cost.h; `joint_weights`); the
//     samples i are the texel's own (v = 1) and its 8 neighbours' expressed in
//     its frame with their own weights (v = neighbour_weight): a texel sees a
//     handful of photos, too few alone for a normal and its weights. That is
//     the first pass only (with `smooth_tilt` > 0, the default): later passes
//     take the texel's own samples and add, per neighbour u fitted too,
//     (sigma / tau_s)^2 |(a, b) - (a_u, b_u)|^2 (u's current tilt in the
//     texel's frame, tau_s = `smooth_tilt`), a smoothness prior instead of a
//     3 x 3 blur of the normal field.
//     rho: Cauchy loss at `robust_sigmas` sigma (samples that the model cannot
//     explain: misregistered pixels, interreflections). The prior is the MAP
//     term of a Gaussian prior on tan(tilt) with std tau = `prior_tilt`,
//     given Gaussian noise of std sigma on each channel of y: with little or
//     noisy data the normal stays at the mesh normal, with much clean data the
//     data decide. sigma is estimated from the data (`noise` < 0): 1.4826 x
//     the median absolute residual over all fitted sample channels under the
//     current normals and weights (first the mesh normals: an over-estimate,
//     hence a stronger, safe prior; re-estimated after every pass).
//  2. Weights: re-solved by NNLS with the refined normal over the materials
//     the texel or its 8 neighbours use, with a weak prior (one sample's
//     worth) towards the clustering's weights; then 1. and 2. once more
//     (`iterations` passes in all).
// Whether the refinement is kept is decided on held-out photos (the same
// whole-photo split as the clustering's, so the basis materials never saw
// them): on up to `decision_texels` texels, normals and weights are fitted on
// the training photos with and without refinement (the same weight solver for
// both), and, per basis material (each texel counted with its largest
// weight), the refined normals are kept only if that material's held-out
// squared error drops by `min_improvement` (relative): one material whose
// normals the data cannot place (a glossy lobe seen by few samples) must not
// cost the others theirs; the chosen normals must lower the error of all
// decision texels by `min_improvement` as well. The same decision on a
// quarter of those texels first (`screen_texels`; without start tilts) ends
// it early when it keeps no normals. The kept materials' normals are then fitted on
// all samples; the other texels keep the mesh normal. Deterministic for a seed and independent of the thread count
// (texels are independent; sums are taken in texel order).
#pragma once
#include <algorithm>
#include <chrono>
#include <string>
#include <vector>

#include "atlas/atlas.h"
#include "cluster/holdout.h"
#include "cluster/reconstruct.h"
#include "gather/samples.h"

namespace svbrdf {

struct NormalOptions {
  // "on": refine, keep if the held-out error drops; "off": skip;
  // "force": refine and keep whatever the held-out error says.
  std::string mode = "on";
  int min_samples = 8;          // pooled samples (own + neighbour_weight x neighbours') a texel needs for its normal
  double neighbour_weight = 0.5;  // weight of the 8 neighbours' samples in a texel's normal fit, in [0, 1]
  // Pooling the neighbours' samples blurs the normal field by a 3 x 3
  // kernel, which a steep lobe pays for dearly (default_bump, true basis
  // and weights given: own samples alone relight better than pooled in
  // every pass; bench_results/bump_default.md). With smooth_tilt > 0 only the first
  // pass pools (a start that sees the bump over the neighbourhood); later
  // passes fit the texel's own samples with a Gaussian prior on the tilt
  // difference to each of its 8 neighbours' current tilts (std smooth_tilt
  // of tan(tilt) per axis, as prior_tilt towards the mesh normal): where a
  // texel's samples are weak (a matte texel, few photos) the neighbours
  // decide, where they are strong (a highlight) the data do. 0 = pool in
  // every pass.
  double smooth_tilt = 0.05;
  int min_own_samples = 4;  // fewer own samples: the texel pools its neighbours' in every pass
  double prior_tilt = 0.35;     // tau: prior std of tan(tilt) per tangent axis (0.35 ~ 19 degrees), > 0
  double noise = -1.0;          // sigma of y per channel; < 0: estimated from the residuals
  double robust_sigmas = 3.0;   // Cauchy loss scale in sigmas; 0 = plain least squares
  // Graduated robustness: pass p of `iterations` uses a Cauchy scale
  // robust_growth^(iterations - 1 - p) times the final one. From mesh normals
  // a glossy texel's highlights miss by many sigmas; a tight Cauchy loss from
  // the start treats exactly the samples that locate the normal as outliers.
  // Off by default (1): on the mixed preset it did not make the metal's
  // normals right (its material is the limit) and cost held-out error.
  double robust_growth = 1.0;   // >= 1 (1 = the same scale in every pass)
  // Shot noise: sample residuals weighted by 1 / (1 + y / y_med) (y the
  // sample's mean over channels, y_med the median over all samples), the
  // inverse variance of photon noise above a floor, so that sigma and the
  // Cauchy scale hold for dark and bright samples alike. It pays together
  // with joint_weights (the mixed preset's copper normals come closer to
  // the truth and relight better); with the weights held fixed it costs.
  bool shot_noise = true;
  // The tilt fit solves the mixing weights with it (joint_cost.h: every
  // pooled source's weights re-solved at each trial tilt) instead of holding
  // the previous pass's weights fixed: weights fitted under the mesh normal
  // are biased under a bump, and a tilt fitted with them falls short of
  // the true tilt (mixed preset, true basis and weights given), far less
  // so jointly.
  bool joint_weights = true;
  double max_tilt_deg = 60.0;   // bound of the tilt per tangent axis, in (0, 85]
  int iterations = 3;           // normal + weights passes, >= 1
  // When kept: cluster again on reoriented samples, refine again (pipeline).
  // Off by default: it doubles the reconstruction time, and on the standard
  // and mixed captures the second clustering was never the better one.
  bool recluster = false;
  // When kept: the basis materials' models chosen and fitted again on the
  // samples re-expressed in the refined normals' frames (the clustering's
  // partition kept), then the normals refined again from the refined ones;
  // repeated up to this many times while the held-out error drops (pipeline).
  // Under a bump map the materials fitted with the mesh normals are biased
  // (a metal's shifted highlights read as a broader, dimmer lobe), and the
  // normals fitted with biased materials stay short of the true tilt.
  // 2 by default (as the pipeline's bootstrap, normal_stage.h): with the
  // joint weights the first refinement is kept on the bump-mapped default
  // capture (its glossy paint's normals lower its error), which skips the
  // bootstrap, and the rounds then gain most of its held-out accuracy
  // (bench_results/bump_default.md). On the mixed preset and mixed_tiny
  // round 1 is rejected (it only costs CPU); where no normals are kept
  // (default, standard) no round runs.
  int material_rounds = 2;
  // In each material round, after the basis is refitted in the current
  // normals' frames: its parameters fitted jointly with the tilts of its
  // interior texels (basis_polish.h), so that the round does not stop where
  // the tilts absorbed the basis' error.
  bool polish_basis = true;
  int max_iterations = 10;      // Levenberg-Marquardt iterations per texel (2 unknowns: converges in a few)
  long decision_texels = 4000;  // texels used for the held-out decision (a seeded subset), >= 100
  // A screening decision first, the same on this many of the decision
  // texels (the seeded subset's first ones): when it does not keep the
  // normals, neither does the refinement, and the full decision is not run.
  // Where the mesh carries the true normals (no material gains clearly)
  // that costs a quarter of the decision; where normals do pay, the full
  // decision runs after it and alone decides. Only for a refinement from
  // the mesh normals (no start tilts): the rounds that start from kept
  // normals would mostly pass it and pay for it. 0 = off; else in
  // [100, decision_texels].
  long screen_texels = 1000;
  double min_improvement = 0.01;  // relative held-out squared-error drop needed to keep the normals
  double holdout_fraction = 0.2;  // must match the clustering's (ReconstructOptions)
  uint64_t seed = 1;              // must match the clustering's
  int threads = 0;
  bool progress = true;
  // Anytime (reconstruct --time-budget): when the held-out decision took
  // so long that the fit on all texels (estimated from it) would end after
  // this, the refinement is not kept (cut_by_deadline) instead of overrunning;
  // the decision and the fit also stop before a pass that would start after it.
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();
  void Check() const;
  bool Enabled() const { return mode != "off"; }
};

struct NormalRefinement {
  bool kept = false;                // refined normals (and re-solved weights) replace the clustering's (for some material)
  // Per basis material: its texels (by largest weight) keep refined normals
  // (decided per material on the held-out photos; all 1 with mode "force").
  std::vector<char> material_kept;
  std::vector<double> heldout_rmse_mesh_by_material, heldout_rmse_refined_by_material;  // decision, per material
  std::vector<Vec3> normal;         // per texel, world space, unit (the mesh normal where not refined)
  std::vector<Vec2> tilt;           // per texel, (a, b) of normal_cost.h in the mesh frame (0 where not refined)
  std::vector<char> refined;        // per texel: has its own normal
  std::vector<float> weights;       // [t][k][c], re-solved with the normals (the estimate's when not kept)
  long texels_refined = 0;
  double noise_sigma = 0;           // sigma used in the final pass
  double heldout_rmse_mesh = 0;     // decision: held-out RMSE with mesh normals
  double heldout_rmse_refined = 0;  // ... and with the chosen normals (refined for kept materials, mesh elsewhere)
  long decision_texels = 0;
  double mean_tilt_deg = 0, median_tilt_deg = 0;  // of refined texels, from the mesh normal
  bool cut_by_deadline = false;     // not kept for lack of time: the deadline came during the decision or the fit, or the fit on all texels would end after it
  std::string Report() const;
};

// `start`: per-texel tilts to start the refined fits from (e.g. an earlier
// round's); null = the mesh normals. The prior always pulls towards the mesh normal.
NormalRefinement RefineNormals(const SampleSet& samples, const Atlas& atlas, const SvbrdfEstimate& estimate,
                               const NormalOptions& options, const std::vector<Vec2>* start = nullptr);

// The pieces of RefineNormals' own-sample passes that the basis polish
// (basis_polish.h) shares:
// - the texel's 8 atlas neighbours (texels below num_texels);
std::vector<int> TexelNeighbours8(const Atlas& atlas, int t, int num_texels);
// - a neighbour's tilt (a, b) in its frame `from`, carried into the tangent
//   axes of `to`; false across a crease or a thin part (normals > 60 deg
//   apart: unrelated bumps, no constraint);
bool NeighbourTiltInFrame(const Vec2& ab, const Frame& from, const Frame& to, Vec2* out);
// - the Gaussian priors of a tilt fit as one: towards the mesh normal (std
//   prior_tilt) and towards each neighbour's tilt (std smooth_tilt, when
//   > 0), in units of the noise sigma: scale = sigma sqrt(sum of
//   precisions), centred at their precision-weighted mean.
void CombinedTiltPrior(const NormalOptions& o, const std::vector<Vec2>& neighbour_tilts, double sigma, double* scale,
                       double mean[2]);

// Shot-noise weighting of the normal fits (NormalOptions::shot_noise): a
// sample of mean brightness ybar has relative variance 1 + ybar / median,
// the median taken over (a subsample of) all samples' mean brightness.
struct ShotNoiseWeights {
  double y_median = 0;  // > 0: weights on; 0: every weight 1
  // Inverse relative variance of a sample with colour y.
  double operator()(const double* y) const {
    return y_median > 0 ? 1.0 / (1.0 + std::max(0.0, (y[0] + y[1] + y[2]) / 3.0) / y_median) : 1.0;
  }
};
ShotNoiseWeights MakeShotNoiseWeights(const SampleSet& samples, bool on);

// The samples re-expressed in the frames of the refined normals (directions
// rotated, geom = cos_i(refined) s), so that a second clustering sees the
// materials without the shading of the bumps. Samples below a refined
// texel's horizon (light or viewer) are dropped.
SampleSet ReorientSamples(const SampleSet& samples, const std::vector<Vec2>& tilt);

}  // namespace svbrdf
