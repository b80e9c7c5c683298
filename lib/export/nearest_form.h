// The Mitsuba 3 form of one basis material: a diffuse part plus an optional
// rough-conductor lobe,
//
//   f = rd/pi + rs D(h; alpha) G_smith(wi, wo; alpha) F(<h|wo>) / (4 <n|wi><n|wo>)
//
// which is exactly our cook_torrance-{beckmann,ggx}-smith[-nofresnel] model
// (D normalised, alpha = RMS slope for Beckmann and alpha for GGX, Smith
// masking as in Mitsuba 3's microfacet.h, F the exact dielectric Fresnel of
// `eta` (Mitsuba: roughconductor with eta = ior, k = 0) or 1 (material
// "none")). Mitsuba renders it as blendbsdf(diffuse, roughconductor).
//
// Mapping of our models (MapToNearestForm):
//   lambert                                   exact: diffuse, no lobe
//   cook_torrance-{beckmann,ggx}-smith        exact (same D, G, F)
//   cook_torrance-...-nofresnel               exact with material "none"
//   cook_torrance, V-cavity G                 nearest: same D and F, Smith G
//   cook_torrance-...-schlick                 nearest: exact Fresnel of the same ior
//   cook_torrance-blinn-*                     nearest: Beckmann with alpha = m
//                                             (equal for small m)
//   oren_nayar, phong, blinn_phong,           nearest: rd, rs >= 0 per channel and
//   cosine_lobe, lafortune-*                  alpha, distribution fitted by least squares
//                                             on DirectionPairs (grid over alpha,
//                                             exact 2-variable NNLS per channel)
// `error` is the relative RMSE of the form against the model on
// DirectionPairs::Standard() (radiance under unit irradiance), so 0 for exact
// mappings.
#pragma once
#include <string>

#include "export/directions.h"
#include "io/material.h"

namespace svbrdf {

struct NearestForm {
  Rgb rd = Rgb::Zero();
  bool has_lobe = false;
  Rgb rs = Rgb::Zero();                   // Mitsuba: specular_reflectance
  Distribution distribution = Distribution::kBeckmann;  // Beckmann or GGX only
  double alpha = 0.1;                     // Mitsuba: alpha
  bool fresnel = false;                   // true: eta = ior, k = 0; false: material "none" (F = 1)
  double eta = 1.5;
  bool exact = false;
  std::string how;                        // one line: how the mapping was made
  double error = 0;                       // relative RMSE against the model (see above)

  // The form as one of our models, for evaluation (cook_torrance-*-smith[-nofresnel] or lambert).
  BasisMaterial AsBasis(const std::string& name) const;
};

NearestForm MapToNearestForm(const BasisMaterial& basis, const DirectionPairs& d);

}  // namespace svbrdf
