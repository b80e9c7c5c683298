// Light calibration from mirror spheres and a diffuse reference.
//
// Position: a point lamp seen in a mirror sphere of known centre and radius
// shows as a highlight; the camera ray through the highlight, reflected at
// the sphere, passes through the lamp. Rays from several spheres or views
// are intersected in the least-squares sense (the point nearest to all rays).
// Intensity: a Lambertian reference of known albedo a at point x with normal
// n shows the pixel value p = exposure * a / pi * I * cos / r^2, so
// I = p pi r^2 / (exposure a cos); the median over many reference pixels is used.
#pragma once
#include <vector>

#include "camera/camera.h"
#include "io/image.h"

namespace svbrdf {

struct MirrorSphere {
  Vec3 centre = Vec3::Zero();  // world
  double radius = 0;           // metres
};

// Highlight position (COLMAP pixel convention) in a linear image: the
// intensity-weighted centroid of the brightest spot inside the sphere's
// projected disc. Returns false when the sphere is out of view or shows no
// spot clearly brighter than its surroundings.
bool FindHighlight(const Image& linear, const Camera& camera, const Rigid3& cam_from_world, const MirrorSphere& sphere,
                   Vec2* pixel);

struct Ray3 {
  Vec3 origin, direction;  // unit direction
};
// The reflected ray towards the light for a highlight at `pixel`; false if the
// pixel ray misses the sphere.
bool ReflectedRay(const Camera& camera, const Rigid3& cam_from_world, const MirrorSphere& sphere, const Vec2& pixel,
                  Ray3* ray);

// Least-squares point nearest to all rays (at least two, not parallel);
// *rms_m gets the RMS distance of the point to the rays.
Vec3 NearestPointToRays(const std::vector<Ray3>& rays, double* rms_m = nullptr);

// One reference observation: pixel value (RGB), exposure, albedo and geometry.
struct DiffuseSample {
  Rgb value = Rgb::Zero();
  double exposure = 1, albedo = 0;
  Vec3 point = Vec3::Zero(), normal = Vec3::UnitZ();
};
// Point-light intensity per channel (W/sr in the image's units) from
// reference samples, in parts so that a light that moves between photos (a
// flash) pools them: each usable sample's estimate appended (grazing,
// < 0.2 cosine, or black samples skipped), then the per-channel median
// (throws Error when empty).
void AppendIntensityEstimates(const std::vector<DiffuseSample>& samples, const Vec3& light_position,
                              std::vector<Rgb>* estimates);
Rgb MedianIntensity(const std::vector<Rgb>& estimates);

}  // namespace svbrdf
