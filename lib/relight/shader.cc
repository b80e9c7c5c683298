#include "relight/shader.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "atlas/atlas.h"
#include "brdf/fresnel.h"

namespace svbrdf {

namespace {

// Lookup of a texture map at uv (bilinear or the nearest texel), clamped at the border.
Rgb SampleMap(const Image& map, const Vec2& uv, TextureFilter filter) {
  const Vec2 p = UvToTexel(uv, map.width, map.height);
  Rgb out;
  if (filter == TextureFilter::kNearest) {
    const int x = std::clamp(int(std::floor(p.x())), 0, map.width - 1);
    const int y = std::clamp(int(std::floor(p.y())), 0, map.height - 1);
    for (int c = 0; c < 3; ++c) out[c] = map.at(x, y, std::min(c, map.channels - 1));
    return out;
  }
  for (int c = 0; c < 3; ++c) out[c] = map.Bilinear(p.x(), p.y(), std::min(c, map.channels - 1));
  return out;
}

uint64_t NextShaderId() {
  static std::atomic<uint64_t> next{1};
  return next++;
}

}  // namespace

MaterialShader::MaterialShader(const Material& material) : material_(material), id_(NextShaderId()) {
  for (size_t k = 0; k < material_.basis.size(); ++k) {
    const BasisMaterial& b = material_.basis[k];
    if (b.spec.family == Family::kMirror)
      mirrors_.push_back({int(k), false, 0.0, Rgb(b.params[0], b.params[1], b.params[2])});
    if (b.spec.family != Family::kPlastic) continue;
    const std::vector<ParamInfo> info = b.spec.Params();
    for (size_t i = 0; i < info.size(); ++i)
      if (info[i].name == "ior") mirrors_.push_back({int(k), true, b.params[i], Rgb::Zero()});
  }
}

Rgb MaterialShader::Mirror(const Vec2& uv, const Frame& frame, const Vec3& wo_world) const {
  const double mu = frame.n.dot(wo_world);
  if (mirrors_.empty() || !(mu > 0)) return Rgb::Zero();
  Rgb r = Rgb::Zero();
  const double s5 = std::pow(1 - std::min(mu, 1.0), 5);
  for (const MirrorPart& m : mirrors_) {
    const Rgb w = SampleMap(material_.weights[m.k], uv, material_.texture_filter).max(0.0);
    r += m.coat ? Rgb(w * brdf::FresnelDielectric(mu, m.ior)) : Rgb(w * (m.f0 + (1 - m.f0) * s5));
  }
  return r;
}

void MaterialShader::Weights(const Vec2& uv, std::vector<Rgb>* w) const {
  w->resize(material_.basis.size());
  for (size_t k = 0; k < material_.basis.size(); ++k) (*w)[k] = SampleMap(material_.weights[k], uv, material_.texture_filter);
}

Vec3 MaterialShader::Normal(const Vec2& uv, const Vec3& smooth_normal, const Vec3& dpdu) const {
  if (material_.normal_map.width == 0) return smooth_normal;
  const Rgb n = SampleMap(material_.normal_map, uv, material_.texture_filter);
  // A tangent-space value is applied in the frame of this point, not of
  // the texel centres it was interpolated from: the mesh's turn is kept.
  return NormalFromMapValue(Vec3(n[0], n[1], n[2]), material_.normal_map_space, smooth_normal, dpdu);
}

Rgb MaterialShader::Transfer(const Vec2& uv, const Vec3& to_light) const {
  if (!HasTransfer()) return Rgb::Zero();
  Rgb t = Rgb::Zero();
  if (!material_.light_transfer.empty()) {
    double phi[kLightTransferMaxTerms];
    LightTransferTerms(to_light, phi);
    for (size_t k = 0; k < material_.light_transfer.size(); ++k)
      t += phi[k] * SampleMap(material_.light_transfer[k], uv, material_.texture_filter);
  }
  if (!material_.light_residuals.empty()) {
    // A distant light has one direction for every pixel: its neighbours are
    // found once per thread, shader and direction, not per shading point.
    thread_local uint64_t cached_shader = 0;
    thread_local Vec3 cached_dir(0, 0, 0);
    thread_local int index[kLightResidualNeighbours], n = 0;
    thread_local double weight[kLightResidualNeighbours];
    if (cached_shader != id_ || cached_dir != to_light) {
      n = LightResidualNeighbours(material_.light_residual_directions, to_light, -1, index, weight);
      cached_shader = id_, cached_dir = to_light;
    }
    for (int k = 0; k < n; ++k) t += weight[k] * SampleMap(material_.light_residuals[index[k]], uv, material_.texture_filter);
  }
  return t;
}

Rgb MaterialShader::Eval(const Vec2& uv, const Frame& frame, const Vec3& wi_world, const Vec3& wo_world) const {
  const Vec3 wi = frame.ToLocal(wi_world), wo = frame.ToLocal(wo_world);
  if (wi.z() <= 0 || wo.z() <= 0) return Rgb::Zero();
  Rgb f = Rgb::Zero();
  for (size_t k = 0; k < material_.basis.size(); ++k) {
    const Rgb w = SampleMap(material_.weights[k], uv, material_.texture_filter);
    if ((w <= 0).all()) continue;
    const BasisMaterial& b = material_.basis[k];
    f += w * EvalModelD(b.spec, b.params.data(), wi, wo);
  }
  return f;
}

}  // namespace svbrdf
