// Small statistics shared by the clustering stages: per-sample errors of a
// model, a trimmed RMSE and a paired z statistic.
#pragma once
#include <cstdint>
#include <vector>

#include "brdf/model.h"
#include "gather/samples.h"

namespace svbrdf {

// Where model selection measures errors. Empty: linear, in the samples'
// units (reflected radiance per unit light). Otherwise per image (indexed as
// SampleSet::image) the photo's pixel value per unit sample value, per
// channel (its exposure x its light's colour): a sample and its prediction
// are brought to the photo's pixel values, clamped to [0, 1] and
// sRGB-encoded, the units held-out photos are scored in (svbrdf evaluate).
// Linear errors let the few brightest samples (a highlight's peak, which the
// photo may not even resolve below saturation) decide between models that
// differ in the dark flanks and the diffuse most of every picture shows.
using DisplayScale = std::vector<Rgb>;

// Per-sample squared residuals (summed over channels) of a model on samples
// `ids`, linear or on the display scale `display` (when non-empty).
std::vector<double> SampleErrors(const ModelSpec& spec, const std::vector<double>& params, const SampleSet& s,
                                 const std::vector<int64_t>& ids, const DisplayScale& display = {});

// RMS residual per channel without the largest 2 % of per-sample errors:
// held-out samples of texels that the assignment got wrong must not decide
// which model describes the cluster.
double TrimmedRmse(std::vector<double> e);

// Share of the samples `ids` that `display` shows at white (some channel at
// or above 1): clamped, they cannot tell models apart. Model selection falls
// back to linear errors for a cluster where this share is large (photos
// stored at a radiance scale far above their display range).
double ClippedShare(const SampleSet& s, const std::vector<int64_t>& ids, const DisplayScale& display);
// Above this share of samples shown at white, display-unit errors cannot
// rank models or materials: linear errors instead.
constexpr double kMaxClippedShare = 0.2;

// Value v of sample i's channel c as `display` shows it (identity when empty).
double Shown(double v, const DisplayScale& display, const SampleSet& s, int64_t i, int c);

// RMS of the samples' values per channel (the scale of "parsimony" margins),
// linear or on the display scale `display` (when non-empty).
double SignalRms(const SampleSet& samples, const std::vector<int64_t>& ids, const DisplayScale& display = {});

// Paired z statistic: how many standard errors the mean of `b` lies below `a`.
double PairedZ(const std::vector<double>& a, const std::vector<double>& b);

// As PairedZ on the bounded per-texel changes (a_t - b_t) / (a_t + b_t) of
// texels with a_t + b_t > 0: how consistently texels improve, not dominated
// by the few texels with the largest errors (highlights).
double BoundedPairedZ(const std::vector<double>& a, const std::vector<double>& b);

// The larger of the two: paired tests over texels on the squared errors
// (dominated by the texels with the largest errors) or on the bounded
// per-texel changes (how consistently texels improve; with few photos the
// first is noisy). The z of every held-out "b improves on a" test here.
double ImprovementZ(const std::vector<double>& a, const std::vector<double>& b);

// Relative drop 1 - sum(b) / sum(a) of paired per-texel errors, without the
// texels among the largest `trim` share of either (the union): one texel
// whose held-out samples a new glossy material mispredicts (a misassigned
// texel, a highlight the neighbour pooling put on the wrong side of a
// border) must not decide a split. Seen on mixed_tiny: one copper texel's
// held-out error outweighed the gain of all the others, and the right
// 3-material split read as far worse.
double TrimmedDrop(const std::vector<double>& a, const std::vector<double>& b, double trim = 0.02);
// The drop a material brings (pruning's test and the split search's blend
// test: errors `without` it against `with` it), trimmed of the largest
// `trim` share of `with` only. The texels that are bad only without the
// material are its evidence: trimmed as TrimmedDrop trims, a small region
// of a distinct material lost it (issue capture type bunny, seed 205: a
// green paint on 7 % of the texels, relit as copper and red plastic once
// removed, read as an 8 % drop; trimmed on `with` only, 83 %). Texels bad with
// the material too (a highlight it does not explain) still stay out.
double RemovalDrop(const std::vector<double>& without, const std::vector<double>& with, double trim = 0.02);
// The texels TrimmedDrop leaves out (1): the largest `trim` share of a and
// that of b (their union), over the first min(a.size(), b.size()) texels.
std::vector<char> WorstOfEither(const std::vector<double>& a, const std::vector<double>& b, double trim = 0.02);

}  // namespace svbrdf
