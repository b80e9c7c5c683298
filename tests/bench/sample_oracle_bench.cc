// Oracle of sample quality (bench_results/independent.md, "Stop 18: sample
// quality on the bunny"): every gathered sample against the prediction of the
// capture's true material at its texel centre, the residual's distribution by
// sample class (footprint probe, gather.h), and a reconstruction without the
// worst samples (an upper bound of what rejecting samples can gain).
// ORACLE_EXACT=n also predicts every sample by the true material averaged
// over n x n rays through each pixel of its bilinear lookup (each ray's own
// normal, light and view directions), as the photo integrates it, against
// the texel-centre prediction that every fit uses.
//
// Usage: sample_oracle_bench SCENE TRUTH_MATERIAL OUT [DROP_FRACTION [PROBE_RAYS [CLASSES]]]
//   TRUTH_MATERIAL: a material folder on the atlas gather makes for SCENE
//   (scripts/mitsuba_truth_material.py). DROP_FRACTION (default 0 = report
//   only, no reconstruction): drop this share of the samples with the largest
//   relative residual and reconstruct (CLI defaults) into OUT. CLASSES
//   (e.g. "foreign,unlit"): drop the samples of these classes instead.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "brdf/model.h"
#include "fit/fit.h"
#include "io/scene.h"
#include "light/light.h"
#include "raytrace/raytracer.h"
#include "core/error.h"
#include "io/material.h"
#include "io/output_folder.h"
#include "pipeline/reconstruction.h"

using namespace svbrdf;

namespace {

const char* kClassNames[] = {"foreign (occluding edge/silhouette)", "unlit part (shadow boundary)", "chart-border texel",
                             "normal spread > 5 deg", "grazing (cos < 0.3)", "rest"};
constexpr int kClasses = 6;

bool NextToChartBorder(const Atlas& a, const Texel& t) {
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int x = t.x + dx, y = t.y + dy;
      if (x < 0 || y < 0 || x >= a.width || y >= a.height) return true;
      const int i = a.At(x, y);
      if (i < 0 || !a.texels[i].interior) return true;
    }
  return false;
}

int Classify(const GatherResult& g, int64_t s) {
  const SampleProbe& p = g.probes[s];
  if (p.foreign > 0) return 0;
  if (p.unlit > 0) return 1;
  if (NextToChartBorder(g.atlas, g.atlas.texels[g.samples.texel[s]])) return 2;
  if (p.spread_deg > 5) return 3;
  if (std::min(g.samples.wi[2][s], g.samples.wo[2][s]) < 0.3f) return 4;
  return 5;
}

struct Residuals {
  std::vector<double> abs2, rel;
  std::vector<int> cls;
};

Residuals Compute(const GatherResult& g, const Material& truth) {
  if (truth.width != g.atlas.width || truth.height != g.atlas.height)
    throw Error(Msg("truth material is ", truth.width, "x", truth.height, ", the atlas ", g.atlas.width, "x",
                    g.atlas.height));
  const SampleSet& ss = g.samples;
  Residuals r;
  r.abs2.resize(ss.size());
  r.rel.resize(ss.size());
  r.cls.resize(ss.size());
  std::vector<double> pn(ss.size());
  for (int64_t s = 0; s < ss.size(); ++s) {
    const Texel& t = g.atlas.texels[ss.texel[s]];
    const Vec3 wi(ss.wi[0][s], ss.wi[1][s], ss.wi[2][s]), wo(ss.wo[0][s], ss.wo[1][s], ss.wo[2][s]);
    Rgb f = Rgb::Zero();
    for (size_t k = 0; k < truth.basis.size(); ++k) {
      // PredictSample includes the geometry factor and the footprint
      // sub-samples when gathered (GatherOptions::footprint_subsamples).
      const Rgb fk = PredictSample(truth.basis[k].spec, truth.basis[k].params.data(), ss, s) / double(ss.geom[s]);
      for (int c = 0; c < 3; ++c) f[c] += truth.weights[k].at(t.x, t.y, c) * fk[c];
    }
    double e2 = 0, p2 = 0;
    for (int c = 0; c < 3; ++c) {
      const double p = f[c] * ss.geom[s];
      e2 += (ss.y[c][s] - p) * (ss.y[c][s] - p);
      p2 += p * p;
    }
    r.abs2[s] = e2;
    pn[s] = std::sqrt(p2);
    r.cls[s] = Classify(g, s);
  }
  std::vector<double> sorted = pn;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double floor = 0.1 * sorted[sorted.size() / 2];
  for (int64_t s = 0; s < ss.size(); ++s) r.rel[s] = std::sqrt(r.abs2[s]) / std::max(pn[s], floor);
  return r;
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(q * v.size()));
  std::nth_element(v.begin(), v.begin() + i, v.end());
  return v[i];
}

void Report(const Residuals& r) {
  double total = 0;
  for (double e : r.abs2) total += e;
  std::printf("%-38s %8s %7s %8s %9s %9s %9s\n", "class", "samples", "share", "sq.err", "rel p50", "rel p90", "rel p99");
  for (int c = 0; c < kClasses; ++c) {
    std::vector<double> rel;
    double e = 0;
    for (size_t s = 0; s < r.cls.size(); ++s)
      if (r.cls[s] == c) rel.push_back(r.rel[s]), e += r.abs2[s];
    std::printf("%-38s %8zu %6.1f%% %7.1f%% %9.4f %9.4f %9.4f\n", kClassNames[c], rel.size(),
                100.0 * rel.size() / r.cls.size(), 100 * e / total, Quantile(rel, 0.5), Quantile(rel, 0.9),
                Quantile(rel, 0.99));
  }
  std::printf("%-38s %8zu %6.1f%% %7.1f%% %9.4f %9.4f %9.4f\n", "all", r.rel.size(), 100.0, 100.0,
              Quantile(r.rel, 0.5), Quantile(r.rel, 0.9), Quantile(r.rel, 0.99));
}


// ORACLE_EXACT: the true material's prediction of sample s averaged over the
// lookup's rays (n x n per pixel, weighted like the bilinear lookup; rays
// that miss or meet another surface are left out), in the sample's units
// (samples.h: y = f cos_i E / E(x) at the texel's irradiance).
Rgb FootprintPrediction(const GatherResult& g, const Scene& scene, const RayTracer& tracer, const Material& truth,
                        int64_t s, int n) {
  const SampleSet& ss = g.samples;
  const Texel& tx = g.atlas.texels[ss.texel[s]];
  const ImageEntry& e = scene.images[ss.image[s]];
  const Camera& cam = scene.CameraById(e.camera);
  const Light& light = scene.LightById(e.light);
  const Rigid3 world_from_cam = e.cam_from_world.Inverse();
  const Vec3 eye = e.cam_from_world.CentreInWorld();
  const Vec2 px = cam.Project(e.cam_from_world * tx.position);
  const double tolerance = 3.0 * (eye - tx.position).norm() / cam.fx() / 0.2;
  const LightSample centre = SampleLight(light, tx.position, world_from_cam.rotation, eye);
  const double centre_irradiance = tx.normal.dot(centre.wi) * centre.normal_irradiance.mean();
  const double fx = px.x() - 0.5 - std::floor(px.x() - 0.5), fy = px.y() - 0.5 - std::floor(px.y() - 0.5);
  const int x0 = int(std::floor(px.x() - 0.5)), y0 = int(std::floor(px.y() - 0.5));
  Rgb sum = Rgb::Zero();
  double total = 0;
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const double w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) / (n * n);
      for (int sy = 0; w > 0 && sy < n; ++sy)
        for (int sx = 0; sx < n; ++sx) {
          Hit h;
          const Vec2 p(x0 + dx + (sx + 0.5) / n, y0 + dy + (sy + 0.5) / n);
          if (!tracer.Intersect(eye, world_from_cam.rotation * cam.Unproject(p), &h)) continue;
          const Vec3 q = tracer.Position(h);
          if ((q - tx.position).norm() > tolerance) continue;
          total += w;
          const LightSample ls = SampleLight(light, q, world_from_cam.rotation, eye);
          const Frame frame = Frame::FromNormalTangent(tracer.ShadingNormal(h), tx.tangent);
          const Vec3 wi = frame.ToLocal(ls.wi), wo = frame.ToLocal((eye - q).normalized());
          if (wi.z() <= 0 || wo.z() <= 0) continue;
          Rgb f = Rgb::Zero();
          for (size_t k = 0; k < truth.basis.size(); ++k) {
            const Rgb fk = EvalModelD(truth.basis[k].spec, truth.basis[k].params.data(), wi, wo);
            for (int c = 0; c < 3; ++c) f[c] += truth.weights[k].at(tx.x, tx.y, c) * fk[c];
          }
          sum += w * f * (wi.z() * ls.normal_irradiance.mean());
        }
    }
  if (!(total > 0) || !(centre_irradiance > 0)) return Rgb::Constant(std::nan(""));
  // geom = cos_i s at the texel centre: divide it out again.
  return sum / total / centre_irradiance * double(ss.geom[s]);
}

void ReportFootprintPrediction(const GatherResult& g, const Scene& scene, const Material& truth, const Residuals& r,
                               int n) {
  const RayTracer tracer(g.mesh);
  const SampleSet& ss = g.samples;
  std::vector<double> rel_centre, rel_footprint;
  double sse_centre = 0, sse_footprint = 0;
  for (int64_t s = 0; s < ss.size(); ++s) {
    const Rgb p = FootprintPrediction(g, scene, tracer, truth, s, n);
    if (!std::isfinite(p[0])) continue;
    double e2 = 0;
    for (int c = 0; c < 3; ++c) e2 += (ss.y[c][s] - p[c]) * (ss.y[c][s] - p[c]);
    // Relative to the same norm as Residuals::rel (the centre prediction's).
    const double norm = r.rel[s] > 0 ? std::sqrt(r.abs2[s]) / r.rel[s] : 0;
    rel_centre.push_back(r.rel[s]);
    rel_footprint.push_back(norm > 0 ? std::sqrt(e2) / norm : 0);
    sse_centre += r.abs2[s], sse_footprint += e2;
  }
  std::printf("truth as the fits predict it:     rel p50 %.4f p90 %.4f p99 %.4f, squared error %.4g (%zu samples)\n",
              Quantile(rel_centre, 0.5), Quantile(rel_centre, 0.9), Quantile(rel_centre, 0.99), sse_centre,
              rel_centre.size());
  std::printf("truth over the lookup's %dx%d rays: rel p50 %.4f p90 %.4f p99 %.4f, squared error %.4g\n", n, n,
              Quantile(rel_footprint, 0.5), Quantile(rel_footprint, 0.9), Quantile(rel_footprint, 0.99),
              sse_footprint);
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s SCENE TRUTH_MATERIAL OUT [DROP_FRACTION [PROBE_RAYS [CLASSES]]]\n", argv[0]);
    return 2;
  }
  const double drop = argc > 4 ? std::atof(argv[4]) : 0.0;
  const std::string classes = argc > 6 ? argv[6] : "";
  const Material truth = LoadMaterial(argv[2]);
  ReconstructionJob job;
  job.scene_path = argv[1];
  job.gather.probe_rays = argc > 5 ? std::atoi(argv[5]) : 2;
  if (const char* f = std::getenv("ORACLE_FOOTPRINT")) job.gather.footprint_subsamples = std::atoi(f);
  job.gather.threads = job.estimate.threads;
  job.estimate.fit.threads = job.estimate.threads;
  job.estimate.fit.seed = job.estimate.seed;
  bool reconstruct = drop > 0 || !classes.empty();
  job.after_gather = [&](GatherResult& g) {
    const Residuals r = Compute(g, truth);
    Report(r);
    if (const char* exact = std::getenv("ORACLE_EXACT"))
      ReportFootprintPrediction(g, LoadScene(job.scene_path), truth, r, std::max(1, std::atoi(exact)));
    if (const char* dump = std::getenv("ORACLE_DUMP")) {
      // float32 columns per sample: rel, abs2, foreign, unlit, spread, contrast, chart border, cos_i, cos_o, image, texel
      FILE* f = std::fopen(dump, "wb");
      for (int64_t s = 0; s < g.samples.size(); ++s) {
        const SampleProbe& p = g.probes[s];
        const float row[11] = {float(r.rel[s]), float(r.abs2[s]), p.foreign, p.unlit, p.spread_deg, p.contrast,
                               float(NextToChartBorder(g.atlas, g.atlas.texels[g.samples.texel[s]])),
                               g.samples.wi[2][s], g.samples.wo[2][s], float(g.samples.image[s]),
                               float(g.samples.texel[s])};
        std::fwrite(row, sizeof row, 1, f);
      }
      std::fclose(f);
    }
    if (!reconstruct) throw Error("report only");
    std::vector<char> keep(r.rel.size(), 1);
    if (!classes.empty()) {
      for (size_t s = 0; s < keep.size(); ++s)
        if (classes.find(std::string(kClassNames[r.cls[s]]).substr(0, 4)) != std::string::npos) keep[s] = 0;
    } else {
      const double limit = Quantile(r.rel, 1 - drop);
      for (size_t s = 0; s < keep.size(); ++s) keep[s] = r.rel[s] <= limit;
    }
    g.samples = KeepSamples(g.samples, keep);
    g.probes.clear();
    long kept = 0;
    for (char k : keep) kept += k;
    std::printf("kept %ld of %zu samples\n", kept, keep.size());
    std::fflush(stdout);
  };
  OutputFolder out(argv[3]);
  job.out_dir = out.path();
  RunReconstruction(job);
  out.Commit();
  return 0;
} catch (const Error& e) {
  std::fprintf(stderr, "%s\n", e.what());
  return std::string(e.what()) == "report only" ? 0 : 1;
}
