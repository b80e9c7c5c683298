#include "export/directions.h"

#include <cmath>

namespace svbrdf {

DirectionPairs DirectionPairs::Standard(int theta_steps, int phi_steps) {
  DirectionPairs d;
  // Viewing elevations by the midpoint rule on [0, 90) degrees, weighted by
  // cos(theta_o) sin(theta_o) d(theta_o): views count as often as they cover
  // pixels of a convex object (projected area), so grazing views, where
  // microfacet and cosine lobes differ most, do not dominate fits.
  const int elevations = 5;
  const double azimuths_deg[] = {0, 90};
  double view_sum = 0;
  for (int ie = 0; ie < elevations; ++ie) {
    const double te = 0.5 * kPi * (ie + 0.5) / elevations;
    view_sum += 2 * std::cos(te) * std::sin(te);
  }
  for (int ie = 0; ie < elevations; ++ie)
    for (double az : azimuths_deg) {
      const double te = 0.5 * kPi * (ie + 0.5) / elevations, pe = az * kPi / 180;
      const double view_weight = std::cos(te) * std::sin(te) / view_sum;
      const Vec3 wo(std::sin(te) * std::cos(pe), std::sin(te) * std::sin(pe), std::cos(te));
      for (int it = 0; it < theta_steps; ++it) {
        const double t = (it + 0.5) / theta_steps;
        const double th = 0.5 * kPi * t * t;
        const double dth = kPi * t / theta_steps;  // d(theta_h)/dt * dt
        for (int ip = 0; ip < phi_steps; ++ip) {
          const double ph = 2 * kPi * (ip + 0.5) / phi_steps;
          const Vec3 h(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
          const double oh = wo.dot(h);
          if (oh <= 0) continue;
          const Vec3 wi = 2 * oh * h - wo;
          if (wi.z() <= 1e-3) continue;
          const double dwh = std::sin(th) * dth * (2 * kPi / phi_steps);
          d.wi.push_back(wi);
          d.wo.push_back(wo);
          d.weight.push_back(4 * oh * dwh * view_weight);
        }
      }
    }
  return d;
}

std::vector<double> BrdfFeatures(const ModelSpec& spec, const std::vector<double>& params, const DirectionPairs& d) {
  std::vector<double> out(3 * d.size());
  for (size_t j = 0; j < d.size(); ++j) {
    const Rgb f = EvalModelD(spec, params.data(), d.wi[j], d.wo[j]);
    const double s = std::sqrt(d.weight[j]) * d.wi[j].z();
    for (int c = 0; c < 3; ++c) out[3 * j + c] = s * f[c];
  }
  return out;
}

double RelativeFeatureError(const std::vector<double>& a, const std::vector<double>& b) {
  double num = 0, den = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    num += (a[i] - b[i]) * (a[i] - b[i]);
    den += a[i] * a[i];
  }
  return den > 0 ? std::sqrt(num / den) : 0.0;
}

}  // namespace svbrdf
