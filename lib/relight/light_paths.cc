#include "relight/light_paths.h"

#include <cmath>

namespace svbrdf {

LightPaths::LightPaths(const RayTracer& tracer, const MaterialShader& shader, const Light& light,
                       const Rigid3& world_from_cam)
    : tracer_(tracer), shader_(shader), light_(light), world_from_cam_(world_from_cam),
      eye_(world_from_cam.translation) {}

LightPaths::Vertex LightPaths::At(const Hit& hit) const {
  Vertex v{hit, tracer_.Position(hit), tracer_.TexCoord(hit), Frame{}};
  const Vec3 dpdu = tracer_.mesh().FaceDpDu(hit.prim);
  const Vec3 n_shade = shader_.Normal(v.uv, tracer_.ShadingNormal(hit), dpdu);
  v.frame = Frame::FromNormalTangent(n_shade, dpdu);
  return v;
}

Vec3 LightPaths::Offset(const Vertex& v, const Vec3& d) const {
  const Vec3 ng = v.hit.geometric_normal.dot(d) >= 0 ? v.hit.geometric_normal : Vec3(-v.hit.geometric_normal);
  return v.x + ng * kSceneScale;
}

LightSample LightPaths::LightAt(const Vec3& x) const {
  return SampleLight(light_, x, world_from_cam_.rotation, eye_);
}

Rgb LightPaths::Direct(const Vertex& v, const Vec3& wo) const {
  const LightSample ls = LightAt(v.x);
  const double cos_i = v.frame.n.dot(ls.wi);
  if (cos_i <= 0 || (ls.normal_irradiance <= 0).all()) return Rgb::Zero();
  if (tracer_.Occluded(Offset(v, ls.wi), ls.wi, 0.0, std::isinf(ls.distance) ? 1e30 : ls.distance - 2 * kSceneScale))
    return Rgb::Zero();
  return shader_.Eval(v.uv, v.frame, ls.wi, wo) * ls.normal_irradiance * cos_i;
}

Rgb LightPaths::Indirect(const Frame& first_frame, const std::function<Rgb(const Vec3&)>& first_f,
                         const std::function<Vec3(const Vec3&)>& origin_offset, int bounces, int paths,
                         Rng& rng) const {
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  Rgb sum = Rgb::Zero();
  for (int k = 0; k < paths; ++k) {
    Frame frame = first_frame;
    Vertex v;
    Vec3 wo;
    Rgb throughput = Rgb::Ones();
    for (int b = 0; b < bounces; ++b) {
      // Cosine-weighted direction: pdf cos/pi, so f cos / pdf = f pi.
      const double u1 = u01(rng), u2 = u01(rng);
      const Vec3 wi = frame.ToWorld(CosineHemisphere(u1, u2));
      throughput *= (b == 0 ? first_f(wi) : shader_.Eval(v.uv, v.frame, wi, wo)) * kPi;
      if (!(throughput > 0).any()) break;
      Hit next;
      if (!tracer_.Intersect(b == 0 ? origin_offset(wi) : Offset(v, wi), wi, &next)) break;
      v = At(next);
      frame = v.frame;
      wo = -wi;
      sum += throughput * Direct(v, wo);
      if (b >= 1) {  // Russian roulette
        const double survive = std::min(1.0, throughput.maxCoeff());
        if (u01(rng) >= survive) break;
        throughput /= survive;
      }
    }
  }
  return sum / double(paths);
}

Rgb LightPaths::Indirect(const Vertex& v, const Vec3& wo, int bounces, int paths, Rng& rng) const {
  return Indirect(
      v.frame, [&](const Vec3& wi) { return shader_.Eval(v.uv, v.frame, wi, wo); },
      [&](const Vec3& wi) { return Offset(v, wi); }, bounces, paths, rng);
}

}  // namespace svbrdf
