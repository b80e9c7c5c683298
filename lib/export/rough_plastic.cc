#include "export/rough_plastic.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "brdf/fresnel.h"
#include "brdf/microfacet.h"
#include "brdf/rough_coat.h"

namespace svbrdf {
RoughPlastic RoughPlastic::Make(Distribution distribution, double alpha, double ior) {
  RoughPlastic p;
  p.distribution = distribution == Distribution::kGGX ? Distribution::kGGX : Distribution::kBeckmann;
  p.alpha = alpha;
  p.ior = ior;
  constexpr int kFacetNodes = 256;
  for (int j = 0; j < kTableSize; ++j) {
    const double mu = std::max(1e-6, double(j) / (kTableSize - 1));
    p.transmittance[j] = brdf::RoughCoatTransmittance(p.distribution, alpha, ior, mu, kFacetNodes);
  }
  p.internal_reflectance = brdf::RoughCoatInternalReflectance(p.distribution, alpha, ior, kFacetNodes);
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
