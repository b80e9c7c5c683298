#include "indirect/interreflection.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <utility>

#include "core/error.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "core/rng.h"
#include "io/material.h"
#include "raytrace/raytracer.h"
#include "relight/light_paths.h"
#include "relight/shader.h"

namespace svbrdf {

void InterreflectionOptions::Check() const {
  if (bounces < 0 || bounces > 8) throw Error(Msg("reconstruct: --interreflection-bounces must be in [0, 8], got ", bounces));
  if (paths < 1 || paths > 256) throw Error(Msg("reconstruct: --interreflection-paths must be in [1, 256], got ", paths));
  if (refit_paths < 1 || refit_paths > 256)
    throw Error(Msg("reconstruct: --interreflection-refit-paths must be in [1, 256], got ", refit_paths));
}

std::string InterreflectionReport::Summary() const {
  return Msg("interreflection (", bounces, " bounces): ", 100 * removed_share, " % of the signal removed, ",
             100 * samples_over_5pc, " % of ", samples, " samples lost more than 5 %, at most ", 100 * max_share, " %");
}

namespace {

// Per texel and channel: median of pi y / (geom + e) over the texel's
// samples (e: per sample and channel, or none); texels without samples
// take the median over texels.
std::vector<Rgb> LambertAlbedo(const SampleSet& s, const std::vector<Rgb>* e) {
  std::vector<Rgb> rho(s.num_texels, Rgb::Constant(-1));
  std::vector<double> all[3];
  for (int t = 0; t < s.num_texels; ++t) {
    if (s.texel_begin[t] == s.texel_begin[t + 1]) continue;
    for (int c = 0; c < 3; ++c) {
      std::vector<double> v;
      for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i)
        v.push_back(kPi * s.y[c][i] / (s.geom[i] + (e ? (*e)[i][c] : 0.0)));
      rho[t][c] = Median(std::move(v));
      all[c].push_back(rho[t][c]);
    }
  }
  Rgb typical;
  for (int c = 0; c < 3; ++c) typical[c] = Median(std::move(all[c]));
  for (Rgb& r : rho)
    if (r[0] < 0) r = typical;
  return rho;
}

// A material with one Lambertian basis BRDF (rd = 1) weighted per texel by rho.
Material LambertMaterial(const GatherResult& g, const std::vector<Rgb>& rho) {
  Material m;
  m.mesh = g.mesh;
  m.width = g.atlas.width, m.height = g.atlas.height;
  BasisMaterial b;
  b.name = "lambert_estimate";
  b.spec = ModelSpec::FromLabel("lambert");
  b.params = b.spec.InitialParams();
  const std::vector<ParamInfo> info = b.spec.Params();
  for (size_t i = 0; i < info.size(); ++i) b.params[i] = 1.0;  // rd_r, rd_g, rd_b
  m.basis = {b};
  Image w(m.width, m.height, 3);
  for (size_t t = 0; t < g.atlas.texels.size(); ++t)
    for (int c = 0; c < 3; ++c) w.at(g.atlas.texels[t].x, g.atlas.texels[t].y, c) = float(rho[t][c]);
  m.weights = {w};
  return m;
}

// Texels that see some part of the object (none of a convex one), found
// with a few cosine-weighted rays each.
std::vector<char> TexelsThatSeeTheObject(const GatherResult& g, const InterreflectionOptions& o) {
  const SampleSet& s = g.samples;
  const RayTracer geometry(g.mesh);
  std::vector<char> sees_object(s.num_texels, 0);
  ParallelFor(s.num_texels, o.threads, [&](long t) {
    if (s.texel_begin[t] == s.texel_begin[t + 1]) return;
    const Texel& tx = g.atlas.texels[t];
    const Frame frame = Frame::FromNormalTangent(tx.normal, tx.tangent);
    constexpr int kSide = 6;  // 36 stratified directions
    Rng rng(StreamSeed(o.seed, uint64_t(t), 1));
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    for (int k = 0; k < kSide * kSide && !sees_object[t]; ++k) {
      const double u1 = (k / kSide + u01(rng)) / kSide, u2 = (k % kSide + u01(rng)) / kSide;
      const Vec3 d = frame.ToWorld(CosineHemisphere(u1, u2));
      Hit hit;
      sees_object[t] = geometry.Intersect(tx.position + tx.normal * LightPaths::kSceneScale, d, &hit);
    }
  }, 64);
  return sees_object;
}

}  // namespace

InterreflectionReport RemoveInterreflection(const Scene& scene, GatherResult* g, const InterreflectionOptions& o) {
  o.Check();
  if (size_t(g->samples.num_texels) != g->atlas.texels.size())
    throw Error("internal: interreflection: samples and atlas disagree on the texel count");
  InterreflectionReport rep;
  rep.bounces = o.bounces;
  SampleSet& s = g->samples;
  rep.samples = s.size();
  if (o.bounces == 0 || s.size() == 0) return rep;
  // e per sample in y's units: y_c = radiance_c * m / E_c with m = mean_c E_c
  // (gather.cc), so an indirect irradiance scales alike.
  // Texels that see no part of the object (all of a convex one) get no
  // indirect light.
  rep.sees_object = TexelsThatSeeTheObject(*g, o);
  const std::vector<char>& sees_object = rep.sees_object;
  auto trace = [&](const std::vector<Rgb>& rho, const char* what) {
    const Material lambert = LambertMaterial(*g, rho);
    const RayTracer tracer(lambert.mesh);
    const MaterialShader shader(lambert);
    const std::vector<LightPaths> paths = PathsPerImage(scene, tracer, shader);
    std::vector<Rgb> e(s.size(), Rgb::Zero());
    Progress bar(what, s.num_texels, o.progress);
    ParallelFor(s.num_texels, o.threads, [&](long t) {
      bar.Tick();
      if (!sees_object[t]) return;
      const Texel& tx = g->atlas.texels[t];
      const Frame frame = Frame::FromNormalTangent(tx.normal, tx.tangent);
      const Vec3 origin = tx.position + tx.normal * LightPaths::kSceneScale;
      // Irradiance only: a first "BRDF" of 1/pi makes each path's estimate
      // the incoming radiance, whose cosine-weighted mean is E_ind / pi.
      auto white = [](const Vec3&) { return Rgb::Constant(1.0 / kPi); };
      auto leave = [&](const Vec3&) { return origin; };
      for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) {
        const LightPaths& lp = paths[s.image[i]];
        const LightSample ls = lp.LightAt(tx.position);
        if (!(ls.normal_irradiance > 0).all()) continue;
        Rng rng(StreamSeed(o.seed, uint64_t(i)));  // the same paths in both passes
        const Rgb l_in = lp.Indirect(frame, white, leave, o.bounces, o.paths, rng);
        const double m = ls.normal_irradiance.mean();
        for (int c = 0; c < 3; ++c) e[i][c] = kPi * l_in[c] * m / ls.normal_irradiance[c];
      }
    }, 16);
    return e;
  };
  // The albedo that traces the indirect light is the unknown being solved
  // for: rho = g(rho) = median pi y / (geom + e(rho)). Traced with the
  // inflated albedo of the raw samples (a), g overshoots below the fixed
  // point; traced again with that (b), it lands above. The fixed point per
  // texel and channel is taken on the secant through the two, and e there
  // interpolated (e is close to linear in the albedo: the first bounce
  // dominates). Inside a closed white sphere, where every texel sees only
  // the object, this recovers the albedo within a few per cent where one
  // pass is a third too low.
  const std::vector<Rgb> rho_a = LambertAlbedo(s, nullptr);
  const std::vector<Rgb> e_a = trace(rho_a, "interreflection 1/2");
  const std::vector<Rgb> rho_b = LambertAlbedo(s, &e_a);
  const std::vector<Rgb> e_b = trace(rho_b, "interreflection 2/2");
  const std::vector<Rgb> g_b = LambertAlbedo(s, &e_b);
  std::vector<Rgb> e(s.size());
  for (int t = 0; t < s.num_texels; ++t)
    for (int c = 0; c < 3; ++c) {
      const double h_a = rho_b[t][c] - rho_a[t][c], h_b = g_b[t][c] - rho_b[t][c];
      const double lambda = std::abs(h_a - h_b) > 1e-12 ? std::clamp(h_a / (h_a - h_b), 0.0, 1.0) : 1.0;
      for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i)
        e[i][c] = std::max(0.0, e_a[i][c] + lambda * (e_b[i][c] - e_a[i][c]));
    }
  const std::vector<Rgb> rho = LambertAlbedo(s, &e);
  double removed = 0, total = 0;
  int64_t over = 0;
  for (int64_t i = 0; i < s.size(); ++i) {
    double r = 0, y = 0;
    for (int c = 0; c < 3; ++c) {
      const double d = std::min<double>(s.y[c][i], rho[s.texel[i]][c] / kPi * e[i][c]);
      r += d, y += s.y[c][i];
      s.y[c][i] = float(s.y[c][i] - d);
    }
    removed += r, total += y;
    const double share = y > 0 ? r / y : 0.0;
    over += share > 0.05;
    rep.max_share = std::max(rep.max_share, share);
  }
  rep.removed_share = total > 0 ? removed / total : 0.0;
  rep.samples_over_5pc = double(over) / double(s.size());
  return rep;
}

std::vector<Rgb> TraceIndirectWithMaterial(const Scene& scene, const GatherResult& g, const Material& material,
                                           const InterreflectionOptions& o, const std::vector<char>* sees_object_in) {
  o.Check();
  const SampleSet& s = g.samples;
  if (size_t(s.num_texels) != g.atlas.texels.size() || material.width != g.atlas.width ||
      material.height != g.atlas.height)
    throw Error("internal: interreflection: samples, atlas and material disagree on the texels");
  std::vector<Rgb> out(s.size(), Rgb::Zero());
  if (o.bounces == 0 || s.size() == 0) return out;
  if (sees_object_in && sees_object_in->size() != size_t(s.num_texels))
    throw Error("internal: interreflection: the texels seeing the object are of another atlas");
  const std::vector<char> traced = sees_object_in ? std::vector<char>() : TexelsThatSeeTheObject(g, o);
  const std::vector<char>& sees_object = sees_object_in ? *sees_object_in : traced;
  const RayTracer tracer(material.mesh);
  const MaterialShader shader(material);
  const std::vector<LightPaths> paths = PathsPerImage(scene, tracer, shader);
  const int K = int(material.basis.size());
  Progress bar("interreflection with the fit", s.num_texels, o.progress);
  ParallelFor(s.num_texels, o.threads, [&](long t) {
    bar.Tick();
    if (!sees_object[t]) return;
    const Texel& tx = g.atlas.texels[t];
    const Frame frame = Frame::FromNormalTangent(tx.normal, tx.tangent);
    const Vec3 origin = tx.position + tx.normal * LightPaths::kSceneScale;
    std::vector<Rgb> w(K);
    for (int k = 0; k < K; ++k)
      for (int c = 0; c < 3; ++c) w[k][c] = material.weights[k].at(tx.x, tx.y, c);
    auto leave = [&](const Vec3&) { return origin; };
    for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) {
      const LightPaths& lp = paths[s.image[i]];
      const LightSample ls = lp.LightAt(tx.position);
      if (!(ls.normal_irradiance > 0).all()) continue;
      const Vec3 wo = (lp.eye() - tx.position).normalized();
      const Vec3 wo_local = frame.ToLocal(wo);
      auto f = [&](const Vec3& wi_world) {
        const Vec3 wi = frame.ToLocal(wi_world);
        Rgb v = Rgb::Zero();
        if (wi.z() <= 0) return v;
        for (int k = 0; k < K; ++k)
          if ((w[k] > 0).any()) v += w[k] * EvalModelD(material.basis[k].spec, material.basis[k].params.data(), wi, wo_local);
        return v;
      };
      Rng rng(StreamSeed(o.seed, uint64_t(i), 2));
      const Rgb radiance = lp.Indirect(frame, f, leave, o.bounces, o.refit_paths, rng, &wo);
      const double m = ls.normal_irradiance.mean();
      for (int c = 0; c < 3; ++c) out[i][c] = radiance[c] * m / ls.normal_irradiance[c];
    }
  }, 16);
  return out;
}

}  // namespace svbrdf
