#include "brdf/rough_coat.h"

#include <mutex>
#include <vector>

#include "brdf/fresnel.h"
#include "brdf/microfacet.h"
#include "core/parallel.h"
#include "core/types.h"

namespace svbrdf::brdf {
namespace {

Distribution Supported(Distribution d) { return d == Distribution::kGGX ? Distribution::kGGX : Distribution::kBeckmann; }

// Smith G1 with the facet orientation rule: 0 when v sees the back of the facet m.
double FacetG1(Distribution d, const Vec3& v, const Vec3& m, double alpha) {
  if (v.dot(m) * v.z() <= 0) return 0;
  return SmithG1(d, std::abs(v.z()), alpha);
}

// tan^2 of the facet angle at which the projected density D(m) <n|m> has CDF u.
double Tan2FromCdf(Distribution d, double u, double alpha) {
  return d == Distribution::kGGX ? alpha * alpha * u / (1 - u) : -alpha * alpha * std::log1p(-u);
}

// Facet normals of the quadrature (the same for every mu and n), with the
// weight du/ds; wi lies in the xz plane, so phi in [0, pi] suffices.
struct FacetNodes {
  std::vector<Vec3> m;
  std::vector<double> weight;
};
FacetNodes MakeFacetNodes(Distribution d, double alpha, int nu) {
  const int nphi = std::max(4, nu / 4);
  FacetNodes n;
  for (int iu = 0; iu < nu; ++iu) {
    const double s = (iu + 0.5) / nu, du_ds = 2 * (1 - s);
    const double tan2 = Tan2FromCdf(d, 1 - (1 - s) * (1 - s), alpha);
    const double cos_m = 1 / std::sqrt(1 + tan2), sin_m = std::sqrt(tan2) * cos_m;
    for (int ip = 0; ip < nphi; ++ip) {
      const double phi = kPi * (ip + 0.5) / nphi;
      n.m.emplace_back(sin_m * std::cos(phi), sin_m * std::sin(phi), cos_m);
      n.weight.push_back(du_ds / (double(nu) * nphi));
    }
  }
  return n;
}

// int D(m) G1(wi, m) <wi|m> / mu X(m) dm, X the Fresnel part of the
// scattered light times G1 of the outgoing direction: refracted (transmit)
// or reflected.
double FacetIntegral(const FacetNodes& nodes, Distribution d, double alpha, double n, double mu, bool transmit) {
  mu = std::max(mu, 1e-6);
  const Vec3 wi(std::sqrt(std::max(0.0, 1 - mu * mu)), 0, mu);
  double sum = 0;
  for (size_t i = 0; i < nodes.m.size(); ++i) {
    const Vec3& m = nodes.m[i];
    const double c = wi.dot(m);
    if (c <= 0) continue;
    const double g_in = FacetG1(d, wi, m, alpha);
    if (g_in <= 0) continue;
    const double f = FresnelDielectric(c, n);
    double x;
    if (transmit) {
      const double cos_t = std::sqrt(std::max(0.0, 1 - (1 - c * c) / (n * n)));
      const Vec3 wt = m * (c / n - cos_t) - wi / n;
      x = wt.z() < 0 ? (1 - f) * FacetG1(d, wt, m, alpha) : 0.0;
    } else {
      const Vec3 wr = 2 * c * m - wi;
      x = wr.z() > 0 ? f * FacetG1(d, wr, m, alpha) : 0.0;
    }
    sum += nodes.weight[i] * g_in * c / (mu * m.z()) * x;
  }
  return sum;
}

// Cosine average of the reflectance from inside, as Mitsuba's roughplastic
// computes it: 2 x the mean of R_int(mu_j) mu_j over the 64 cosines
// mu_j = max(1e-6, j / 63). That is the integral int_0^1 2 mu R_int dmu
// scaled by about 63/64 (plus a small end term); kept so that our model and
// the renderer that exports and independent captures use agree.
double InternalReflectance(const FacetNodes& nodes, Distribution d, double alpha, double n) {
  constexpr int kMuNodes = 64;
  double sum = 0;
  for (int j = 0; j < kMuNodes; ++j) {
    const double mu = std::max(1e-6, double(j) / (kMuNodes - 1));
    sum += 2 * mu * FacetIntegral(nodes, d, alpha, 1 / n, mu, false);
  }
  return sum / kMuNodes;
}

constexpr int kTableFacetNodes = 48;

RoughCoatTable* Build(Distribution d) {
  auto* tab = new RoughCoatTable;
  ParallelFor(RoughCoatTable::kAlpha, 0, [&](long ia) {
    const double alpha = RoughCoatTable::kAlphaMin *
                         std::pow(RoughCoatTable::kAlphaMax / RoughCoatTable::kAlphaMin, double(ia) / (RoughCoatTable::kAlpha - 1));
    const FacetNodes nodes = MakeFacetNodes(d, alpha, kTableFacetNodes);
    for (int in = 0; in < RoughCoatTable::kIor; ++in) {
      const double n = RoughCoatTable::kIorMin + (RoughCoatTable::kIorMax - RoughCoatTable::kIorMin) * in / (RoughCoatTable::kIor - 1);
      for (int im = 0; im < RoughCoatTable::kMu; ++im)
        tab->t[ia][in][im] = float(FacetIntegral(nodes, d, alpha, n, double(im) / (RoughCoatTable::kMu - 1), true));
      tab->f_int[ia][in] = float(InternalReflectance(nodes, d, alpha, n));
    }
  });
  return tab;
}

}  // namespace

double RoughCoatTransmittance(Distribution d, double alpha, double n, double mu, int facet_nodes) {
  d = Supported(d);
  return FacetIntegral(MakeFacetNodes(d, alpha, facet_nodes), d, alpha, n, mu, true);
}

double RoughCoatReflectance(Distribution d, double alpha, double n, double mu, int facet_nodes) {
  d = Supported(d);
  return FacetIntegral(MakeFacetNodes(d, alpha, facet_nodes), d, alpha, n, mu, false);
}

double RoughCoatInternalReflectance(Distribution d, double alpha, double n, int facet_nodes) {
  d = Supported(d);
  return InternalReflectance(MakeFacetNodes(d, alpha, facet_nodes), d, alpha, n);
}

const RoughCoatTable& RoughCoatTable::Get(Distribution d) {
  static std::once_flag once[2];
  static RoughCoatTable* tables[2] = {nullptr, nullptr};
  const int i = Supported(d) == Distribution::kGGX ? 1 : 0;
  std::call_once(once[i], [&] { tables[i] = Build(Supported(d)); });
  return *tables[i];
}

}  // namespace svbrdf::brdf
