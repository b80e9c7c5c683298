// Footprint quadrature (GatherOptions::footprint_subsamples): the rays of a
// sample's bilinear lookup, each a tilt (a, b) of the sample's frame with
// its lookup weight, reduced to SampleSet::kFootprintSubsamples weighted
// tilts over which the fits average the BRDF.
//
// Why not each pixel's mean tilt: a photo's pixel integrates the BRDF over
// the normals within it, and a lobe as narrow as the turn of the normal
// within a pixel (a polished metal on a scan) averaged over that turn is far
// dimmer at its peak than at the mean normal. A weighted k-means of the rays
// (Lloyd's iterations from two deterministic starts, the pixels and a
// principal-axis split) keeps the mean tilt and lowers the entries'
// within-spread (the error a quadrature of a smooth function makes to
// second order) below the pixels' means'.
#pragma once

namespace svbrdf {

// Bounds of the reduction: SampleSet::kFootprintSubsamples entries, and the
// lookup's 4 pixels of n x n rays with n <= 8 (GatherOptions::Check).
constexpr int kMaxFootprintEntries = 4;
constexpr int kMaxFootprintRays = 4 * 8 * 8;

struct FootprintRay {
  double a = 0, b = 0;  // tilt of the ray's shading normal: normalize(a, b, 1) in the sample's frame
  double w = 0;         // lookup weight (> 0)
  int entry = 0;        // start: the ray's pixel in [0, entries); out: its entry
};

// Reduces `count` rays to `entries` weighted tilts, written as (a, b, w)
// triples to out[0 .. 3 * entries): weights sum to 1, entries that keep no
// ray have weight 0 (and tilt 0). Returns false when no ray has weight.
// Throws when `entries` or `count` exceed the bounds above.
bool ReduceFootprintRays(FootprintRay* rays, int count, int entries, float* out);

// Weighted within-entry spread sum_r w_r |t_r - c_entry(r)|^2 / sum_r w_r
// of the rays' current entries (c: the entries' weighted means; entries <=
// kMaxFootprintEntries): what the reduction lowers.
double FootprintSpread(const FootprintRay* rays, int count, int entries);

// The largest tilt |(a, b)| of the entries' mean normals (the rays' unit
// normals averaged per entry, as a tilt; entries <= kMaxFootprintEntries),
// over entries with weight: before the reduction, how far the lookup
// pixels' normals turn from the frame's.
double LargestEntryTilt(const FootprintRay* rays, int count, int entries);

}  // namespace svbrdf
