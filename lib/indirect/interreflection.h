// Interreflection removed from gathered samples before the fits.
//
// The fits (lib/cluster) model direct light only: y = f(wi, wo) geom
// (gather/samples.h). On a concave object every photo also holds light that
// other parts of the object reflected onto the texel; fitted as direct
// light it brightens the albedo where the surface sees itself, and the split
// search takes the concavities for a material of their own. This stage
// estimates that light and subtracts it, to first order (the usual
// "inverse global illumination" step, e.g. Yu et al., SIGGRAPH 1999):
//
//   1. per texel, a Lambertian albedo rho_t (median over its samples of
//      pi y / geom; the object's median where a texel has none);
//   2. per sample, the indirect irradiance e at the texel under the
//      sample's light, path traced over the mesh with that Lambertian
//      material (LightPaths::Indirect: cosine-weighted paths, `bounces`
//      surface bounces, shadow rays), in the sample's units (y's);
//   3. rho_t estimated again as the median of pi y / (geom + e), and the
//      indirect radiance rho_t / pi * e subtracted from y (kept >= 0).
//
// The albedo that traces step 2 is itself the unknown: steps 2-3 run twice
// (with the raw samples' albedo, then with the first result) and the fixed
// point per texel is taken on the secant between the two passes.
//
// Convex shapes see nothing of themselves: e = 0 and the samples are
// unchanged. The material then describes direct reflection, so renders of
// it need the same indirect light: the material records the bounces
// (`svbrdf relight` uses them unless --bounces is given).
#pragma once
#include <cstdint>
#include <string>

#include <vector>

#include "gather/gather.h"
#include "io/material.h"
#include "io/scene.h"

namespace svbrdf {

// Options (reconstruct --interreflection-*):
//   bounces   surface bounces of the indirect light (0 = off)          [0, 8]
//   paths     paths per sample (noise of e, zero mean)                 [1, 256]
//   seed      random streams (per sample: deterministic)
//   threads   0 = all cores
//   refit     a second pass with fitted materials (see below; the
//             pipeline runs it between the split search and the final fits)
//   refit_paths     paths per sample of that pass                   [1, 256]
struct InterreflectionOptions {
  int bounces = 2;
  int paths = 8;
  bool refit = true;
  int refit_paths = 16;
  uint64_t seed = 1;
  int threads = 0;
  bool progress = true;
  void Check() const;
};

struct InterreflectionReport {
  int bounces = 0;
  int64_t samples = 0;
  double removed_share = 0;      // sum of removed over sum of y (all channels)
  double samples_over_5pc = 0;   // share of samples that lost more than 5 % of their value
  double max_share = 0;          // largest share removed from one sample
  // Per texel: whether it sees some part of the object (traced when
  // bounces > 0; the second pass reuses it).
  std::vector<char> sees_object;
  std::string Summary() const;
};

// Subtracts the estimated indirect light from g->samples (see above). The
// scene gives each sample's camera pose and light.
InterreflectionReport RemoveInterreflection(const Scene& scene, GatherResult* g, const InterreflectionOptions& o);

// The second pass. The Lambertian receiver above is right for diffuse
// texels; a glossy one (a metal inside a torus' ring) reflects mostly what
// lies about its mirror direction, a blurred image of the object that the
// first pass leaves in its samples, and a fit then gives those texels a
// material of their own. With a fitted material, the indirect light of
// every sample is traced again: the texel's own BRDF (`material`'s weights
// at the texel, which must be on g's atlas) receives it, `material` shades
// every other point, directions from LightPaths' glossy mixture. Per sample
// and channel in y's units; zero on texels that see nothing of the object
// (`sees_object`: the first pass's InterreflectionReport::sees_object for
// g's atlas; null: traced here).
std::vector<Rgb> TraceIndirectWithMaterial(const Scene& scene, const GatherResult& g, const Material& material,
                                           const InterreflectionOptions& o,
                                           const std::vector<char>* sees_object = nullptr);

}  // namespace svbrdf
