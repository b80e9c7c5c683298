// Per-texel sample gathering: for every texel of the atlas and every photo,
// decide whether the photo measures that texel's BRDF, and if so store the
// sample (directions in the texel's local frame, measured radiance per unit
// light, geometry factor). A sample is kept only when the texel is
//   inside the image (away from its border), facing the camera at more than
//   the grazing limit, visible from the camera (Embree occlusion ray),
//   inside the mask (all four pixels of the bilinear footprint), lit (facing
//   the light at more than the grazing limit, not shadowed: occlusion ray),
//   valid (every channel of the footprint finite and >= 0: NaN/Inf or
//   negative values, as a broken HDR merge writes them, are rejected and
//   counted, never passed to a fit), and not saturated (no channel of the
//   footprint at the file's maximum).
// A capture without signal (fewer than `min_signal_fraction` of the kept
// samples above `noise_floor`: lights off, lens cap, far too short an
// exposure, masks on the background) is an error saying what to check.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include "atlas/atlas.h"
#include "gather/samples.h"
#include "io/mesh.h"
#include "io/scene.h"

namespace svbrdf {

struct GatherOptions {
  // Atlas resolution (square) of meshes with texture coordinates; 0: chosen
  // like the chart atlas's texel (UvTextureSize), so that a texel of the
  // median surface element covers `texel_footprint` pixel footprints. 128
  // blurs a UV sphere's material borders at 320x240 over ~4 pixels, yet 0
  // is not the default: on seven randomized UV captures it won on the
  // sharp and noisy borders and lost as much where the finer atlas sent the
  // split search down another path (docs/measurements.md, "UV atlases").
  // The mixing weights get the automatic atlas at the end of `reconstruct`
  // (pipeline/fine_weights_stage.h), the search keeps this one.
  int texture_size = 128;
  // Meshes without texture coordinates get a chart atlas (atlas/charts.h)
  // whose texel is `texel_footprint` pixel footprints at the median view
  // (1 = one texel per pixel), at most `max_atlas_size` texels a side.
  // 2 (a texel covers about 2x2 pixels of the median view) gives each texel
  // ~4x the samples of 1: on captures without UVs it relights the held-out
  // views better than both 1 and 3.
  double texel_footprint = 2.0;
  int max_atlas_size = 1024;
  double min_cos = 0.15;        // grazing limit for view and light directions (cos of the angle)
  // Footprint normals: a pixel integrates the surface over its footprint, so
  // where the normal turns within a pixel (scanned meshes, such as the
  // bunny scan) the texel-centre normal does not describe the measured
  // value. Each sample's
  // frame then uses the mean shading normal of n x n rays per pixel of the
  // bilinear lookup (weighted like the lookup); its length < 1 (the cosine
  // of a spread of normals averages to a shorter normal) scales `geom`. Up
  // to `max_foreign_share` of the lookup may see another surface (an
  // occluding edge) or miss; beyond that the sample is rejected as
  // occluded. 0 = off (the texel-centre normal). Off by default: it assumes
  // the camera integrates each pixel (real cameras, Mitsuba's box filter);
  // on photos rendered at the pixel centre (this project's synth at spp 1)
  // it costs the bunny-scan regression, and on the Mitsuba bunny it gains
  // little (bench_results/independent.md).
  int footprint_rays = 0;
  // Footprint sub-samples (SampleSet::footprint): n x n rays through each
  // of the four pixels of a sample's bilinear lookup, each with its shading
  // normal and lookup weight, reduced to four weighted normals
  // (footprint_quadrature.h), and predictions average the BRDF over the
  // four, as the photo does. Where the normal turns within a pixel (the
  // bunny scan) the texel-centre normal mispredicts highlights; the true
  // material predicts a scan's samples far better averaged over the
  // lookup's rays than at the centre (tests/bench/sample_oracle_bench,
  // ORACLE_EXACT), and a polished metal's lobe, as narrow as the turn within
  // one pixel, needs the rays' spread, not only the pixels' mean normals.
  // 0 = off. Cost: 4 n^2 camera rays per kept sample, 48 bytes per sample,
  // and 4 model evaluations per sample in every fit and prediction: they
  // are kept only where the normal turns within the pixels, when the median
  // over samples of the largest tilt of a lookup pixel's mean normal is at
  // least `footprint_min_tilt_deg`. Scans (Mitsuba bunny, armadillo) gain
  // held-out accuracy; smooth meshes (sphere, default, mixed) gain nothing
  // and would pay twice the CPU (bench_results/independent.md). Synthetic
  // photos sample the pixel centre (n = 1 would be exact there), Mitsuba's
  // and cameras integrate the pixel (n >= 2).
  int footprint_subsamples = 2;
  double footprint_min_tilt_deg = 2.0;
  double max_foreign_share = 0.25;
  // Samples whose pixel footprint spans more than this turn of the mesh
  // normal (degrees; the texel's triangle's largest angle between vertex
  // normals per metre, times the footprint dist / (f cos_o)) are rejected:
  // the photo integrates a spread of normals there, which the texel-centre
  // frame cannot describe. 0 = off.
  double max_footprint_turn_deg = 0.0;
  // Footprint probe: n x n rays through each pixel of a kept sample's
  // bilinear lookup (weighted like the lookup) measure what the texel-centre
  // sample cannot see: the share of the footprint on another surface or the
  // background (an occluding edge, a silhouette), the share of the
  // footprint's own surface that the light does not reach (a shadow boundary
  // or the terminator in the pixel) and the largest angle between the
  // footprint's normals and the texel's. Stored per sample in
  // GatherResult::probes (diagnostics, bench tools); `max_unlit_share` and
  // `max_probe_foreign_share` reject on them. 0 = off (no extra rays).
  // Cost: 4 n^2 camera rays and up to as many shadow rays per kept sample.
  // Default 2: the reconstruction leaves partly foreign or unlit samples
  // out of its fits (ReconstructionJob::fit_max_unlit_share). Its share of
  // a whole reconstruct's time: bench_results/independent.md.
  int probe_rays = 2;
  // Lookup contrast: (max - min) / (max + min + 2 noise_floor) of the mean
  // channel over the four pixels of a sample's bilinear lookup. A steep
  // change of the photo within the lookup (a highlight on a normal that
  // turns within the pixel, a shadow boundary, an occluding edge) means the
  // interpolated value is not the texel centre's. Samples above it are
  // rejected when their pixel footprint also spans at least
  // `contrast_min_turn_deg` of the mesh normal's turn (see
  // max_footprint_turn_deg; 0 = everywhere): where the mesh is flat at the
  // pixel's scale the change is the material's or a normal map's own signal
  // (bump captures lose held-out accuracy without that condition). 1 = off
  // (the contrast is < 1), the default: a threshold that helps the Mitsuba
  // bunny scan merges two of the tiny preset's five materials, and a
  // stricter turn condition costs the bunny (bench_results/independent.md,
  // "sample quality on the bunny").
  double max_lookup_contrast = 1.0;
  double contrast_min_turn_deg = 3.0;
  double max_unlit_share = 1.0;          // reject above this unlit share of the footprint (1 = keep all)
  double max_probe_foreign_share = 1.0;  // reject above this foreign share of the footprint (1 = keep all)
  // Generated chart atlases (meshes without UVs): texels outside every UV
  // triangle (the dilation ring around each chart, and texels claimed by
  // triangles smaller than a texel) measure a point clamped onto a chart
  // border, not the surface under the texel; they exist for the bilinear
  // lookups at chart borders. They take no samples (false, the default):
  // their weights come from the neighbour fill (cluster/confidence.cc:
  // their own chart's texels, across the seam when the chart has none).
  // On a scan their samples are a large share of all samples and carry most
  // of the disagreement between the samples and the true material (chart
  // borders follow creases, where the normal turns within a pixel): leaving
  // them out relights the held-out views better at a fraction of the CPU
  // (bench_results/independent.md). Charts of one sliver triangle, whose
  // texels are all border texels, take their weights from the seam fill
  // and chart merging instead. true = sample them too.
  bool border_texel_samples = false;
  // ... except those whose clamped point lies within this many texels of the
  // texel centre (they still measure the surface under the texel; 0.5 keeps
  // most texels claimed by sub-texel triangles).
  double border_texel_max_offset = 0.0;
  // Pixel value (integer files normalised to [0, 1]; float files as stored,
  // 1 = a well exposed white) below which a sample carries no signal.
  double noise_floor = 2.0 / 255;
  // Least share of kept samples above the noise floor for a usable capture.
  double min_signal_fraction = 0.01;
  // Only texels for which this returns true take samples (empty: all;
  // called once per texel, from several threads). The others stay in the atlas without samples and are not counted as
  // candidates (the fine-weights stage gathers a finer atlas near the
  // material borders only: pipeline/fine_weights_stage.h).
  std::function<bool(const Texel&)> sample_texel;
  int threads = 0;
  bool progress = true;
  void Check() const;
};

struct GatherStats {
  long texels = 0, candidates = 0, kept = 0;
  long border_texel = 0;  // candidates on texels outside every UV triangle (GatherOptions::border_texel_samples)
  long outside_image = 0, back_facing = 0, occluded = 0, outside_mask = 0, unlit = 0, shadowed = 0,
       saturated = 0, invalid = 0;
  long turning = 0;  // normal turns too much within the pixel footprint (GatherOptions::max_footprint_turn_deg)
  long probe_unlit = 0, probe_foreign = 0;  // rejected by the footprint probe (GatherOptions::probe_rays)
  long contrast = 0;  // photo changes too steeply within the lookup (GatherOptions::max_lookup_contrast)
  long signal = 0;  // kept samples with a channel above the noise floor
  // GatherOptions::footprint_subsamples: the median largest tilt of a
  // sample's pixel normals (degrees), and whether the sub-samples were kept.
  double footprint_median_tilt_deg = 0;
  bool footprint_kept = false;
  std::vector<long> kept_per_image;
  std::vector<std::string> warnings;  // e.g. views without signal
  std::string Report(bool with_warnings = true) const;
};

// What the footprint probe saw for one sample (GatherOptions::probe_rays).
struct SampleProbe {
  float foreign = 0;  // share of the lookup on another surface or the background
  float unlit = 0;    // share of the lookup's own surface not lit (shadowed or facing away)
  float spread_deg = 0;  // largest angle between a footprint normal and the texel's
  float contrast = 0;    // the lookup's contrast (GatherOptions::max_lookup_contrast)
};

struct GatherResult {
  Mesh mesh;      // the mesh whose UVs the atlas uses (made here when the input had none)
  bool made_uvs = false;
  Atlas atlas;
  SampleSet samples;
  std::vector<SampleProbe> probes;  // per sample, in sample order; empty without GatherOptions::probe_rays
  GatherStats stats;
};

// Throws Error naming the view for a photo or mask whose size disagrees with
// its camera, when no usable sample remains (with the rejection counts), and
// when the kept samples carry no signal (see above).
GatherResult Gather(const Scene& scene, const GatherOptions& options);

// Median over (vertex, view) pairs of the surface length one pixel covers
// head-on (distance / focal length in pixels), for vertices that face the
// camera and project into its image; 0 when no vertex is seen.
double MedianPixelFootprint(const Scene& scene, const Mesh& mesh, double min_cos);

// The square atlas size at which a texel of the mesh's median surface
// element (area-weighted median over faces of sqrt(surface area / UV area))
// is `texel_size` long, clamped to [16, max_size]; 0 when no face has UV area.
int UvTextureSize(const Mesh& mesh, double texel_size, int max_size);

}  // namespace svbrdf
