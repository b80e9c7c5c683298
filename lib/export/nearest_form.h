// The Mitsuba 3 form of one basis material: a diffuse part plus at most one
// lobe, which is a rough conductor or a rough plastic:
//
//   diffuse          rd/pi
//   roughconductor   rs D(h; alpha) G_smith(wi, wo; alpha) F(<h|wo>) / (4 <n|wi><n|wo>)
//                    F: exact Fresnel of the complex index eta + i k per channel
//                    (k = 0: a dielectric of index eta), or 1 (material "none")
//   roughplastic     the same lobe with the dielectric F of `ior` (the coat) plus
//                    a diffuse base rd seen through the rough coat (rough_plastic.h),
//                    nonlinear = true, ext_ior = 1
//   conductor        a smooth conductor: a delta reflection of the exact Fresnel of
//                    eta + i k per channel (no BRDF part), specular_reflectance = weight
//   plastic          a flat coat of `ior` (delta reflection) over a diffuse base:
//                    rd (1 - F(mu_i)) (1 - F(mu_o)) / (pi n^2 (1 - rd F_int)),
//                    nonlinear = true, ext_ior = 1; Mitsuba's F_int is the fit of
//                    Egan & Hilgeman (1973) to the internal diffuse reflectance
//
// D is normalised, alpha = RMS slope for Beckmann and alpha for GGX, Smith
// masking with the rational Beckmann G1 of Walter et al. 2007: all exactly
// as in Mitsuba 3's microfacet.h and our brdf/microfacet.h. Mitsuba renders
// a form as blendbsdf(diffuse, lobe).
//
// Mapping of our models (MapToNearestForm):
//   lambert                                   exact: diffuse, no lobe
//   cook_torrance-{beckmann,ggx}-smith        exact: diffuse + roughconductor, eta = ior, k = 0
//   cook_torrance-...-nofresnel               exact with material "none"
//   conductor-{beckmann,ggx}                  exact: roughconductor with our eta, kappa per channel
//   conductor-...-schlick, -f82               nearest: roughconductor with the eta + i k per
//                                             channel that gives the same F0 and is closest
//                                             elsewhere (grid over eta; kappa from F0)
//   plastic                                   exact up to F_int: plastic, the base albedo set so
//                                             that the internal bounces match ours (ours is
//                                             exact, Mitsuba's a fit: 0.1 % apart at n 1.5)
//   mirror                                    nearest: conductor (smooth), the eta + i k per
//                                             channel that keeps F0 and is closest to
//                                             Schlick's curve over the cosines
//   coated-{beckmann,ggx}                     nearest: roughplastic; the coat is exact, the
//                                             base differs (rough-coat transmittance and
//                                             internal reflectance, rough_plastic.h); the
//                                             base albedo is set so that the internal
//                                             bounces 1/(1 - rd F_int) match ours, times
//                                             the least-squares scale of Mitsuba's
//                                             t(mu_i) t(mu_o) onto our (1 - F)(1 - F)
//   cook_torrance, V-cavity G                 nearest: same D and F, Smith G
//   cook_torrance-...-schlick                 nearest: exact Fresnel of the same ior
//   cook_torrance-blinn-*                     nearest: Beckmann with alpha = m
//                                             (equal for small m)
//   oren_nayar, phong, blinn_phong,           nearest: rd, rs >= 0 per channel and
//   cosine_lobe, lafortune-*                  alpha, distribution fitted by least squares
//                                             on DirectionPairs (grid over alpha,
//                                             exact 2-variable NNLS per channel)
// `error` is the relative RMSE of the form (as Mitsuba evaluates it) against
// the model on DirectionPairs::Standard() (radiance under unit irradiance),
// so 0 for exact mappings.
#pragma once
#include <string>

#include "export/directions.h"
#include "export/rough_plastic.h"
#include "io/material.h"

namespace svbrdf {

struct NearestForm {
  enum class Lobe { kNone, kRoughConductor, kRoughPlastic, kPlastic, kConductor };
  Rgb rd = Rgb::Zero();                   // diffuse part (Mitsuba: diffuse reflectance)
  Lobe lobe = Lobe::kNone;
  Distribution distribution = Distribution::kBeckmann;  // Beckmann or GGX only
  double alpha = 0.1;                     // Mitsuba: alpha
  // roughconductor
  Rgb rs = Rgb::Zero();                   // Mitsuba: specular_reflectance
  bool fresnel = false;                   // true: eta + i k; false: material "none" (F = 1)
  Rgb eta = Rgb::Constant(1.5), k = Rgb::Zero();
  // roughplastic
  // diffuse_reflectance for unit weight: d with d / (1 - d F_int) (Mitsuba's
  // F_int) = base_scale rd / (1 - rd F_int) (ours), so the base's internal
  // bounces match (BaseForCoupling), up to base_scale (see above).
  Rgb base = Rgb::Zero();
  double base_scale = 1;
  double ior = 1.5;                       // Mitsuba: int_ior (ext_ior = 1)
  RoughPlastic plastic;                   // Mitsuba's transmittance table and F_int for alpha, ior
  // plastic (smooth): `base` and `ior` as above; Mitsuba's F_int of the flat coat
  double smooth_internal_reflectance = 0;

  bool exact = false;
  std::string how;                        // one line: how the mapping was made
  double error = 0;                       // relative RMSE against the model (see above)
  double max_fresnel_error = 0;           // conductors from Schlick/F82: max |F_form - F_ours| over angles and channels

  bool has_lobe() const { return lobe != Lobe::kNone; }
  // The form as one of our models, for `relight` of the export's as_rendered/:
  // lambert, cook_torrance-*-smith[-nofresnel] (dielectric or no Fresnel),
  // conductor-* (conductor lobe, no diffuse part) or coated-* (roughplastic;
  // ours, which differs from Mitsuba's base term as described above).
  BasisMaterial AsBasis(const std::string& name) const;
  // The BRDF value as Mitsuba 3 evaluates the form (1/sr; zero below the horizon).
  Rgb Eval(const Vec3& wi, const Vec3& wo) const;
};

NearestForm MapToNearestForm(const BasisMaterial& basis, const DirectionPairs& d);

// A basis material's parameter by its Params() name (colours: name_r, _g, _b);
// throws naming the material and the parameter when it has none.
double BasisParam(const BasisMaterial& b, const std::string& name);
Rgb BasisParamRgb(const BasisMaterial& b, const std::string& name);

// The Mitsuba diffuse_reflectance d whose nonlinear coupling d / (1 - d f_int)
// equals g (>= 0): d = g / (1 + g f_int).
inline double BaseForCoupling(double g, double f_int) { return g / (1 + g * f_int); }

}  // namespace svbrdf
