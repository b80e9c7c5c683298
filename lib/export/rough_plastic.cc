#include "export/rough_plastic.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "brdf/fresnel.h"
#include "brdf/microfacet.h"

namespace svbrdf {
namespace {

// Smith G1 with Mitsuba's orientation rule: 0 when v sees the back of the facet m.
double G1(Distribution d, const Vec3& v, const Vec3& m, double alpha) {
  if (v.dot(m) * v.z() <= 0) return 0;
  return brdf::SmithG1(d, std::abs(v.z()), alpha);
}

// tan^2 of the facet angle at which the projected density D(m) <n|m> has CDF u.
double Tan2FromCdf(Distribution d, double u, double alpha) {
  return d == Distribution::kGGX ? alpha * alpha * u / (1 - u) : -alpha * alpha * std::log1p(-u);
}

// int D(m) G1(wi, m) <wi|m> / mu  X(m) dm over facet normals, X the Fresnel
// part of the scattered light times G1 of the outgoing direction: refracted
// (transmit, index n > 1) or reflected. Midpoint rule in phi and in s with
// u = 1 - (1 - s)^2 (u the CDF of D <n|m>; the substitution puts more nodes
// at grazing facets, where GGX's long tail converged slowly); wi lies in the
// xz plane, so phi in [0, pi] suffices.
// Facet normals of the quadrature (the same for every mu), with the weight du/ds.
struct FacetNodes {
  std::vector<Vec3> m;
  std::vector<double> weight;
};
FacetNodes MakeFacetNodes(Distribution d, double alpha) {
  constexpr int kU = 256, kPhi = 64;
  FacetNodes n;
  for (int iu = 0; iu < kU; ++iu) {
    const double s = (iu + 0.5) / kU, du_ds = 2 * (1 - s);
    const double tan2 = Tan2FromCdf(d, 1 - (1 - s) * (1 - s), alpha);
    const double cos_m = 1 / std::sqrt(1 + tan2), sin_m = std::sqrt(tan2) * cos_m;
    for (int ip = 0; ip < kPhi; ++ip) {
      const double phi = kPi * (ip + 0.5) / kPhi;
      n.m.emplace_back(sin_m * std::cos(phi), sin_m * std::sin(phi), cos_m);
      n.weight.push_back(du_ds / (kU * kPhi));
    }
  }
  return n;
}

double FacetIntegral(const FacetNodes& nodes, Distribution d, double alpha, double n, double mu, bool transmit) {
  const Vec3 wi(std::sqrt(std::max(0.0, 1 - mu * mu)), 0, mu);
  double sum = 0;
  for (size_t i = 0; i < nodes.m.size(); ++i) {
    const Vec3& m = nodes.m[i];
    const double c = wi.dot(m);
    if (c <= 0) continue;
    const double g_in = G1(d, wi, m, alpha);
    if (g_in <= 0) continue;
    const double f = brdf::FresnelDielectric(c, n);
    double x;
    if (transmit) {
      const double cos_t = std::sqrt(std::max(0.0, 1 - (1 - c * c) / (n * n)));
      const Vec3 wt = m * (c / n - cos_t) - wi / n;
      x = wt.z() < 0 ? (1 - f) * G1(d, wt, m, alpha) : 0.0;
    } else {
      const Vec3 wr = 2 * c * m - wi;
      x = wr.z() > 0 ? f * G1(d, wr, m, alpha) : 0.0;
    }
    sum += nodes.weight[i] * g_in * c / (mu * m.z()) * x;
  }
  return sum;
}

}  // namespace

RoughPlastic RoughPlastic::Make(Distribution distribution, double alpha, double ior) {
  RoughPlastic p;
  p.distribution = distribution == Distribution::kGGX ? Distribution::kGGX : Distribution::kBeckmann;
  p.alpha = alpha;
  p.ior = ior;
  const FacetNodes nodes = MakeFacetNodes(p.distribution, alpha);
  double internal = 0;
  for (int j = 0; j < kTableSize; ++j) {
    const double mu = std::max(1e-6, double(j) / (kTableSize - 1));
    p.transmittance[j] = FacetIntegral(nodes, p.distribution, alpha, ior, mu, true);
    internal += FacetIntegral(nodes, p.distribution, alpha, 1 / ior, mu, false) * mu;
  }
  p.internal_reflectance = 2 * internal / kTableSize;
  return p;
}

double RoughPlastic::Transmittance(double mu) const {
  const double x = std::clamp(mu, 0.0, 1.0) * (kTableSize - 1);
  const int i = std::min(int(x), kTableSize - 2);
  return transmittance[i] + (x - i) * (transmittance[i + 1] - transmittance[i]);
}

Rgb RoughPlastic::Eval(const Rgb& rd, bool nonlinear, const Vec3& wi, const Vec3& wo) const {
  if (wi.z() <= 0 || wo.z() <= 0) return Rgb::Zero();
  const Vec3 h = (wi + wo).normalized();
  const double coat = brdf::SmithMicrofacet(distribution, wi, wo, h, alpha) * brdf::FresnelDielectric(h.dot(wi), ior);
  const double through = Transmittance(wi.z()) * Transmittance(wo.z()) / (kPi * ior * ior);
  Rgb f;
  for (int c = 0; c < 3; ++c)
    f[c] = coat + rd[c] * through / (1 - (nonlinear ? rd[c] : 1.0) * internal_reflectance);
  return f;
}

}  // namespace svbrdf
