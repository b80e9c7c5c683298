// Fresnel reflectance of smooth dielectric and conductor interfaces.
//
//   c      cosine of the angle of incidence on the (micro)facet, <H|E>, in [0,1]
//   n      relative index of refraction n_t / n_i; > 1 when light arrives from
//          the optically thinner side (air -> material), < 1 from inside.
//   eta, kappa  complex index eta + i kappa of a conductor (air outside)
//   f0     reflectance at normal incidence, [0, 1]
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
template <class T> T FresnelSchlickF0(const T& c, const T& f0) {
  const T k = T(1) - c;
  const T k2 = k * k;
  return f0 + (T(1) - f0) * k2 * k2 * k;
}
template <class T> T FresnelSchlick(const T& c, const T& n) {
  const T r = (n - T(1)) / (n + T(1));
  return FresnelSchlickF0(c, r * r);
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


// ------------------------------------------------------------- conductors

// Exact unpolarised reflectance of a conductor with complex index
// eta + i kappa (air outside): |r_s|^2 and |r_p|^2 of the Fresnel equations
// with a complex refraction angle, written with real arithmetic
// (a^2 + b^2 = |eta_c^2 - sin^2|, a = Re sqrt(eta_c^2 - sin^2)):
//   Rs = (a^2+b^2 + c^2 - 2ac) / (a^2+b^2 + c^2 + 2ac)
//   Rp = Rs (c^2 (a^2+b^2) + s^4 - 2ac s^2) / (c^2 (a^2+b^2) + s^4 + 2ac s^2),  s^2 = 1 - c^2.
// kappa = 0 gives FresnelDielectric; c = 0 gives 1 (grazing). brdf_test checks
// it against the complex amplitudes and published optical constants (metals.h).
template <class T> T FresnelConductor(const T& c, const T& eta, const T& kappa) {
  const T c2 = c * c, s2 = T(1) - c2;
  const T t0 = eta * eta - kappa * kappa - s2;
  const T a2b2 = SafeSqrt(t0 * t0 + T(4) * eta * eta * kappa * kappa);
  const T a = SafeSqrt(T(0.5) * (a2b2 + t0));
  const T t1 = a2b2 + c2, t2 = T(2) * c * a;
  const T rs = (t1 - t2) / (t1 + t2);
  const T t3 = c2 * a2b2 + s2 * s2, t4 = t2 * s2;
  const T rp = rs * (t3 - t4) / (t3 + t4);
  return T(0.5) * (rs + rp);
}

// Normal-incidence reflectance of a conductor: ((eta-1)^2 + kappa^2) / ((eta+1)^2 + kappa^2).
template <class T> T ConductorF0(const T& eta, const T& kappa) {
  return ((eta - T(1)) * (eta - T(1)) + kappa * kappa) / ((eta + T(1)) * (eta + T(1)) + kappa * kappa);
}

// The kappa that gives normal-incidence reflectance f0 for a given eta (the
// inverse of ConductorF0 in kappa): kappa^2 = (f0 (eta+1)^2 - (eta-1)^2) / (1 - f0).
// 0 when f0 is below the dielectric value ((eta-1)/(eta+1))^2. Needs f0 < 1.
inline double ConductorKappaFromF0(double f0, double eta) {
  const double k2 = (f0 * (eta + 1) * (eta + 1) - (eta - 1) * (eta - 1)) / (1 - f0);
  return k2 > 0 ? std::sqrt(k2) : 0.0;
}

// F82-tint form (Hoffman 2019; Kutz et al. 2021, "Novel aspects of the Adobe
// Standard Material"): Schlick's curve minus a term a c (1-c)^6 that peaks
// near 82 deg (c = 1/7), with a chosen so that F(1/7) = tint * Schlick(1/7).
// tint = 1 is Schlick; tint < 1 gives the dip of real metals (aluminium)
// near grazing. Clamped at 0: for f0 near 0 and tint below about 0.5 the
// subtracted term would exceed Schlick's curve.
template <class T> T FresnelF82Tint(const T& c, const T& f0, const T& tint) {
  constexpr double kMu = 1.0 / 7.0;
  constexpr double kOneMinusMu5 = (1 - kMu) * (1 - kMu) * (1 - kMu) * (1 - kMu) * (1 - kMu);
  const T schlick82 = f0 + (T(1) - f0) * kOneMinusMu5;
  const T a = schlick82 * (T(1) - tint) / (kMu * kOneMinusMu5 * (1 - kMu));
  const T k = T(1) - c;
  const T k3 = k * k * k;
  return Max(FresnelSchlickF0(c, f0) - a * c * k3 * k3, T(0));
}

// The F82 tint that makes FresnelF82Tint match a conductor at 82 deg.
inline double ConductorF82Tint(double eta, double kappa) {
  const double mu = 1.0 / 7.0;
  return FresnelConductor(mu, eta, kappa) / FresnelSchlickF0(mu, ConductorF0(eta, kappa));
}

// ------------------------------------------------ diffuse (hemispherical) Fresnel

// Cosine-weighted hemispherical average of FresnelDielectric for light from
// air onto a dielectric of index n > 1, int_0^1 2 mu F(mu, n) d mu, in closed
// form (the classical result quoted e.g. by d'Eon & Irving 2011 for the
// diffuse Fresnel reflectance; brdf_test checks it against quadrature).
template <class T> T DielectricDiffuseReflectance(const T& n) {
  using std::log;
  const T n2 = n * n, n4 = n2 * n2;
  const T n2p1 = n2 + T(1), n4m1 = n4 - T(1), n2m1 = n2 - T(1);
  return T(0.5) + (n - T(1)) * (T(3) * n + T(1)) / (T(6) * (n + T(1)) * (n + T(1))) +
         n2 * n2m1 * n2m1 / (n2p1 * n2p1 * n2p1) * log((n - T(1)) / (n + T(1))) -
         T(2) * n2 * n * (n2 + T(2) * n - T(1)) / (n2p1 * n4m1) +
         T(8) * n4 * (n4 + T(1)) / (n2p1 * n4m1 * n4m1) * log(n);
}

// The same average for diffuse light inside the dielectric hitting the
// boundary towards air (total internal reflection included): energy balance
// across the interface gives 1 - F_int = (1 - F_ext) / n^2.
template <class T> T DielectricInternalDiffuseReflectance(const T& n) {
  return T(1) - (T(1) - DielectricDiffuseReflectance(n)) / (n * n);
}

}  // namespace svbrdf::brdf
