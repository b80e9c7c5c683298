// Embree-backed ray tracer. Embree is confined to this file (pimpl) so the
// rest of the project never sees its headers or its float-only API.
#include "raytrace/raytracer.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <limits>
#include <mutex>

#include "core/error.h"

namespace svbrdf {
namespace {

// Embree takes floats; 1e30-style "infinity" arguments must stay finite or inf.
float ToFloatDistance(double t) {
  const double kMax = std::numeric_limits<float>::max();
  return t >= kMax ? std::numeric_limits<float>::infinity() : static_cast<float>(t);
}

RTCRay MakeRay(const Vec3& origin, const Vec3& unit_dir, double tnear, double tfar) {
  RTCRay ray;
  ray.org_x = float(origin.x());
  ray.org_y = float(origin.y());
  ray.org_z = float(origin.z());
  ray.dir_x = float(unit_dir.x());
  ray.dir_y = float(unit_dir.y());
  ray.dir_z = float(unit_dir.z());
  ray.tnear = ToFloatDistance(std::max(0.0, tnear));
  ray.tfar = ToFloatDistance(tfar);
  ray.time = 0.f;
  ray.mask = ~0u;
  ray.id = 0;
  ray.flags = 0;
  return ray;
}

}  // namespace

struct RayTracer::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  // Errors arrive through a C callback that must not throw across Embree's
  // frames, so they are recorded here and rethrown by Check().
  std::mutex error_mutex;
  std::string error;

  static void OnError(void* user, RTCError code, const char* message) {
    auto* self = static_cast<Impl*>(user);
    std::lock_guard<std::mutex> lock(self->error_mutex);
    if (self->error.empty()) self->error = Msg("Embree error ", int(code), ": ", message ? message : "(no message)");
  }

  void Check(const char* what) {
    std::lock_guard<std::mutex> lock(error_mutex);
    if (!error.empty()) throw Error(Msg("RayTracer: ", what, ": ", error));
  }

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

RayTracer::RayTracer(const Mesh& mesh) : impl_(std::make_unique<Impl>()), mesh_(mesh) {
  // Embree would accept an empty scene and silently miss everything, and read
  // out of bounds on bad indices; meshes built in code get the same checks as
  // loaded ones (no faces, index ranges, NaNs) with a clear message.
  mesh.Validate("RayTracer");

  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device)
    throw Error(Msg("RayTracer: cannot create Embree device (error ", int(rtcGetDeviceError(nullptr)), ")"));
  rtcSetDeviceErrorFunction(impl_->device, &Impl::OnError, impl_.get());

  impl_->scene = rtcNewScene(impl_->device);
  impl_->Check("creating scene");
  // ROBUST gives watertight hits on shared edges (no leaks between triangles);
  // HIGH quality costs build time once and pays back on millions of queries.
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);

  RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  impl_->Check("creating geometry");
  // rtcSetNewGeometryBuffer owns the memory and adds the padding Embree needs.
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), mesh.positions.size()));
  auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh.faces.size()));
  if (!vertices || !indices) {
    rtcReleaseGeometry(geom);
    impl_->Check("allocating buffers");
    throw Error("RayTracer: cannot allocate Embree buffers");
  }
  for (size_t i = 0; i < mesh.positions.size(); ++i)
    for (int k = 0; k < 3; ++k) vertices[3 * i + k] = float(mesh.positions[i][k]);
  for (size_t f = 0; f < mesh.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) indices[3 * f + k] = unsigned(mesh.faces[f][k]);

  rtcCommitGeometry(geom);
  rtcAttachGeometry(impl_->scene, geom);
  rtcReleaseGeometry(geom);  // the scene keeps its own reference
  rtcCommitScene(impl_->scene);
  impl_->Check("building scene");
}

RayTracer::~RayTracer() = default;

bool RayTracer::Intersect(const Vec3& origin, const Vec3& dir, Hit* hit, double tnear,
                          double tfar) const {
  const Vec3 d = dir.normalized();
  RTCIntersectContext context;  // per call: contexts are not shareable between threads
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  rh.ray = MakeRay(origin, d, tnear, tfar);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &context, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;

  const Vec3i& f = mesh_.faces[rh.hit.primID];
  const Vec3& p0 = mesh_.positions[f[0]];
  const Vec3 e1 = mesh_.positions[f[1]] - p0, e2 = mesh_.positions[f[2]] - p0;
  hit->prim = int(rh.hit.primID);
  hit->t = rh.ray.tfar;
  hit->b1 = rh.hit.u;
  hit->b2 = rh.hit.v;
  // Embree found the triangle in float; redo the ray/triangle solve in double
  // (Moller-Trumbore) so hit points lie on the double-precision surface.
  const Vec3 pv = d.cross(e2);
  const double det = e1.dot(pv);
  if (std::abs(det) > 1e-300) {
    const Vec3 s = origin - p0, q = s.cross(e1);
    const double b1 = std::clamp(s.dot(pv) / det, 0.0, 1.0);
    const double b2 = std::clamp(d.dot(q) / det, 0.0, 1.0 - b1);
    hit->t = e2.dot(q) / det;
    hit->b1 = b1;
    hit->b2 = b2;
  }
  // Winding-oriented (counter-clockwise = front) rather than Embree's Ng, whose
  // sign convention is not the usual right-hand rule.
  hit->geometric_normal = e1.cross(e2).normalized();
  return true;
}

bool RayTracer::Occluded(const Vec3& origin, const Vec3& dir, double tnear, double tfar) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray = MakeRay(origin, dir.normalized(), tnear, tfar);
  rtcOccluded1(impl_->scene, &context, &ray);
  return ray.tfar < 0;  // Embree sets tfar = -inf when something blocks the ray
}

Vec3 RayTracer::Position(const Hit& hit) const {
  const Vec3i& f = mesh_.faces[hit.prim];
  return (1 - hit.b1 - hit.b2) * mesh_.positions[f[0]] + hit.b1 * mesh_.positions[f[1]] +
         hit.b2 * mesh_.positions[f[2]];
}

Vec3 RayTracer::ShadingNormal(const Hit& hit) const {
  if (mesh_.normals.size() != mesh_.positions.size()) return hit.geometric_normal;
  const Vec3i& f = mesh_.faces[hit.prim];
  const Vec3 n = (1 - hit.b1 - hit.b2) * mesh_.normals[f[0]] + hit.b1 * mesh_.normals[f[1]] +
                 hit.b2 * mesh_.normals[f[2]];
  // Opposing vertex normals can cancel out; the face normal is the honest fallback.
  return n.squaredNorm() > 1e-24 ? Vec3(n.normalized()) : hit.geometric_normal;
}

Vec2 RayTracer::TexCoord(const Hit& hit) const {
  if (!mesh_.HasUVs()) return Vec2::Zero();
  const Vec3i& f = mesh_.face_uvs[hit.prim];
  return (1 - hit.b1 - hit.b2) * mesh_.texcoords[f[0]] + hit.b1 * mesh_.texcoords[f[1]] +
         hit.b2 * mesh_.texcoords[f[2]];
}

}  // namespace svbrdf
