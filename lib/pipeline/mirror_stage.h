// The mirror stage of `reconstruct` (after the normal refinement): a basis
// material that is a smooth conductor is recognised by what its mirror
// direction sees, and replaced by the `mirror` model (brdf/mirror.h).
//
// Why: under point and directional lights a polished metal reflects the
// lights towards the camera at single points only; its photos show the
// object itself, reflected. Every BRDF model fits that as (nearly) black,
// and relit views then miss the reflections. Here, for each sample of the
// material's texels, the radiance arriving from the mirror direction of the
// sample's viewer (about each of its footprint's normals) is traced with
// the estimate's materials (direct light at the point it meets, plus its
// indirect light; integrated over the sample's pixel footprint,
// MirrorOptions::lookup_rays), and the mirror's F0 per
// channel is the linear least-squares fit of y = (others' share) +
// w (F0 + (1 - F0)(1 - mu)^5) L on the training photos' samples. The mirror
// replaces the material when it predicts the held-out photos' samples
// better by the model choice's rule (lower RMSE by `parsimony` x the
// signal's RMS and by `model_min_z` standard errors, paired over texels).
// Only materials that reflect little of the light directly are tried
// (largest directional albedo below MirrorOptions::max_direct_albedo): a
// mirror reflects none.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "cluster/reconstruct.h"
#include "gather/gather.h"
#include "io/scene.h"

namespace svbrdf {

struct MirrorOptions {
  bool enabled = true;  // CLI --mirrors / --no-mirrors
  double max_direct_albedo = 0.1;
  int bounces = 1;  // indirect bounces of the light at the point the mirror sees
  int paths = 2;    // per traced mirror direction
  // n x n rays through each pixel of a sample's bilinear photo lookup, each
  // traced in its own mirror direction (the reflection integrated over the
  // footprint, as the photo's pixels integrate it); 0, the default: one
  // direction per pixel of the lookup, about its mean normal
  // (SampleSet::footprint). The two renderers disagree on which is right:
  // on a Mitsuba torus of polished aluminium (F0 about 0.93) 2 rays fitted
  // F0 0.89 against 0.82 with 0; on this project's own synthetic torus
  // (Reconstruct.PolishedMetalIsRecognisedByWhatItReflects, F0 0.9) more
  // rays push F0 up (0: 0.92, 1: 0.94, 2: 0.95, 4: 0.96) and the mirror
  // loses its test (docs/measurements.md, "Seeds 37-48").
  int lookup_rays = 0;
  void Check() const;
};

struct MirrorReport {
  std::vector<std::string> lines;  // one per tried material
  int replaced = 0;
};

// Fits mirrors to the materials of `est` (see above) on the samples of `g`;
// `eo` gives the held-out photos, the rule and the threads.
// `raw`: the samples before the interreflection stage removed the indirect
// light it traced with the search's materials (null: g's own): what a
// mirror reflects is that light, so the mirror is fitted and tested on
// them (a texel's y plus its mirror weight times what was removed).
MirrorReport FitMirrors(const Scene& scene, const GatherResult& g, const ReconstructOptions& eo,
                        const MirrorOptions& o, SvbrdfEstimate* est,
                        const std::array<std::vector<float>, 3>* raw = nullptr);

// The least-squares F0 of y = base + w (F0 + (1 - F0) s5) L over samples,
// per channel, clamped to [0, 1] (0 without signal): the F0 solve above.
double MirrorF0(const std::vector<double>& y, const std::vector<double>& base, const std::vector<double>& w,
                const std::vector<double>& s5, const std::vector<double>& l);

}  // namespace svbrdf
