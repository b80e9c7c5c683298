// Basis materials fitted jointly with the normals of their texels (internal
// to the normals <-> materials rounds of lib/pipeline/normal_stage).
//
// Why: the rounds alternate two fits, the basis materials in the frames of
// the current normals (RefitSvbrdf), then the normals against the refitted
// basis (RefineNormals). Each texel's tilt is fitted to a handful of samples
// against the current basis and absorbs much of that basis' error (a tilt
// can move a highlight's samples towards a wrong lobe), so the next basis
// fit in those frames sees the error only in part: the alternation
// converges linearly and slowly. On the mixed preset the coated plastic's
// ior creeps towards the truth by a shrinking step per round, while the
// same fit in the TRUE normals' frames recovers it exactly, and the truth
// with only that basis swapped in relights the held-out views clearly
// worse.
//
// Here, per basis material k whose normals are kept, its interior texels
// (label k on the texel and its 8 neighbours, no other material's weight),
// a seeded subset of at most `max_samples` training samples: minimise over
// the basis parameters theta_k and every such texel's tilt (a, b) jointly
//     sum_t [ sum_i v_i rho(|w_t f_k(theta_k; frame(a_t, b_t)) - y_i|^2)
//             + (sigma / tau)^2 |(a_t, b_t) - m_t|^2 ]
// (Levenberg-Marquardt, the tilts eliminated by the Schur complement), the
// terms of RefineNormals' later passes: shot-noise weights v_i, Cauchy loss
// at robust_sigmas sigma, the texel's weights w_t held, the priors towards
// the mesh normal and the neighbours' current tilts combined into one
// Gaussian (mean m_t, NormalOptions prior_tilt and smooth_tilt). Only
// theta_k is kept; the normals are then refined from it as before.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "atlas/atlas.h"
#include "cluster/reconstruct.h"
#include "gather/samples.h"
#include "normals/refine.h"

namespace svbrdf {

struct BasisPolishReport {
  int material = 0;
  long texels = 0;
  int64_t samples = 0;
  int iterations = 0;
  double cost_before = 0, cost_after = 0;  // the joint objective (sum of squares)
  std::vector<double> params_before, params_after;
};

// Polishes `est`'s basis (est->basis[k].params) for the materials with
// `material_kept[k]`, from the tilts `tilt` (per texel, NormalRefinement's)
// and the noise `sigma` (NormalRefinement::noise_sigma, > 0). Training photos
// only (the hold-out of `no`). `max_samples` per material (FitOptions').
std::vector<BasisPolishReport> PolishBasisWithTilts(const SampleSet& samples, const Atlas& atlas,
                                                    const NormalOptions& no, const std::vector<Vec2>& tilt,
                                                    const std::vector<char>& material_kept, double sigma,
                                                    int64_t max_samples, SvbrdfEstimate* est);

std::string Report(const BasisPolishReport& r, const SvbrdfEstimate& est);

}  // namespace svbrdf
