// The rays through a bilinear photo lookup: what a sample's value
// integrates. Shared by the gather's footprint measures and the mirror stage
// (pipeline/mirror_stage.cc), which integrates a mirror's reflection over
// the same footprint.
#pragma once
#include <algorithm>
#include <cmath>

#include "camera/camera.h"
#include "raytrace/raytracer.h"

namespace svbrdf {

// How far from a sample's surface point a lookup ray may meet the mesh and
// still be on the same patch: a pixel spans dist / f metres head-on,
// dist / (f cos) along the surface (cos of the view angle, floored at
// 0.05), and the lookup reaches a pixel away; anything within 3 such
// lengths is this patch, anything farther another surface.
inline double LookupPatchTolerance(double dist, double focal_px, double cos_view) {
  return 3.0 * dist / focal_px / std::max(cos_view, 0.05);
}

// The rays of a footprint measure (GatherOptions::footprint_rays,
// probe_rays): n x n stratified rays through each of the four pixels of the
// bilinear lookup at continuous pixel (px, py). Calls visit(w, hit, h, pixel)
// for each, w = the lookup's weight of the ray's pixel / n^2 (they sum to 1),
// hit = whether the ray meets the mesh (then at h), pixel = dx + 2 dy of
// the ray's pixel in the lookup (0..3; pixels of weight 0 are skipped).
template <class Visit>
void ForEachLookupRay(const RayTracer& tracer, const Camera& cam, const Rigid3& world_from_cam, const Vec3& eye,
                      double px, double py, int n, Visit&& visit) {
  const double fx = px - 0.5 - std::floor(px - 0.5), fy = py - 0.5 - std::floor(py - 0.5);
  const int x0 = static_cast<int>(std::floor(px - 0.5)), y0 = static_cast<int>(std::floor(py - 0.5));
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const double w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) / (n * n);
      if (w <= 0) continue;
      for (int sy = 0; sy < n; ++sy)
        for (int sx = 0; sx < n; ++sx) {
          const Vec2 p(x0 + dx + (sx + 0.5) / n, y0 + dy + (sy + 0.5) / n);
          Hit h;
          const bool hit = tracer.Intersect(eye, world_from_cam.rotation * cam.Unproject(p), &h);
          visit(w, hit, h, dx + 2 * dy);
        }
    }
}

}  // namespace svbrdf
