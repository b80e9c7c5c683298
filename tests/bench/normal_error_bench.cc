// Diagnostic (not a timed benchmark): where the refined normals' error comes
// from, on a synthetic capture with a ground-truth normal map (gt/).
//
//   normal_error_bench CAPTURE [MATERIAL] [key=value ...]
//
// Per texel: the angle between a normal estimate and the true normal (the
// truth's map at the texel centre), the distribution per true material
// (texels whose true weight of one material > 0.99), and the features that
// could explain an outlier: the texel's sample count, how close its nearest
// sample's half vector comes to the true normal (no sample near the
// highlight: a glossy lobe cannot place the normal), how much the true normal
// turns over its 8 neighbours (pooling their samples blurs it), a material
// border in the neighbourhood, and whether a brute-force grid over tilts
// finds a lower cost than the Levenberg-Marquardt fit (a local minimum).
// Estimates compared: MATERIAL's normal map (a reconstruction), and
// RefineNormals run here with the TRUE basis and TRUE weights (so that only
// the normal fit itself is measured), with NormalOptions fields overridden by
// key=value (neighbour_weight, prior_tilt, iterations, robust_sigmas,
// min_samples, max_iterations; start=truth starts every fit at the true tilt).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "atlas/atlas.h"
#include "cluster/reconstruct.h"
#include "gather/gather.h"
#include "io/material.h"
#include "io/scene.h"
#include "normals/normal_cost.h"
#include "normals/normal_map.h"
#include "normals/refine.h"

using namespace svbrdf;

namespace {

double AngleDeg(const Vec3& a, const Vec3& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / kPi;
}

Vec2 TexelUv(const Texel& tx, const Atlas& atlas) {
  return Vec2((tx.x + 0.5) / atlas.width, 1.0 - (tx.y + 0.5) / atlas.height);
}

double MapAt(const Image& img, const Vec2& uv, int c) {
  const Vec2 p = UvToTexel(uv, img.width, img.height);
  return img.Bilinear(p.x(), p.y(), c);
}

struct Features {
  int samples = 0;
  double highlight_deg = 90;  // smallest angle between a sample's half vector and the true normal
  double spread_deg = 0;      // mean angle between the true normal and its 8 neighbours'
  bool border = false;        // another true material in the 3 x 3 neighbourhood
  int material = -1;          // true material when pure (weight share > 0.99), else -1
};

void Percentiles(const char* name, std::vector<double> v) {
  if (v.empty()) return;
  std::sort(v.begin(), v.end());
  double sum = 0, top = 0;
  for (double d : v) sum += d;
  const size_t n = v.size();
  for (size_t i = n - n / 10; i < n; ++i) top += v[i];
  auto q = [&](double p) { return v[std::min(n - 1, size_t(p * n))]; };
  std::printf("  %-28s n %6zu  mean %5.2f  p50 %5.2f  p75 %5.2f  p90 %5.2f  p95 %5.2f  p99 %5.2f  max %6.2f  "
              "worst 10%% hold %4.1f%% of the sum\n",
              name, n, sum / n, q(0.5), q(0.75), q(0.9), q(0.95), q(0.99), v.back(), 100 * top / sum);
}

// The error table of one estimate, split by material and by feature bins.
void Report(const char* title, const std::vector<double>& err, const std::vector<Features>& f, int K) {
  std::printf("%s\n", title);
  std::vector<double> all;
  for (size_t t = 0; t < err.size(); ++t) all.push_back(err[t]);
  Percentiles("all texels", all);
  for (int k = -1; k < K; ++k) {
    std::vector<double> v, in, bord, nohl, hl, lown, smooth, rough;
    for (size_t t = 0; t < err.size(); ++t) {
      if (f[t].material != k) continue;
      v.push_back(err[t]);
      (f[t].border ? bord : in).push_back(err[t]);
      (f[t].highlight_deg > 6 ? nohl : hl).push_back(err[t]);
      if (f[t].samples < 8) lown.push_back(err[t]);
      (f[t].spread_deg > 1.5 ? rough : smooth).push_back(err[t]);
    }
    char name[64];
    std::snprintf(name, sizeof name, k < 0 ? "mixed texels" : "true material %d", k);
    Percentiles(name, v);
    Percentiles("  no border", in);
    Percentiles("  border", bord);
    Percentiles("  a sample's h within 6 deg", hl);
    Percentiles("  no h within 6 deg", nohl);
    Percentiles("  < 8 own samples", lown);
    Percentiles("  truth turns < 1.5 deg/texel", smooth);
    Percentiles("  truth turns > 1.5 deg/texel", rough);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s CAPTURE [MATERIAL] [key=value ...]\n", argv[0]);
    return 2;
  }
  const std::string cap = argv[1];
  std::string material_dir;
  NormalOptions no;
  no.mode = "force";
  no.progress = false;
  no.material_rounds = 0;
  bool start_truth = false;
  std::string write_dir;  // write=DIR: normal maps truth128.exr, refined.exr, grid.exr there
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    const size_t eq = a.find('=');
    if (a.rfind("write=", 0) == 0) {
      write_dir = a.substr(6);
      continue;
    }
    if (eq == std::string::npos) {
      material_dir = a;
      continue;
    }
    const std::string k = a.substr(0, eq);
    const double v = std::stod(a.substr(eq + 1) == "truth" ? "1" : a.substr(eq + 1));
    if (k == "neighbour_weight") no.neighbour_weight = v;
    else if (k == "prior_tilt") no.prior_tilt = v;
    else if (k == "iterations") no.iterations = int(v);
    else if (k == "robust_sigmas") no.robust_sigmas = v;
    else if (k == "min_samples") no.min_samples = int(v);
    else if (k == "smooth_tilt") no.smooth_tilt = v;
    else if (k == "min_own_samples") no.min_own_samples = int(v);
    else if (k == "max_iterations") no.max_iterations = int(v);
    else if (k == "start") start_truth = true;
    else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  const Scene scene = LoadScene(cap + "/scene.json");
  GatherOptions go;
  go.progress = false;
  const GatherResult g = Gather(scene, go);
  const Atlas& atlas = g.atlas;
  const SampleSet& s = g.samples;
  const Material truth = LoadMaterial(cap + "/gt");
  const int K = int(truth.basis.size()), nt = s.num_texels;

  // Truth per texel: normal (and its tilt in the mesh frame), weights.
  std::vector<Vec3> true_n(nt);
  std::vector<Vec2> true_ab(nt);
  SvbrdfEstimate est;
  est.basis = truth.basis;
  est.num_texels = nt;
  est.per_channel_weights = true;
  est.weights.assign(size_t(nt) * K * 3, 0.0f);
  est.label.assign(nt, 0);
  std::vector<Features> f(nt);
  for (int t = 0; t < nt; ++t) {
    const Texel& tx = atlas.texels[t];
    true_n[t] = MaterialNormal(truth, tx, atlas);
    const Vec3 l = Frame::FromNormalTangent(tx.normal, tx.tangent).ToLocal(true_n[t]);
    true_ab[t] = Vec2(l.x() / l.z(), l.y() / l.z());
    double most = -1, total = 0;
    for (int k = 0; k < K; ++k) {
      double sum = 0;
      for (int c = 0; c < 3; ++c) {
        const double w = std::max(0.0, MapAt(truth.weights[k], TexelUv(tx, atlas), c));
        est.weights[(size_t(t) * K + k) * 3 + c] = float(w);
        sum += w;
      }
      total += sum;
      if (sum > most) most = sum, est.label[t] = k;
    }
    f[t].material = total > 0 && most > 0.99 * total ? est.label[t] : -1;
    f[t].samples = int(s.texel_begin[t + 1] - s.texel_begin[t]);
    for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) {
      const Vec3 h = (Vec3(s.wi[0][i], s.wi[1][i], s.wi[2][i]) + Vec3(s.wo[0][i], s.wo[1][i], s.wo[2][i])).normalized();
      f[t].highlight_deg = std::min(f[t].highlight_deg, AngleDeg(h, l));
    }
  }
  for (int t = 0; t < nt; ++t) {
    const Texel& tx = atlas.texels[t];
    double sum = 0;
    int n = 0;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int x = tx.x + dx, y = tx.y + dy;
        if (!(dx || dy) || x < 0 || y < 0 || x >= atlas.width || y >= atlas.height || atlas.At(x, y) < 0) continue;
        const int u = atlas.At(x, y);
        sum += AngleDeg(true_n[t], true_n[u]), ++n;
        if (est.label[u] != est.label[t]) f[t].border = true;
      }
    f[t].spread_deg = n ? sum / n : 0;
  }
  std::vector<double> err(nt);
  for (int t = 0; t < nt; ++t) err[t] = AngleDeg(atlas.texels[t].normal, true_n[t]);
  Report("== mesh normals", err, f, K);

  if (!material_dir.empty()) {
    const Material m = LoadMaterial(material_dir);
    for (int t = 0; t < nt; ++t) err[t] = AngleDeg(MaterialNormal(m, atlas.texels[t], atlas), true_n[t]);
    Report(("== " + material_dir + " (its normal map)").c_str(), err, f, K);
  }

  // RefineNormals with the true basis and weights.
  const NormalRefinement nr = RefineNormals(s, atlas, est, no, start_truth ? &true_ab : nullptr);
  for (int t = 0; t < nt; ++t) err[t] = AngleDeg(nr.normal[t], true_n[t]);
  std::printf("refinement: %s\n", nr.Report().c_str());
  Report("== RefineNormals with the true basis and weights", err, f, K);

  // Brute force on the own samples, true basis and weights fixed, least
  // squares: the grid's best tilt vs the fit's, and the true tilt's cost.
  std::vector<double> grid_err(nt, 0), lm_vs_grid(nt, 0);
  std::vector<Vec2> grid_ab(nt, Vec2::Zero());
  long local_minima = 0, fitted = 0;
  for (int t = 0; t < nt; ++t) {
    if (f[t].samples < 3) continue;
    std::vector<normals::TexelSample> ts;
    for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) {
      normals::TexelSample x;
      for (int c = 0; c < 3; ++c) x.wi[c] = s.wi[c][i], x.wo[c] = s.wo[c][i], x.y[c] = s.y[c][i];
      x.geom = s.geom[i];
      ts.push_back(x);
    }
    std::vector<normals::WeightedBasis> basis;
    for (int k = 0; k < K; ++k) {
      normals::WeightedBasis b;
      b.spec = &est.basis[k].spec;
      b.params = est.basis[k].params;
      for (int c = 0; c < 3; ++c) b.w[c] = est.weights[(size_t(t) * K + k) * 3 + c];
      basis.push_back(b);
    }
    auto cost = [&](double a, double b) {
      const double ab[2] = {a, b};
      double c = 0;
      for (const auto& x : ts) {
        double r[3];
        normals::NormalSampleCost{&x, &basis}(ab, r);
        c += r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
      }
      return c;
    };
    // 1 degree steps over +-15 degrees, then 0.1 degree steps around the best.
    double best = 1e300, ba = 0, bb = 0;
    const double coarse = std::tan(1.0 * kPi / 180), fine = std::tan(0.1 * kPi / 180);
    for (int i = -15; i <= 15; ++i)
      for (int j = -15; j <= 15; ++j) {
        const double c = cost(i * coarse, j * coarse);
        if (c < best) best = c, ba = i * coarse, bb = j * coarse;
      }
    const double ca = ba, cb = bb;
    for (int i = -10; i <= 10; ++i)
      for (int j = -10; j <= 10; ++j) {
        const double c = cost(ca + i * fine, cb + j * fine);
        if (c < best) best = c, ba = ca + i * fine, bb = cb + j * fine;
      }
    const Vec3 gn = Frame::FromNormalTangent(atlas.texels[t].normal, atlas.texels[t].tangent).ToWorld(Vec3(ba, bb, 1));
    grid_err[t] = AngleDeg(gn, true_n[t]);
    grid_ab[t] = Vec2(ba, bb);
    lm_vs_grid[t] = AngleDeg(gn, nr.normal[t]);
    ++fitted;
    const double lm_cost = cost(nr.tilt[t].x(), nr.tilt[t].y());
    if (lm_vs_grid[t] > 1.0 && lm_cost > 1.2 * best) ++local_minima;
  }
  if (!write_dir.empty()) {
    std::vector<Vec3> grid_n(nt);
    for (int t = 0; t < nt; ++t) grid_n[t] = grid_ab[t].allFinite() ? Frame::FromNormalTangent(atlas.texels[t].normal, atlas.texels[t].tangent).ToWorld(Vec3(grid_ab[t].x(), grid_ab[t].y(), 1)).normalized() : atlas.texels[t].normal;
    WriteImage(write_dir + "/truth128.exr", NormalMapImage(atlas, true_n, NormalMapSpace::kWorld));
    WriteImage(write_dir + "/refined.exr", NormalMapImage(atlas, nr.normal, NormalMapSpace::kWorld));
    WriteImage(write_dir + "/grid.exr", NormalMapImage(atlas, grid_n, NormalMapSpace::kWorld));
  }
  Report("== grid over tilts (own samples only, true basis and weights, least squares)", grid_err, f, K);
  Report("== angle between the grid's tilt and RefineNormals'", lm_vs_grid, f, K);
  std::printf("texels where the grid's tilt is > 1 deg away and its own-sample cost < 1/1.2 of the fit's: %ld of %ld\n",
              local_minima, fitted);
  return 0;
}
