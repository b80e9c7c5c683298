// Starting points for the non-convex model fits. Models are linear in their
// colour amplitudes (rd, rs, rho) and non-linear in a few shape parameters
// (exponents, roughness), so a start is a guess of the shape parameters with
// the amplitudes solved by linear least squares for that shape.
#pragma once
#include <cstdint>
#include <vector>

#include "brdf/model.h"
#include "fit/batch_cost.h"

namespace svbrdf {

// Clamps each parameter into [lower, upper] of spec.Params().
void ClampToBounds(const ModelSpec& spec, std::vector<double>* params);

// Sets the colour parameters the model is affine in (ParamInfo::linear,
// names ending _r/_g/_b) to their per-channel linear least-squares estimate
// over the first `count` samples of `packed`, holding the other parameters
// fixed, clamped into bounds; the basis responses come from EvalModel.
// Conductors with the exact Fresnel get (eta, kappa) from the f0 of their
// Schlick twin. Other non-linear colour parameters keep their values.
void FitAmplitudes(const ModelSpec& spec, const PackedSamples& packed, int64_t count, std::vector<double>* params);

// `base` first, then copies of it with the shape parameters spread over their
// typical range (Lafortune/Phong exponents 5, 30, 200 — multi-lobe Lafortune
// gets a different exponent per lobe; Cook–Torrance and coated roughness
// 0.05, 0.15, 0.4; conductor roughness 0.02, 0.08, 0.3).
// Models without lobes get only `base`. Values are clamped into bounds.
std::vector<std::vector<double>> ShapeStarts(const ModelSpec& spec, const std::vector<double>& base);

// Conductors with the exact Fresnel: `start` with each channel's (eta, kappa)
// replaced by a real metal's kind of index (kappa large) of the same
// normal-incidence reflectance; empty for other models or when nothing
// changes. A second start family for a fit that is not convex in (eta, kappa).
std::vector<double> MetalLikeStart(const ModelSpec& spec, const std::vector<double>& start);

}  // namespace svbrdf
