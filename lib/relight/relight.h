// The relighting renderer used for validation and for synthetic captures:
// direct illumination from one light per image (point, camera-frame flash,
// directional, spot, goniometric) with hard shadows, per-texel SVBRDF from a
// material folder, exposure, stratified supersampling; multithreaded over rows.
//
// Pixel value = exposure * radiance, radiance = f(wi, wo) * E_n * <n|wi>, where
// E_n is the light's irradiance on a surface facing it (lib/light). By default
// no interreflection (direct light only), as the reconstruction assumes;
// `bounces` > 0 adds indirect light by path tracing (for synthetic captures
// that measure robustness to interreflection).
#pragma once
#include <functional>
#include <string>

#include "core/rng.h"
#include "light/envmap.h"

#include "io/material.h"
#include "io/scene.h"
#include "raytrace/raytracer.h"
#include "relight/shader.h"

namespace svbrdf {

struct RelightOptions {
  int samples_per_pixel = 1;  // 1 = the pixel centre; n>1: n x n stratified jittered samples per pixel
  int threads = 0;            // 0 = all cores
  uint64_t seed = 1;          // jitter of supersampling
  // Adaptive supersampling (needs samples_per_pixel > 1): each pixel gets
  // rounds of n x n stratified samples until the standard error of its
  // sRGB-encoded value (from the spread of the round means, every channel)
  // is at most `adaptive_tolerance`, or `adaptive_max_rounds` rounds are
  // spent; at least 2 rounds to measure the spread. 0 = fixed: one round.
  // Pixels that integrate sub-pixel edges, occlusions and normals turning
  // within the pixel (a scanned mesh's) need many samples to match photos
  // whose pixels integrate their area; flat interiors need few.
  int adaptive_max_rounds = 0;
  double adaptive_tolerance = 0.001;  // sRGB units (1 = white): noise of a 60 dB PSNR
  bool png_preview = false;   // also write <file>.preview.png (sRGB, 8 bit)
  bool progress = true;
  // Indirect light: paths of up to `bounces` surface bounces after the first
  // hit, `bounce_samples` paths per camera sample, directions drawn from the
  // cosine-weighted hemisphere around the shading normal (estimate
  // f pi L per step), direct light with a shadow ray at every vertex,
  // Russian roulette from the second bounce on (survival = the path's largest
  // throughput, at most 1). Deterministic for `seed`. 0 = direct light only.
  int bounces = 0;
  int bounce_samples = 4;
  // Environment lighting (RenderViewEnvironment) instead of each entry's light:
  std::string envmap;          // lat-long HDR image (EXR/HDR); empty = use the scene's lights
  double envmap_scale = 1.0;   // multiplies the map's radiances
  int env_samples = 64;        // per pixel sample: this many environment + as many cosine samples
  void Check() const;
  // What `relight` and `evaluate` use by default, and the reconstruction
  // report too, so that one view gets one number: a photo's pixel is the
  // integral over its area (cameras, Mitsuba, synth), so the pixel is
  // integrated (8 x 8 jittered samples per round, up to 16 adaptive rounds).
  static RelightOptions PixelIntegrating();
  // One line saying how pixels are sampled (for reports).
  std::string SamplingDescription() const;
};

struct RenderedView {
  Image color;  // 3 channels, linear, exposure applied
  Image mask;   // 1 channel, 1 where the pixel centre sees the object
};

// Renders image entry `index` of `scene` (its camera, pose, light, exposure).
RenderedView RenderView(const RayTracer& tracer, const MaterialShader& shader, const Scene& scene, size_t index,
                        const RelightOptions& options);

// Renders image entry `index` (camera, pose, exposure) lit by the environment
// instead of the entry's light: direct light with shadows, estimated per
// pixel sample by multiple importance sampling (balance heuristic) of
// options.env_samples directions from the environment's luminance sampler
// and as many cosine-weighted directions about the shading normal, each
// with a shadow ray (lib/raytrace). Deterministic for options.seed
// (per-row random streams), multithreaded over rows.
RenderedView RenderViewEnvironment(const RayTracer& tracer, const MaterialShader& shader, const Scene& scene,
                                   size_t index, const EnvironmentMap& env, const RelightOptions& options);

// The pixel loop shared by both: radiance(px, py, rng, &hit) per (sub)pixel
// sample at continuous pixel coordinates; exposure, supersampling and mask.
using PixelRadiance = std::function<Rgb(double px, double py, Rng& rng, bool* hit)>;
RenderedView RenderPixels(const Camera& cam, const ImageEntry& entry, size_t index, const RelightOptions& options,
                          const PixelRadiance& radiance);

// The relighting contract: renders every image entry into out_dir/<entry.file>
// (format from its extension; integer formats encoded per the scene's
// images_color_space) and its mask into out_dir/<entry.mask> (or
// <file stem>.mask.png when the entry has none). Returns the number of images.
int RelightScene(const Material& material, const Scene& scene, const std::string& out_dir,
                 const RelightOptions& options);

// Writes a rendered colour image with the pixel format its extension implies.
void WriteRendered(const std::string& path, const Image& color, ColorSpace integer_space);

}  // namespace svbrdf
