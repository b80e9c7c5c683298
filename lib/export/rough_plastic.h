// Mitsuba 3's `roughplastic` BSDF, evaluated as Mitsuba evaluates it, so the
// export can state how far it is from our coated model (brdf/coated.h) and
// write the base albedo that reproduces ours.
//
//   f(wi, wo) = D(h) G1(wi) G1(wo) F_n(<h|wi>) / (4 <n|wi><n|wo>)                  coat (same as ours)
//             + rd t(<n|wi>) t(<n|wo>) / (pi n^2 (1 - rd F_int))                    base (nonlinear = true)
//
//   alpha, distribution  Beckmann RMS slope / GGX alpha, as our roughness m
//   n                    int_ior / ext_ior (we write ext_ior = 1)
//   t(mu)                transmittance of the rough coat for light arriving at
//                        cosine mu: the single-scattering integral over
//                        microfacet normals m seen from wi,
//                          t = int D(m) G1(wi, m) <wi|m> / mu (1 - F_n(<wi|m>)) G1(wt, m) dm,
//                        wt the refracted direction; Mitsuba tabulates it at
//                        64 cosines max(1e-6, j/63) and interpolates linearly.
//   F_int                internal reflectance: the same integral for reflection
//                        from inside (index 1/n, total internal reflection
//                        included), averaged as Mitsuba does:
//                          F_int = 2 mean_j (R_int(mu_j) mu_j) over the same 64 cosines.
//   nonlinear = false    replaces rd F_int by F_int in the denominator.
//
// Source: Mitsuba 3.9 roughplastic.cpp and microfacet.h (eval_transmittance,
// eval_reflectance), read for the definitions; the integrals are our own
// quadrature (brdf/rough_coat.h), which converges to the same values
// (scripts/check_mitsuba_export.py --plastic compares with Mitsuba's own
// BSDF evaluation).
//
// Our coated model (brdf/coated.h) is this BSDF with nonlinear = true: the
// same coat and base, its t and F_int interpolated from tables over
// (mu, alpha, n) instead of computed for one material.
#pragma once
#include <array>

#include "brdf/model.h"
#include "core/types.h"

namespace svbrdf {

struct RoughPlastic {
  static constexpr int kTableSize = 64;  // MI_ROUGH_TRANSMITTANCE_RES
  Distribution distribution = Distribution::kGGX;  // Beckmann or GGX
  double alpha = 0.1;
  double ior = 1.5;
  std::array<double, kTableSize> transmittance{};  // t(mu_j)
  double internal_reflectance = 0;                 // F_int

  // Precomputes the table and F_int (a few ms).
  static RoughPlastic Make(Distribution distribution, double alpha, double ior);

  double Transmittance(double mu) const;  // linear interpolation in the table, as Mitsuba
  // BRDF value (1/sr, no cosine) for base albedo rd per channel; zero below the horizon.
  Rgb Eval(const Rgb& rd, bool nonlinear, const Vec3& wi, const Vec3& wo) const;
};

}  // namespace svbrdf
