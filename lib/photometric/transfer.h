// Light transfer beyond the BRDF: what the photos hold that a direct
// reflection off the surface does not explain (interreflection from the
// object's other parts, light through the cast shadows, subsurface and
// stray light, the BRDF fit's own error). For distant lights seen from the
// capture's view it is, per texel, a smooth function of the direction
// towards the light (precomputed radiance transfer, Sloan et al. 2002); it
// is stored as a polynomial of that direction d (world frame):
//
//   L_transfer = E * sum_k c_k phi_k(d)   (io/material.h LightTransferTerms)
//
// with E the light's irradiance on a surface facing it and c_k an RGB map
// each (material.json "light_transfer"). It is fitted per pixel to the
// residuals of the direct prediction; its degree (none, 1, 2 or 3) is the
// one with the lowest error on photos left out of the fit (light folds),
// a higher degree kept only when it lowers that error by min_gain.
#pragma once
#include <string>
#include <vector>

#include "io/image.h"
#include "io/material.h"
#include "photometric/dictionary_fit.h"
#include "photometric/observations.h"

namespace svbrdf {

struct TransferFit {
  std::vector<Image> maps;      // 4, 9 or 16 RGB maps (photo-sized), empty when not kept
  int terms = 0;                // maps.size()
  std::vector<std::pair<int, double>> cv_error_by_terms;  // (terms, cross-validated error), 0 = none
  double cv_error_without = 0;  // cross-validated error of the direct prediction alone
  double cv_error_with = 0;     // with the transfer term fitted on the other folds
  bool kept = false;
};

// `weights` are SolveWeights' maps for `basis`; `shadowed` the cast shadows.
// ridge: Tikhonov weight relative to the mean diagonal of the normal
// equations (keeps sparse pixels near zero transfer).
TransferFit FitTransfer(const PsObservations& obs, const std::vector<BasisMaterial>& basis,
                        const std::vector<Image>& weights, const Image& normals_cam,
                        const std::vector<uint8_t>& shadowed, const DictionaryFitOptions& o, double ridge = 1e-4);

// What the direct prediction plus the light transfer still leave in the
// training photos, kept as samples over the light directions and
// interpolated between the nearest of them for a new light (io/material.h
// LightResidualNeighbours): per-pixel detail that no smooth function of the
// light direction holds (a highlight's exact shape and place, a shadow
// edge), where the photos' lights are dense enough to carry it. Each pixel's
// residuals are scaled by lambda in [0, 1], the least-squares share of a
// left-out light's residual that its neighbours' interpolated residuals
// predict, pooled over a (2 window + 1)^2 pixel window: ~0 where the
// residuals are noise (interpolating noise only adds it), ~1 where they are
// structure the model lacks. Kept when that leave-one-light-out error is
// lower than without by min_gain.
struct ResidualField {
  std::vector<Vec3> directions;  // world frame, one per light of `obs`
  std::vector<Image> maps;       // lambda-scaled residuals (RGB, photo-sized); empty when not kept
  Image share;                   // lambda per pixel (1 channel)
  double loo_error_without = 0;  // weighted squared residuals of direct + transfer
  double loo_error_with = 0;     // ... minus lambda times the left-out light's interpolated residual
  bool kept = false;
};

ResidualField FitResidualField(const PsObservations& obs, const std::vector<BasisMaterial>& basis,
                               const std::vector<Image>& weights, const std::vector<Image>& transfer_maps,
                               const Image& normals_cam, const std::vector<uint8_t>& shadowed,
                               const DictionaryFitOptions& o);

}  // namespace svbrdf
