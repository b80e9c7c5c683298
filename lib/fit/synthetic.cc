#include "fit/synthetic.h"

#include <cmath>
#include <random>

#include "core/rng.h"

namespace svbrdf {
namespace {

// Uniform in solid angle, but not closer than ~3 degrees to the horizon where
// every model is ill-conditioned and real captures are unreliable.
Vec3 UniformHemisphere(Rng& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double z = 0.05 + 0.95 * u(rng), phi = 2 * kPi * u(rng), r = std::sqrt(1 - z * z);
  return Vec3(r * std::cos(phi), r * std::sin(phi), z);
}

}  // namespace

SampleSet SynthesizeSamples(const ModelSpec& spec, const std::vector<double>& params, const SynthOptions& o) {
  Rng rng(o.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  SampleSet set;
  set.num_texels = 1;
  set.texel_begin = {0, o.count};
  set.Reserve(o.count);
  for (int s = 0; s < o.count; ++s) {
    const Vec3 wi = UniformHemisphere(rng);
    Vec3 wo = UniformHemisphere(rng);
    if (s % 2 == 0) {
      const Vec3 mirror(-wi.x(), -wi.y(), wi.z());
      do {
        wo = (mirror + 0.25 * Vec3(gauss(rng), gauss(rng), gauss(rng))).normalized();
      } while (wo.z() < 0.05);
    }
    const float wif[3] = {float(wi.x()), float(wi.y()), float(wi.z())};
    const float wof[3] = {float(wo.x()), float(wo.y()), float(wo.z())};
    const float geom = wif[2];
    Rgb y = EvalModelD(spec, params.data(), Vec3(wif[0], wif[1], wif[2]), Vec3(wof[0], wof[1], wof[2])) * double(geom);
    if (o.noise > 0) y *= 1 + o.noise * gauss(rng);
    if (u(rng) < o.outlier_fraction) y = 3 * y + 0.3;
    const float yf[3] = {float(y[0]), float(y[1]), float(y[2])};
    set.Push(0, 0, wif, wof, geom, yf);
  }
  return set;
}

}  // namespace svbrdf
