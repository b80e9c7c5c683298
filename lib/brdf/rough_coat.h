// Light through a rough dielectric coat (the base term of coated.h and of
// Mitsuba 3's `roughplastic`).
//
//   t(mu; alpha, n)   transmittance of the rough coat for light arriving at
//                     cosine mu: the single-scattering integral over facet
//                     normals m seen from wi,
//                       t = int D(m) G1(wi, m) <wi|m> / mu (1 - F_n(<wi|m>)) G1(wt, m) dm,
//                     wt the refracted direction (Walter et al. 2007's
//                     microfacet transmission, integrated over wt).
//   F_int(alpha, n)   internal diffuse reflectance: the same integral for
//                     reflection from inside (index 1/n, total internal
//                     reflection included), cosine-averaged over directions
//                     as Mitsuba averages it: 2 x the mean of R_int(mu_j) mu_j
//                     over mu_j = j / 63, j = 0..63 (about 63/64 of
//                     int_0^1 2 mu R_int dmu).
//
//   alpha  Beckmann RMS slope or GGX alpha      [0.01, 1]
//   n      index of refraction of the coat      [1.1, 2.5]
//   mu     cosine of the direction to the normal [0, 1]
//
// A smooth coat transmits 1 - F_n(mu); a rough one transmits more at
// grazing angles (facets tilted towards the light), e.g. 1.8x at 85 degrees
// for Beckmann alpha 0.31, n 1.37. Mitsuba tabulates t per material at 64
// cosines (roughplastic.cpp, MI_ROUGH_TRANSMITTANCE_RES, read for the
// definitions); here t and F_int are tabulated once per distribution over
// (mu, log alpha, n) and interpolated (tri-/bilinearly, so Ceres Jets flow
// through alpha, n and mu). The quadrature: midpoint rule in phi and in s
// with u = 1 - (1 - s)^2, u the CDF of D <n|m> (nodes dense at grazing
// facets, where GGX's tail converges slowly).
#pragma once
#include <algorithm>
#include <cmath>

#include "brdf/model.h"

namespace svbrdf::brdf {

// The integrals themselves (quadrature with `facet_nodes` x `facet_nodes / 4`
// facet normals); what the tables hold, and what tests check them against.
double RoughCoatTransmittance(Distribution d, double alpha, double n, double mu, int facet_nodes = 128);
// Reflectance of the interface for light arriving at cosine mu (n < 1: from
// inside, total internal reflection included).
double RoughCoatReflectance(Distribution d, double alpha, double n, double mu, int facet_nodes = 128);
double RoughCoatInternalReflectance(Distribution d, double alpha, double n, int facet_nodes = 128);

// The tables: built on first use (all threads; a fraction of a second) and
// shared, read-only, by every thread afterwards.
struct RoughCoatTable {
  static constexpr int kMu = 33, kAlpha = 24, kIor = 15;
  static constexpr double kAlphaMin = 0.01, kAlphaMax = 1.0, kIorMin = 1.1, kIorMax = 2.5;
  float t[kAlpha][kIor][kMu];
  float f_int[kAlpha][kIor];
  static const RoughCoatTable& Get(Distribution d);  // Beckmann or GGX (others: Beckmann)
};

namespace rough_coat_detail {
inline double Scalar(double x) { return x; }
template <class T> double Scalar(const T& x) { return x.a; }  // ceres::Jet

// Cell index and fraction of x on a uniform grid of `count` nodes over [0, 1] (x clamped).
template <class T> int Cell(const T& x, int count, T* frac) {
  const double s = std::fmin(std::fmax(Scalar(x), 0.0), 1.0) * (count - 1);
  const int i = std::min(int(s), count - 2);
  *frac = Scalar(x) <= 0 ? T(0) : (Scalar(x) >= 1 ? T(1) : x * T(count - 1) - T(double(i)));
  return i;
}
template <class T> T AlphaCoordinate(const T& alpha) {
  using std::log;
  return log(alpha / T(RoughCoatTable::kAlphaMin)) / std::log(RoughCoatTable::kAlphaMax / RoughCoatTable::kAlphaMin);
}
template <class T> T IorCoordinate(const T& n) {
  return (n - T(RoughCoatTable::kIorMin)) / T(RoughCoatTable::kIorMax - RoughCoatTable::kIorMin);
}
}  // namespace rough_coat_detail

// One coat's entries in the tables: the four (alpha, n) nodes around it with
// their interpolation weights, found once per parameter set
// (Coated::Prepare): its internal reflectance F_int, and its t(mu)
// interpolated in mu for every direction.
template <class T> struct RoughCoat {
  const float* row[4] = {nullptr, nullptr, nullptr, nullptr};  // t over mu at the four nodes
  T weight[4];
  T f_int = T(0);
  RoughCoat() = default;
  RoughCoat(Distribution d, const T& alpha, const T& n) {
    using namespace rough_coat_detail;
    const RoughCoatTable& tab = RoughCoatTable::Get(d);
    T fa, fn;
    const int ia = Cell(AlphaCoordinate(alpha), RoughCoatTable::kAlpha, &fa);
    const int in = Cell(IorCoordinate(n), RoughCoatTable::kIor, &fn);
    row[0] = tab.t[ia][in], row[1] = tab.t[ia][in + 1], row[2] = tab.t[ia + 1][in], row[3] = tab.t[ia + 1][in + 1];
    weight[0] = (T(1) - fa) * (T(1) - fn), weight[1] = (T(1) - fa) * fn;
    weight[2] = fa * (T(1) - fn), weight[3] = fa * fn;
    const T lo = T(double(tab.f_int[ia][in])) * (T(1) - fn) + T(double(tab.f_int[ia][in + 1])) * fn;
    const T hi = T(double(tab.f_int[ia + 1][in])) * (T(1) - fn) + T(double(tab.f_int[ia + 1][in + 1])) * fn;
    f_int = lo * (T(1) - fa) + hi * fa;
  }
  T Transmittance(const T& mu) const {
    T fm;
    const int im = rough_coat_detail::Cell(mu, RoughCoatTable::kMu, &fm);
    T sum = T(0);
    for (int k = 0; k < 4; ++k)
      sum += weight[k] * (T(double(row[k][im])) * (T(1) - fm) + T(double(row[k][im + 1])) * fm);
    return sum;
  }
};

template <class T> T CoatTransmittance(Distribution d, const T& mu, const T& alpha, const T& n) {
  return RoughCoat<T>(d, alpha, n).Transmittance(mu);
}

template <class T> T CoatInternalReflectance(Distribution d, const T& alpha, const T& n) {
  return RoughCoat<T>(d, alpha, n).f_int;
}

}  // namespace svbrdf::brdf
