#include "gather/footprint_quadrature.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace svbrdf {

namespace {

// Weighted means of the entries' rays (entries <= kMaxFootprintEntries).
// Fixed-size: the gather reduces every kept sample's rays, and heap vectors
// there cost more than the reduction itself.
struct EntryMeans {
  double a[kMaxFootprintEntries] = {}, b[kMaxFootprintEntries] = {}, w[kMaxFootprintEntries] = {};
  double total = 0;
  EntryMeans(const FootprintRay* rays, int count, int entries) {
    for (int r = 0; r < count; ++r) {
      const FootprintRay& ray = rays[r];
      a[ray.entry] += ray.w * ray.a, b[ray.entry] += ray.w * ray.b, w[ray.entry] += ray.w;
      total += ray.w;
    }
    for (int e = 0; e < entries; ++e)
      if (w[e] > 0) a[e] /= w[e], b[e] /= w[e];
  }
};

// Lloyd's iterations from the rays' entries: each ray to its nearest entry,
// each entry to its rays' weighted mean. A handful settle 4 n^2 rays.
void Lloyd(FootprintRay* rays, int count, int entries) {
  EntryMeans c(rays, count, entries);
  for (int iter = 0; iter < 4; ++iter) {
    bool moved = false;
    for (int r = 0; r < count; ++r) {
      FootprintRay& ray = rays[r];
      // Squared distances: the nearest entry without a square root per pair.
      auto d2 = [&](int e) {
        const double da = ray.a - c.a[e], db = ray.b - c.b[e];
        return da * da + db * db;
      };
      int best = ray.entry;
      double best_d = d2(best);
      for (int e = 0; e < entries; ++e) {
        const double d = d2(e);
        if (c.w[e] > 0 && d < best_d) best = e, best_d = d;
      }
      moved |= best != ray.entry;
      ray.entry = best;
    }
    if (!moved) break;
    c = EntryMeans(rays, count, entries);
  }
}

// Splits the rays of entry `from` (those with weight) in two at their
// weighted mean across their principal axis; the far side goes to entry `to`.
void SplitAlongPrincipalAxis(FootprintRay* rays, int count, int from, int to) {
  double w = 0, ma = 0, mb = 0;
  for (int r = 0; r < count; ++r)
    if (rays[r].entry == from) w += rays[r].w, ma += rays[r].w * rays[r].a, mb += rays[r].w * rays[r].b;
  if (!(w > 0)) return;
  ma /= w, mb /= w;
  double saa = 0, sab = 0, sbb = 0;
  for (int r = 0; r < count; ++r)
    if (rays[r].entry == from) {
      const double da = rays[r].a - ma, db = rays[r].b - mb;
      saa += rays[r].w * da * da, sab += rays[r].w * da * db, sbb += rays[r].w * db * db;
    }
  // Principal axis of [[saa, sab], [sab, sbb]]: angle 0.5 atan2(2 sab, saa - sbb).
  const double theta = 0.5 * std::atan2(2 * sab, saa - sbb);
  const double ua = std::cos(theta), ub = std::sin(theta);
  for (int r = 0; r < count; ++r)
    if (rays[r].entry == from && (rays[r].a - ma) * ua + (rays[r].b - mb) * ub > 0) rays[r].entry = to;
}

}  // namespace

bool ReduceFootprintRays(FootprintRay* rays, int count, int entries, float* out) {
  if (entries < 1 || entries > kMaxFootprintEntries || count < 0 || count > kMaxFootprintRays)
    throw Error(Msg("footprint quadrature: ", count, " rays into ", entries, " entries (at most ", kMaxFootprintRays,
                    " into ", kMaxFootprintEntries, ")"));
  // Two deterministic starts, the better kept: the pixels (right where the
  // lookup weighs its pixels alike and the normal turns evenly), and the
  // rays split in two along their principal axis, each half again (right
  // where one pixel carries most of the weight, or the normal turns within
  // the pixels across the pixel grid); Lloyd's iterations refine both.
  FootprintRay split[kMaxFootprintRays];
  std::copy(rays, rays + count, split);
  Lloyd(rays, count, entries);
  if (entries == 4 && count > 0) {
    for (int r = 0; r < count; ++r) split[r].entry = 0;
    SplitAlongPrincipalAxis(split, count, 0, 2);
    SplitAlongPrincipalAxis(split, count, 0, 1);
    SplitAlongPrincipalAxis(split, count, 2, 3);
    Lloyd(split, count, entries);
    if (FootprintSpread(split, count, entries) < FootprintSpread(rays, count, entries))
      std::copy(split, split + count, rays);
  }
  const EntryMeans c(rays, count, entries);
  for (int e = 0; e < entries; ++e) {
    const bool used = c.w[e] > 0 && c.total > 0;
    out[3 * e] = used ? float(c.a[e]) : 0.f;
    out[3 * e + 1] = used ? float(c.b[e]) : 0.f;
    out[3 * e + 2] = used ? float(c.w[e] / c.total) : 0.f;
  }
  return c.total > 0;
}

double LargestEntryTilt(const FootprintRay* rays, int count, int entries) {
  double x[kMaxFootprintEntries] = {}, y[kMaxFootprintEntries] = {}, z[kMaxFootprintEntries] = {};
  for (int r = 0; r < count; ++r) {
    const double inv = 1 / std::sqrt(rays[r].a * rays[r].a + rays[r].b * rays[r].b + 1);
    const int e = rays[r].entry;
    x[e] += rays[r].w * rays[r].a * inv, y[e] += rays[r].w * rays[r].b * inv, z[e] += rays[r].w * inv;
  }
  double worst = 0;
  for (int e = 0; e < entries; ++e)
    if (z[e] > 0) worst = std::max(worst, std::hypot(x[e] / z[e], y[e] / z[e]));
  return worst;
}

double FootprintSpread(const FootprintRay* rays, int count, int entries) {
  const EntryMeans c(rays, count, entries);
  double s = 0;
  for (int r = 0; r < count; ++r) {
    const double da = rays[r].a - c.a[rays[r].entry], db = rays[r].b - c.b[rays[r].entry];
    s += rays[r].w * (da * da + db * db);
  }
  return c.total > 0 ? s / c.total : 0.0;
}

}  // namespace svbrdf
