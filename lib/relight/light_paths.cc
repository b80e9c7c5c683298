#include "relight/light_paths.h"

#include <algorithm>
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

Vec3 GlossyMixture::Mirror(const Frame& frame, const Vec3& wo) {
  return (2 * frame.n.dot(wo) * frame.n - wo).normalized();
}

Vec3 GlossyMixture::Sample(const Frame& frame, const Vec3& mirror, double u0, double u1, double u2) {
  if (u0 < kCosineShare) return frame.ToWorld(CosineHemisphere(u1, u2));
  const int k = std::min(2, int((u0 - kCosineShare) / ((1 - kCosineShare) / 3)));
  const double c = std::pow(u1, 1 / (kExponents[k] + 1)), s = std::sqrt(std::max(0.0, 1 - c * c));
  const double phi = 2 * kPi * u2;
  return Frame::FromNormal(mirror).ToWorld(Vec3(s * std::cos(phi), s * std::sin(phi), c));
}

double GlossyMixture::Pdf(const Frame& frame, const Vec3& mirror, const Vec3& wi) {
  const double cos_n = frame.n.dot(wi);
  if (cos_n <= 0) return 0;
  const double cos_r = std::max(0.0, mirror.dot(wi));
  double pdf = kCosineShare * cos_n / kPi;
  for (double n : kExponents) pdf += (1 - kCosineShare) / 3 * (n + 1) / (2 * kPi) * std::pow(cos_r, n);
  return pdf;
}

Rgb LightPaths::Indirect(const Frame& first_frame, const std::function<Rgb(const Vec3&)>& first_f,
                         const std::function<Vec3(const Vec3&)>& origin_offset, int bounces, int paths,
                         Rng& rng, const Vec3* first_wo, const Rgb* first_mirror) const {
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  Rgb sum = Rgb::Zero();
  for (int k = 0; k < paths; ++k) {
    Frame frame = first_frame;
    Vertex v;
    Vec3 wo = first_wo ? *first_wo : Vec3::Zero();
    Rgb throughput = Rgb::Ones();
    for (int b = 0; b < bounces; ++b) {
      Vec3 wi;
      const Rgb mirror_r = b == 0 ? (first_mirror && first_wo ? *first_mirror : Rgb::Zero())
                                  : shader_.HasMirror() ? shader_.Mirror(v.uv, v.frame, wo) : Rgb::Zero();
      const double q = mirror_r.maxCoeff() > 0 ? std::clamp(mirror_r.maxCoeff(), 0.1, 0.5) : 0.0;
      if (q > 0 && u01(rng) < q) {
        wi = 2 * frame.n.dot(wo) * frame.n - wo;  // the mirror direction
        throughput *= mirror_r / q;
      } else if (first_wo) {
        if (q > 0) throughput /= 1 - q;
        const double u0 = u01(rng), u1 = u01(rng), u2 = u01(rng);
        const Vec3 mirror = GlossyMixture::Mirror(frame, wo);
        wi = GlossyMixture::Sample(frame, mirror, u0, u1, u2);
        const double pdf = GlossyMixture::Pdf(frame, mirror, wi);
        if (!(pdf > 0)) break;  // below the surface: this path ends
        throughput *= (b == 0 ? first_f(wi) : shader_.Eval(v.uv, v.frame, wi, wo)) * (frame.n.dot(wi) / pdf);
      } else {
        // Cosine-weighted direction: pdf cos/pi, so f cos / pdf = f pi.
        const double u1 = u01(rng), u2 = u01(rng);
        wi = frame.ToWorld(CosineHemisphere(u1, u2));
        throughput *= (b == 0 ? first_f(wi) : shader_.Eval(v.uv, v.frame, wi, wo)) * kPi;
      }
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
  const Rgb mirror = shader_.HasMirror() ? shader_.Mirror(v.uv, v.frame, wo) : Rgb::Zero();
  return Indirect(
      v.frame, [&](const Vec3& wi) { return shader_.Eval(v.uv, v.frame, wi, wo); },
      [&](const Vec3& wi) { return Offset(v, wi); }, bounces, paths, rng, &wo, &mirror);
}

std::vector<LightPaths> PathsPerImage(const Scene& scene, const RayTracer& tracer, const MaterialShader& shader) {
  std::vector<LightPaths> paths;
  paths.reserve(scene.images.size());
  for (const ImageEntry& e : scene.images)
    paths.emplace_back(tracer, shader, scene.LightById(e.light), e.cam_from_world.Inverse());
  return paths;
}

}  // namespace svbrdf
