// The only user of Embree in the project: a static triangle scene with
// closest-hit and occlusion queries. Thread-safe for concurrent queries.
#pragma once
#include <memory>
#include <string>

#include "core/types.h"
#include "io/mesh.h"

namespace svbrdf {

struct Hit {
  double t = 0;      // distance along the (unit) ray direction
  int prim = -1;     // triangle index into mesh.faces
  double b1 = 0, b2 = 0;  // barycentrics: p = (1-b1-b2) v0 + b1 v1 + b2 v2
  Vec3 geometric_normal = Vec3::Zero();  // unit, from the triangle winding
};

class RayTracer {
 public:
  explicit RayTracer(const Mesh& mesh);  // throws Error with Embree's message on failure
  ~RayTracer();
  RayTracer(const RayTracer&) = delete;
  RayTracer& operator=(const RayTracer&) = delete;

  // Closest hit with t in [tnear, tfar]; `dir` need not be unit (it is normalised).
  bool Intersect(const Vec3& origin, const Vec3& dir, Hit* hit, double tnear = 0.0,
                 double tfar = 1e30) const;
  // True when anything blocks the segment origin + t dir, t in [tnear, tfar].
  bool Occluded(const Vec3& origin, const Vec3& dir, double tnear, double tfar) const;

  const Mesh& mesh() const { return mesh_; }
  // Interpolated quantities at a hit.
  Vec3 Position(const Hit& hit) const;
  Vec3 ShadingNormal(const Hit& hit) const;  // smooth vertex normal, unit
  Vec2 TexCoord(const Hit& hit) const;       // (0,0) when the mesh has no UVs

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  const Mesh& mesh_;
};

}  // namespace svbrdf
