// Fresnel reflectance of a smooth dielectric interface.
//
//   c  cosine of the angle of incidence on the (micro)facet, <H|E>, in [0,1]
//   n  relative index of refraction n_t / n_i; > 1 when light arrives from
//      the optically thinner side (air -> material), < 1 from inside.
#pragma once
#include "brdf/common.h"

namespace svbrdf::brdf {

// Exact unpolarised reflectance, Cook & Torrance 1982:
//   F = (g-c)^2 / (2 (g+c)^2) * (1 + (c(g+c)-1)^2 / (c(g-c)+1)^2),
//   g^2 = n^2 + c^2 - 1.
// The lecture prints (c(g+c)+1)^2 in the last denominator; that is a typo:
// only (c(g-c)+1)^2 equals 1/2 (sin^2(ti-tt)/sin^2(ti+tt) + tan^2(ti-tt)/tan^2(ti+tt)),
// which brdf_test checks against the s/p amplitudes below.
// g^2 < 0 means total internal reflection (only possible for n < 1): F = 1.
template <class T> T FresnelDielectric(const T& c, const T& n) {
  const T g2 = n * n + c * c - T(1);
  if (g2 < T(0)) return T(1);
  const T g = SafeSqrt(g2);
  const T a = (g - c) / (g + c);
  const T b = (c * (g + c) - T(1)) / (c * (g - c) + T(1));
  return T(0.5) * a * a * (T(1) + b * b);
}

// Schlick 1994: F0 + (1 - F0)(1 - c)^5 with F0 = ((n-1)/(n+1))^2, the exact
// value at normal incidence. Ignores total internal reflection.
template <class T> T FresnelSchlick(const T& c, const T& n) {
  const T r = (n - T(1)) / (n + T(1));
  const T f0 = r * r;
  const T k = T(1) - c;
  const T k2 = k * k;
  return f0 + (T(1) - f0) * k2 * k2 * k;
}

// Reflected amplitudes of the electric field (Fresnel equations) for given
// incidence / transmission cosines (from Snell) and indices n_i, n_t:
//   r_perp = (n_i cos_i - n_t cos_t) / (n_i cos_i + n_t cos_t)   (s-polarised)
//   r_par  = (n_t cos_i - n_i cos_t) / (n_t cos_i + n_i cos_t)   (p-polarised)
// The lecture prints r_par with the same expression as r_perp (typo; the
// indices swap for p-polarised light). The reflected intensity is |r|^2, and
// unpolarised F = (r_perp^2 + r_par^2) / 2.
template <class T> struct FresnelAmplitudes {
  T r_perp, r_par;
};
template <class T>
FresnelAmplitudes<T> FresnelReflectedAmplitudes(const T& cos_i, const T& cos_t, const T& n_i, const T& n_t) {
  return {(n_i * cos_i - n_t * cos_t) / (n_i * cos_i + n_t * cos_t),
          (n_t * cos_i - n_i * cos_t) / (n_t * cos_i + n_i * cos_t)};
}

}  // namespace svbrdf::brdf
