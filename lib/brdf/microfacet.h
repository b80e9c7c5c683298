// Microfacet normal distributions p(H) and shadowing/masking terms G for the
// Cook-Torrance model. Directions live in the local frame (N = z).
//
//   m   roughness: RMS slope (Beckmann), angular width in radians (Blinn
//       Gaussian), or GGX alpha                              [0.01, 1]
//
// p(H) follows the lecture's convention, in which the BRDF carries an extra
// 1/pi: D = p(H)/pi is the normalised density, int D <N|H> dH = 1.
#pragma once
#include "brdf/common.h"
#include "brdf/model.h"

namespace svbrdf::brdf {

// Beckmann (Torrance-Sparrow 1967): p = 1/(m^2 cos^4 a) exp(-tan^2 a / m^2),
// a = angle between H and N. p/pi is exactly normalised.
template <class T> T BeckmannP(const T& cos_a, const T& m) {
  using std::exp;
  const T c2 = cos_a * cos_a;
  const T m2 = m * m;
  const T tan2 = (T(1) - c2) / c2;
  return exp(-tan2 / m2) / (m2 * c2 * c2);
}

// Blinn 1977 Gaussian: p = c exp(-(a/m)^2) with c = 1/m^2. With this c, p/pi
// is normalised only in the small-m limit (int ~ 2/m^2 int a exp(-a^2/m^2) da
// = 1, using sin a cos a ~ a); for larger m the integral is below 1.
template <class T> T BlinnGaussianP(const T& cos_a, const T& m) {
  using std::atan2;
  using std::exp;
  const T a = atan2(SafeSqrt(T(1) - cos_a * cos_a), cos_a);  // acos without acos'(1) = inf
  const T t = a / m;
  return exp(-t * t) / (m * m);
}

// GGX / Trowbridge-Reitz in the same convention: p = m^2 / (cos^2 a (m^2-1) + 1)^2,
// so p/pi is the normalised GGX density with alpha = m.
template <class T> T GgxP(const T& cos_a, const T& m) {
  const T m2 = m * m;
  const T d = cos_a * cos_a * (m2 - T(1)) + T(1);
  return m2 / (d * d);
}

// V-cavity geometry term (Torrance-Sparrow, lecture): G = min(1, Gm, Gs) with
// masking Gm = 2<N|H><N|E>/<E|H> and shadowing Gs = 2<N|H><N|L>/<E|H>
// (<E|H> = <L|H> by definition of H).
template <class T> T VCavityG(const Vec3T<T>& wi, const Vec3T<T>& wo, const Vec3T<T>& h) {
  const T k = T(2) * h.z() / Dot(wo, h);
  return Min(T(1), Min(k * wo.z(), k * wi.z()));
}

// Smith masking for one direction with Beckmann slopes: the rational
// approximation (Walter et al. 2007) of the exact 2 / (1 + erf(a) + exp(-a^2)/(a sqrt(pi))),
// a = 1/(m tan theta): G1 = (3.535a + 2.181a^2)/(1 + 2.276a + 2.577a^2) for
// a < 1.6, else 1 (avoids erf, which Jet lacks). Also used for the Blinn
// Gaussian, whose slopes match Beckmann's for small m.
template <class T> T SmithG1Beckmann(const T& cos_t, const T& m) {
  const T sin_t = SafeSqrt(T(1) - cos_t * cos_t);
  if (!(T(1.6) * m * sin_t > cos_t)) return T(1);  // a >= 1.6, including normal incidence
  const T a = cos_t / (m * sin_t);
  return (T(3.535) * a + T(2.181) * a * a) / (T(1) + T(2.276) * a + T(2.577) * a * a);
}

// Smith masking for GGX (exact): G1 = 2 / (1 + sqrt(1 + m^2 tan^2 theta)).
template <class T> T SmithG1Ggx(const T& cos_t, const T& m) {
  using std::sqrt;
  const T c2 = cos_t * cos_t;
  return T(2) / (T(1) + sqrt(T(1) + m * m * (T(1) - c2) / c2));
}

// p(H) of the chosen distribution.
template <class T> T MicrofacetP(Distribution d, const T& cos_h, const T& m) {
  switch (d) {
    case Distribution::kBlinnGaussian: return BlinnGaussianP(cos_h, m);
    case Distribution::kGGX: return GgxP(cos_h, m);
    case Distribution::kBeckmann: break;
  }
  return BeckmannP(cos_h, m);
}

// Smith masking G1 of the chosen distribution (Beckmann's for the Blinn Gaussian).
template <class T> T SmithG1(Distribution d, const T& cos_t, const T& m) {
  return d == Distribution::kGGX ? SmithG1Ggx(cos_t, m) : SmithG1Beckmann(cos_t, m);
}

// The microfacet reflection without Fresnel, p(H)/pi G1(L) G1(E) / (4 <N|L><N|E>)
// (a normalised density times Smith shadowing), for a Fresnel factor evaluated
// at <H|E> by the caller: the specular part of conductors and coats.
template <class T> T SmithMicrofacet(Distribution d, const Vec3T<T>& wi, const Vec3T<T>& wo, const Vec3T<T>& h,
                                     const T& m) {
  return MicrofacetP(d, h.z(), m) * SmithG1(d, wi.z(), m) * SmithG1(d, wo.z(), m) / (T(4 * kPi) * wi.z() * wo.z());
}

}  // namespace svbrdf::brdf
