// Light reaching surface points from one image's light: direct light with a
// shadow ray, and indirect light (interreflection) by path tracing with the
// material's BRDF. Shared by the relighting renderer (RenderView) and by the
// reconstruction's interreflection stage, which needs the indirect light at
// texels rather than at pixels.
#pragma once
#include <functional>
#include <vector>

#include "core/rng.h"
#include "io/scene.h"
#include "light/light.h"
#include "raytrace/raytracer.h"
#include "relight/shader.h"

namespace svbrdf {

// Directions for a path's next bounce at a point with shading frame `frame`
// and outgoing direction `wo` (world, unit): a defensive mixture (Hesterberg,
// "Weighted average importance sampling and defensive mixture
// distributions", Technometrics 1995) of the cosine-weighted hemisphere
// (share 0.4) and three normalized Phong lobes cos^n about the mirror
// direction of wo (n = 10, 100, 1000; share 0.2 each). Any BRDF is
// estimated without bias (the cosine part covers the hemisphere); a GGX lobe
// of roughness 0.02-0.3 is matched by one of the three lobes.
struct GlossyMixture {
  static constexpr double kCosineShare = 0.4;
  static constexpr double kExponents[3] = {10, 100, 1000};
  // The lobes' axis: wo mirrored about the frame's normal (unit).
  static Vec3 Mirror(const Frame& frame, const Vec3& wo);
  // A direction from three uniform numbers in [0, 1); `mirror` from Mirror().
  static Vec3 Sample(const Frame& frame, const Vec3& mirror, double u0, double u1, double u2);
  // Its density over solid angle (0 below the surface of `frame`).
  static double Pdf(const Frame& frame, const Vec3& mirror, const Vec3& wi);
};

class LightPaths {
 public:
  // `world_from_cam`: the pose of the image's camera, which places
  // camera-frame lights (a flash). The tracer, shader and light must outlive this.
  LightPaths(const RayTracer& tracer, const MaterialShader& shader, const Light& light, const Rigid3& world_from_cam);

  // A surface point as seen along a ray: position, texture coordinate, shading frame.
  struct Vertex {
    Hit hit;
    Vec3 x;
    Vec2 uv;
    Frame frame;
  };
  Vertex At(const Hit& hit) const;

  // The light at world point x (direction, distance, irradiance on a surface facing it).
  LightSample LightAt(const Vec3& x) const;

  // Radiance leaving v towards wo (world, unit) lit directly by the light.
  Rgb Direct(const Vertex& v, const Vec3& wo) const;

  // Indirect radiance leaving a point towards its viewer: `paths` paths of up
  // to `bounces` surface bounces, direct light with a shadow ray at every
  // vertex, Russian roulette from the second bounce on.
  // `first_f(wi)`: the BRDF at the first point for an incoming world
  // direction wi (the first point may be a texel, not a ray hit).
  // `origin_offset(wi)`: where rays towards wi leave the first point.
  // `first_wo`: the viewer's direction at the first point (world, unit), or
  // null. Without it every direction is drawn from the cosine-weighted
  // hemisphere (estimate f pi L per step), which suits a Lambertian first
  // point. With it directions come from a defensive mixture of the cosine
  // hemisphere and lobes about the mirror direction of the outgoing one
  // (GlossyMixture below): a glossy BRDF, which cosine directions rarely
  // hit, is then estimated with far less noise, whatever its roughness.
  // Delta (mirror) reflection (MaterialShader::Mirror: flat coats): at a
  // vertex that has one, the path follows the mirror direction with
  // probability q = min(0.5, max(0.1, largest channel of the reflectance R))
  // and weight R / q, else it samples the BRDF as above with weight
  // 1 / (1 - q). At the first point only with `first_mirror` (its R for the
  // viewer's direction) and `first_wo`.
  Rgb Indirect(const Frame& frame, const std::function<Rgb(const Vec3&)>& first_f,
               const std::function<Vec3(const Vec3&)>& origin_offset, int bounces, int paths, Rng& rng,
               const Vec3* first_wo = nullptr, const Rgb* first_mirror = nullptr) const;
  // The same from a ray hit, with the material's BRDF (and mirror) there.
  Rgb Indirect(const Vertex& v, const Vec3& wo, int bounces, int paths, Rng& rng) const;

  // Ray origin just off the surface at v, on the side direction d leaves to.
  Vec3 Offset(const Vertex& v, const Vec3& d) const;

  const Vec3& eye() const { return eye_; }
  static constexpr double kSceneScale = 1e-4;  // ray offset; meshes are in metres, objects ~0.1-10 m

 private:
  const RayTracer& tracer_;
  const MaterialShader& shader_;
  const Light& light_;
  Rigid3 world_from_cam_;
  Vec3 eye_;
};

// Light paths under each image's light, seen from its camera (index = image);
// the scene, tracer and shader must outlive them.
std::vector<LightPaths> PathsPerImage(const Scene& scene, const RayTracer& tracer, const MaterialShader& shader);

}  // namespace svbrdf
