// Environment-map lighting for relight (RenderViewEnvironment, relight.h).
#include <cmath>
#include <random>

#include "relight/relight.h"

namespace svbrdf {

RenderedView RenderViewEnvironment(const RayTracer& tracer, const MaterialShader& shader, const Scene& scene,
                                   size_t index, const EnvironmentMap& env, const RelightOptions& options) {
  const ImageEntry& entry = scene.images.at(index);
  const Camera& cam = scene.CameraById(entry.camera);
  const Rigid3 world_from_cam = entry.cam_from_world.Inverse();
  const double scene_scale = 1e-4;  // shadow-ray offset, as RenderView
  const int n = options.env_samples;

  auto radiance = [&](double px, double py, Rng& rng, bool* hit_out) -> Rgb {
    Vec3 origin_cam, dir_cam;
    cam.PixelRay(Vec2(px, py), &origin_cam, &dir_cam);
    const Vec3 dir = world_from_cam.rotation * dir_cam;
    Hit hit;
    if (!tracer.Intersect(world_from_cam * origin_cam, dir, &hit)) {
      *hit_out = false;
      return Rgb::Zero();
    }
    *hit_out = true;
    const Vec3 x = tracer.Position(hit);
    const Vec2 uv = tracer.TexCoord(hit);
    const Vec3 dpdu = tracer.mesh().FaceDpDu(hit.prim);
    const Vec3 n_shade = shader.Normal(uv, tracer.ShadingNormal(hit), dpdu);
    const Frame frame = Frame::FromNormalTangent(n_shade, dpdu);
    const Vec3 wo = -dir.normalized();  // towards the viewer (the eye, or -z of an orthographic camera)
    // Shadow rays leave on the viewer's side of the triangle.
    const Vec3 ng = hit.geometric_normal.dot(wo) >= 0 ? hit.geometric_normal : Vec3(-hit.geometric_normal);
    const Vec3 origin = x + ng * scene_scale;
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    // Balance heuristic with n samples of each strategy: every sample
    // contributes f L cos / (n (p_env + p_cos)).
    auto contribution = [&](const Vec3& wi, double p_env) -> Rgb {
      const double cos_i = n_shade.dot(wi);
      if (cos_i <= 0 || ng.dot(wi) <= 0) return Rgb::Zero();
      const double p = p_env + cos_i / kPi;
      if (!(p > 0) || tracer.Occluded(origin, wi, 0.0, 1e30)) return Rgb::Zero();
      return shader.Eval(uv, frame, wi, wo) * env.Radiance(wi) * (cos_i / p);
    };
    Rgb sum = Rgb::Zero();
    for (int s = 0; s < n; ++s) {
      double p_env = 0;
      const double a = u01(rng), b = u01(rng);
      const Vec3 wi_env = env.Sample(a, b, &p_env);
      sum += contribution(wi_env, p_env);
      // Cosine-weighted direction about the shading normal (Malley's method).
      const double u1 = u01(rng), u2 = u01(rng);
      const Vec3 wi_cos = frame.ToWorld(CosineHemisphere(u1, u2));
      sum += contribution(wi_cos, env.Pdf(wi_cos));
    }
    return sum / double(n);
  };
  return RenderPixels(cam, entry, index, options, radiance);
}

}  // namespace svbrdf
