#include "gather/footprint_quadrature.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace svbrdf {

namespace {

// Weighted means of the entries' rays; returns the total weight.
double EntryMeans(const FootprintRay* rays, int count, int entries, std::vector<double>* a, std::vector<double>* b,
                  std::vector<double>* w) {
  a->assign(entries, 0.0), b->assign(entries, 0.0), w->assign(entries, 0.0);
  double total = 0;
  for (int r = 0; r < count; ++r) {
    const FootprintRay& ray = rays[r];
    (*a)[ray.entry] += ray.w * ray.a, (*b)[ray.entry] += ray.w * ray.b, (*w)[ray.entry] += ray.w;
    total += ray.w;
  }
  for (int e = 0; e < entries; ++e)
    if ((*w)[e] > 0) (*a)[e] /= (*w)[e], (*b)[e] /= (*w)[e];
  return total;
}

}  // namespace

namespace {

// Lloyd's iterations from the rays' entries: each ray to its nearest entry,
// each entry to its rays' weighted mean. A handful settle 4 n^2 rays.
void Lloyd(FootprintRay* rays, int count, int entries) {
  std::vector<double> ca, cb, cw;
  EntryMeans(rays, count, entries, &ca, &cb, &cw);
  for (int iter = 0; iter < 4; ++iter) {
    bool moved = false;
    for (int r = 0; r < count; ++r) {
      FootprintRay& ray = rays[r];
      int best = ray.entry;
      double best_d = std::hypot(ray.a - ca[best], ray.b - cb[best]);
      for (int e = 0; e < entries; ++e) {
        const double d = std::hypot(ray.a - ca[e], ray.b - cb[e]);
        if (cw[e] > 0 && d < best_d) best = e, best_d = d;
      }
      moved |= best != ray.entry;
      ray.entry = best;
    }
    if (!moved) break;
    EntryMeans(rays, count, entries, &ca, &cb, &cw);
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
  // Two deterministic starts, the better kept: the pixels (right where the
  // lookup weighs its pixels alike and the normal turns evenly), and the
  // rays split in two along their principal axis, each half again (right
  // where one pixel carries most of the weight, or the normal turns within
  // the pixels across the pixel grid); Lloyd's iterations refine both.
  std::vector<FootprintRay> split(rays, rays + count);
  Lloyd(rays, count, entries);
  if (entries == 4 && count > 0) {
    for (FootprintRay& r : split) r.entry = 0;
    SplitAlongPrincipalAxis(split.data(), count, 0, 2);
    SplitAlongPrincipalAxis(split.data(), count, 0, 1);
    SplitAlongPrincipalAxis(split.data(), count, 2, 3);
    Lloyd(split.data(), count, entries);
    if (FootprintSpread(split.data(), count, entries) < FootprintSpread(rays, count, entries))
      std::copy(split.begin(), split.end(), rays);
  }
  std::vector<double> ca, cb, cw;
  const double total = EntryMeans(rays, count, entries, &ca, &cb, &cw);
  for (int e = 0; e < entries; ++e) {
    const bool used = cw[e] > 0 && total > 0;
    out[3 * e] = used ? float(ca[e]) : 0.f;
    out[3 * e + 1] = used ? float(cb[e]) : 0.f;
    out[3 * e + 2] = used ? float(cw[e] / total) : 0.f;
  }
  return total > 0;
}

double LargestEntryTilt(const FootprintRay* rays, int count, int entries) {
  std::vector<double> x(entries, 0.0), y(entries, 0.0), z(entries, 0.0);
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
  std::vector<double> ca, cb, cw;
  const double total = EntryMeans(rays, count, entries, &ca, &cb, &cw);
  double s = 0;
  for (int r = 0; r < count; ++r) {
    const double da = rays[r].a - ca[rays[r].entry], db = rays[r].b - cb[rays[r].entry];
    s += rays[r].w * (da * da + db * db);
  }
  return total > 0 ? s / total : 0.0;
}

}  // namespace svbrdf
