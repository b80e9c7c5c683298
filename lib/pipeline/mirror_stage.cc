#include "pipeline/mirror_stage.h"

#include <algorithm>
#include <cmath>

#include "cluster/holdout.h"
#include "cluster/stats.h"
#include "core/error.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "fit/fit.h"
#include "gather/lookup_rays.h"
#include "raytrace/raytracer.h"
#include "relight/light_paths.h"
#include "relight/shader.h"

namespace svbrdf {

void MirrorOptions::Check() const {
  if (!(max_direct_albedo >= 0)) throw Error(Msg("mirror stage: max_direct_albedo must be >= 0, got ", max_direct_albedo));
  if (bounces < 0 || paths < 1) throw Error(Msg("mirror stage: bounces >= 0 and paths >= 1, got ", bounces, ", ", paths));
  if (lookup_rays < 0 || lookup_rays > 8)
    throw Error(Msg("reconstruct: --mirror-lookup-rays must be in [0, 8] (rays per pixel side), got ", lookup_rays));
}

double MirrorF0(const std::vector<double>& y, const std::vector<double>& base, const std::vector<double>& w,
                const std::vector<double>& s5, const std::vector<double>& l) {
  double num = 0, den = 0;
  for (size_t i = 0; i < y.size(); ++i) {
    const double a = w[i] * (1 - s5[i]) * l[i];
    num += (y[i] - base[i] - w[i] * s5[i] * l[i]) * a;
    den += a * a;
  }
  return den > 0 ? std::clamp(num / den, 0.0, 1.0) : 0.0;
}

namespace {

// Per sample of the texels of one material: what the fit and the test need.
struct MirrorSamples {
  std::vector<int64_t> ids;       // into the sample set
  std::vector<Rgb> base, own, l;  // others' share, the material's own share (as fitted), mirror radiance (y units)
  std::vector<double> w;          // the material's weight (channel mean)
  std::vector<Rgb> s5;            // (1 - mu)^5, over the footprint's normals weighted by their radiance
};

}  // namespace

MirrorReport FitMirrors(const Scene& scene, const GatherResult& g, const ReconstructOptions& eo,
                        const MirrorOptions& o, SvbrdfEstimate* est, const std::array<std::vector<float>, 3>* raw) {
  o.Check();
  MirrorReport rep;
  const SampleSet& s = g.samples;
  const int K = int(est->basis.size());
  if (!o.enabled || K == 0 || s.size() == 0) return rep;
  if (est->weights.size() != size_t(s.num_texels) * K * 3 || est->label.size() != size_t(s.num_texels))
    throw Error("internal: mirror stage: weights or labels do not match the samples' texels");
  std::vector<int> tried;
  for (int k = 0; k < K; ++k) {
    const BasisMaterial& b = est->basis[k];
    if (b.spec.family == Family::kMirror) continue;
    if (MaxDirectionalAlbedo(b.spec, b.params.data()) < o.max_direct_albedo) tried.push_back(k);
  }
  if (tried.empty()) return rep;
  if (raw)
    for (int c = 0; c < 3; ++c)
      if (int64_t((*raw)[c].size()) != s.size()) throw Error("internal: mirror stage: raw samples do not match");
  // The mirror's target: y plus its weight's share of the removed indirect light.
  auto target = [&](const MirrorSamples& m, size_t e, int c) {
    const int64_t i = m.ids[e];
    return raw ? s.y[c][i] + m.w[e] * std::max(0.0f, (*raw)[c][i] - s.y[c][i]) : double(s.y[c][i]);
  };

  const Material material = MixedMaterial(est->basis, est->weights, g.atlas, g.mesh);
  const RayTracer tracer(material.mesh);
  const MaterialShader shader(material);
  const std::vector<LightPaths> paths = PathsPerImage(scene, tracer, shader);
  const std::vector<char> held = HeldOutImages(int(scene.images.size()), eo.holdout_fraction, eo.seed);
  auto weight = [&](int t, int k) {
    const float* w = &est->weights[(size_t(t) * K + k) * 3];
    return Rgb(w[0], w[1], w[2]);
  };

  for (const int k : tried) {
    std::vector<int> texels;
    for (int t = 0; t < s.num_texels; ++t)
      if (est->label[t] == k && s.texel_begin[t + 1] > s.texel_begin[t]) texels.push_back(t);
    if (texels.empty()) continue;
    // Per texel: its samples' shares and the radiance their mirror directions see.
    std::vector<MirrorSamples> per(texels.size());
    ParallelFor(long(texels.size()), eo.threads, [&](long j) {
      const int t = texels[j];
      const Texel& tx = g.atlas.texels[t];
      const Frame frame = Frame::FromNormalTangent(tx.normal, tx.tangent);
      const Vec3 origin = tx.position + tx.normal * LightPaths::kSceneScale;
      MirrorSamples& m = per[j];
      for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) {
        const LightPaths& lp = paths[s.image[i]];
        const LightSample ls = lp.LightAt(tx.position);
        if (!(ls.normal_irradiance > 0).all()) continue;
        const Vec3 wo = (lp.eye() - tx.position).normalized();
        if (!(tx.normal.dot(wo) > 0)) continue;
        Rgb base = Rgb::Zero(), own = Rgb::Zero();
        for (int q = 0; q < K; ++q) {
          const Rgb wq = weight(t, q);
          if (!(wq > 0).any()) continue;
          const Rgb f = wq * PredictSample(est->basis[q].spec, est->basis[q].params.data(), s, i);
          (q == k ? own : base) += f;
        }
        // The radiance arriving from the mirror direction, in y's units
        // (y_c = radiance_c m / E_c, m the mean of E: gather.cc), weighted
        // as the photo lookup: by default one direction per pixel of the
        // lookup, about its mean normal (SampleSet::footprint); with
        // MirrorOptions::lookup_rays, n x n rays through each pixel
        // (ForEachLookupRay), each traced about the shading normal it meets
        // on this patch (a curved mirror turns its reflection within a pixel).
        Rgb l = Rgb::Zero(), l_s5 = Rgb::Zero();
        auto mirror = [&](const Vec3& from, const Vec3& n, const Vec3& to_eye, double weight, uint64_t stream) {
          const double mu = n.dot(to_eye);
          if (!(mu > 0) || !(weight > 0)) return;
          const Vec3 r = 2 * mu * n - to_eye;
          Hit hit;
          if (!tracer.Intersect(from, r, &hit)) return;
          const LightPaths::Vertex v = lp.At(hit);
          Rgb lj = lp.Direct(v, -r);
          if (o.bounces > 0) {
            Rng rng(StreamSeed(eo.seed ^ 0x6d6972726f72ULL, uint64_t(i), stream));
            lj += lp.Indirect(v, -r, o.bounces, o.paths, rng);
          }
          l += weight * lj;
          l_s5 += weight * std::pow(1 - std::min(mu, 1.0), 5) * lj;
        };
        double on_patch = 0;  // lookup weight of the rays that meet this patch
        const ImageEntry& entry = scene.images[s.image[i]];
        const Vec3 xc = entry.cam_from_world * tx.position;
        if (o.lookup_rays > 0 && xc.z() > 1e-9) {
          const Camera& cam = scene.CameraById(entry.camera);
          const Vec2 px = cam.Project(xc);
          const double tolerance = LookupPatchTolerance((lp.eye() - tx.position).norm(), cam.fx(), tx.normal.dot(wo));
          uint64_t stream = 0;
          ForEachLookupRay(tracer, cam, entry.cam_from_world.Inverse(), lp.eye(), px.x(), px.y(), o.lookup_rays,
                           [&](double w, bool hit, const Hit& h, int) {
                             ++stream;
                             if (!hit) return;
                             const Vec3 q = tracer.Position(h);
                             if ((q - tx.position).norm() > tolerance) return;
                             const Vec3 ns = tracer.ShadingNormal(h);
                             const Vec3 ng = h.geometric_normal.dot(ns) < 0 ? Vec3(-h.geometric_normal)
                                                                              : Vec3(h.geometric_normal);
                             on_patch += w;
                             mirror(q + ng * LightPaths::kSceneScale, ns, (lp.eye() - q).normalized(), w, stream);
                           });
        }
        if (on_patch > 0) {
          l /= on_patch, l_s5 /= on_patch;
        } else if (s.HasFootprint()) {  // lookup_rays 0 (or no ray met the patch): the footprint's mean normals
          const float* fp = &s.footprint[size_t(i) * 3 * SampleSet::kFootprintSubsamples];
          for (int j = 0; j < SampleSet::kFootprintSubsamples; ++j, fp += 3)
            mirror(origin, frame.ToWorld(Vec3(fp[0], fp[1], 1.0).normalized()), wo, fp[2], uint64_t(j));
        } else {
          mirror(origin, tx.normal, wo, 1.0, 0);
        }
        const double mean_e = ls.normal_irradiance.mean();
        Rgb s5 = Rgb::Zero();
        for (int c = 0; c < 3; ++c) {
          s5[c] = l[c] > 0 ? l_s5[c] / l[c] : 0.0;
          l[c] *= mean_e / ls.normal_irradiance[c];
        }
        m.ids.push_back(i);
        m.base.push_back(base);
        m.own.push_back(own);
        m.l.push_back(l);
        m.w.push_back(weight(t, k).mean());
        m.s5.push_back(s5);
      }
    }, 8);
    // F0 per channel on the training photos' samples.
    Rgb f0;
    for (int c = 0; c < 3; ++c) {
      std::vector<double> y, base, w, s5, l;
      for (const MirrorSamples& m : per)
        for (size_t e = 0; e < m.ids.size(); ++e) {
          if (held[s.image[m.ids[e]]]) continue;
          y.push_back(target(m, e, c)), base.push_back(m.base[e][c]), w.push_back(m.w[e]);
          s5.push_back(m.s5[e][c]), l.push_back(m.l[e][c]);
        }
      f0[c] = MirrorF0(y, base, w, s5, l);
    }
    // Held-out squared errors per texel: the material as fitted against the mirror.
    std::vector<double> sse_fit, sse_mirror, count;
    std::vector<int64_t> held_ids;
    for (const MirrorSamples& m : per) {
      double a = 0, b = 0;
      int n = 0;
      for (size_t e = 0; e < m.ids.size(); ++e) {
        const int64_t i = m.ids[e];
        if (!held[s.image[i]]) continue;
        held_ids.push_back(i);
        ++n;
        for (int c = 0; c < 3; ++c) {
          const double y = s.y[c][i], y_mirror = target(m, e, c);
          const double mirror = m.base[e][c] + m.w[e] * (f0[c] + (1 - f0[c]) * m.s5[e][c]) * m.l[e][c];
          a += (y - m.base[e][c] - m.own[e][c]) * (y - m.base[e][c] - m.own[e][c]);
          b += (y_mirror - mirror) * (y_mirror - mirror);
        }
      }
      if (n == 0) continue;
      sse_fit.push_back(a), sse_mirror.push_back(b), count.push_back(3.0 * n);
    }
    if (held_ids.empty()) continue;
    // Without the worst 2 % of texels of either (as the split search's
    // TrimmedDrop): a mirror's prediction is heavy-tailed where its
    // reflection holds an edge (a reflected silhouette or highlight a
    // fraction of a pixel off), and those few texels must not outweigh the
    // others (a Mitsuba bull's polished chromium: better on most texels,
    // z = 15.9, yet a higher RMSE over all; docs/measurements.md).
    const std::vector<char> worst = WorstOfEither(sse_fit, sse_mirror);
    double sum_fit = 0, sum_mirror = 0, n = 0;
    for (size_t t = 0; t < worst.size(); ++t)
      if (!worst[t]) sum_fit += sse_fit[t], sum_mirror += sse_mirror[t], n += count[t];
    const double rmse_fit = std::sqrt(sum_fit / std::max(1.0, n)), rmse_mirror = std::sqrt(sum_mirror / std::max(1.0, n));
    const double margin = eo.parsimony * SignalRms(s, held_ids);
    const double z = ImprovementZ(sse_fit, sse_mirror);
    const bool take = rmse_fit - rmse_mirror > margin && z >= eo.model_min_z;
    rep.lines.push_back(Msg("m", k, " (", est->basis[k].spec.Label(), ", ", texels.size(), " texels): held-out RMSE ",
                            rmse_fit, " as fitted, ", rmse_mirror, " as a mirror (without the worst 2 % of texels) of F0 (",
                            f0[0], ", ", f0[1], ", ", f0[2], "), z = ", z, take ? ": a mirror" : ": kept"));
    if (!take) continue;
    BasisMaterial mirror;
    mirror.name = est->basis[k].name;
    mirror.spec = ModelSpec::FromLabel("mirror");
    mirror.params = {f0[0], f0[1], f0[2]};
    est->basis[k] = mirror;
    ++rep.replaced;
  }
  return rep;
}

}  // namespace svbrdf
