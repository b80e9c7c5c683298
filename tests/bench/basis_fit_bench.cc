// Diagnostic (not a timed benchmark): where a basis material's fitted
// parameters go wrong, on a synthetic capture with ground truth (gt/).
//
//   basis_fit_bench CAPTURE MATERIAL TRUE_K [min_weight=0.999]
//
// Fits the true material TRUE_K's model to the samples of texels whose true
// weight of it exceeds min_weight (pure texels), each sample divided by the
// texel's true weight, expressed in the frames of (a) the mesh normals,
// (b) the true normals, (c) MATERIAL's normal map (a reconstruction), by
// least squares and by the clustering's Cauchy refit (3 robust sigmas); then
// on the texels MATERIAL labels with its basis material matched to TRUE_K
// (largest overlap), as the clustering fits it, in MATERIAL's frames.
// Prints the parameters next to the truth's.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "atlas/atlas.h"
#include "fit/fit.h"
#include "gather/gather.h"
#include "io/material.h"
#include "io/scene.h"
#include "normals/normal_map.h"
#include "normals/refine.h"

using namespace svbrdf;

namespace {

Vec2 TexelUv(const Texel& tx, const Atlas& atlas) {
  return Vec2((tx.x + 0.5) / atlas.width, 1.0 - (tx.y + 0.5) / atlas.height);
}

double MapAt(const Image& img, const Vec2& uv, int c) {
  const Vec2 p = UvToTexel(uv, img.width, img.height);
  return img.Bilinear(p.x(), p.y(), c);
}

std::vector<Vec2> Tilts(const Atlas& atlas, const Material& m) {
  std::vector<Vec2> ab(atlas.texels.size(), Vec2::Zero());
  if (!m.normal_map.width) return ab;
  for (size_t t = 0; t < atlas.texels.size(); ++t) {
    const Texel& tx = atlas.texels[t];
    const Vec3 l = Frame::FromNormalTangent(tx.normal, tx.tangent).ToLocal(MaterialNormal(m, tx, atlas));
    ab[t] = Vec2(l.x() / l.z(), l.y() / l.z());
  }
  return ab;
}

void Print(const char* name, const ModelSpec& spec, const std::vector<double>& p, double cost) {
  std::printf("  %-44s", name);
  const std::vector<ParamInfo> info = spec.Params();
  for (size_t i = 0; i < info.size(); ++i) std::printf(" %s %.4f", info[i].name.c_str(), p[i]);
  std::printf("  (rms %.5f)\n", std::sqrt(std::max(0.0, cost)));
}

// Least squares, then the clustering's Cauchy refit from it.
void FitBoth(const char* name, const ModelSpec& spec, const SampleSet& s, const std::vector<int64_t>& ids,
             const std::vector<double>& truth) {
  FitOptions fo;
  fo.max_samples = 40000;
  FitResult ls = FitModel(spec, s, ids, fo, truth);
  Print((std::string(name) + ", least squares").c_str(), spec, ls.params, ls.cost);
  std::vector<float> r;
  for (int64_t i : ids) {
    const Rgb p = PredictSample(spec, ls.params.data(), s, i);
    for (int c = 0; c < 3; ++c) r.push_back(std::abs(s.y[c][i] - float(p[c])));
  }
  std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
  fo.robust_scale = std::max(1e-6, 3.0 * 1.4826 * r[r.size() / 2]);
  fo.multi_start = false;
  FitResult rb = FitModel(spec, s, ids, fo, ls.params);
  Print((std::string(name) + ", Cauchy").c_str(), spec, rb.params, rb.cost);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s CAPTURE MATERIAL TRUE_K [min_weight]\n", argv[0]);
    return 2;
  }
  const std::string cap = argv[1];
  const Material rec = LoadMaterial(argv[2]);
  const int k = std::stoi(argv[3]);
  const double min_w = argc > 4 ? std::stod(argv[4]) : 0.999;
  const Scene scene = LoadScene(cap + "/scene.json");
  GatherOptions go;
  go.progress = false;
  const GatherResult g = Gather(scene, go);
  const Atlas& atlas = g.atlas;
  const Material truth = LoadMaterial(cap + "/gt");
  const int nt = g.samples.num_texels;
  const ModelSpec& spec = truth.basis[k].spec;
  std::printf("true material %d (%s):\n", k, spec.Label().c_str());
  Print("truth", spec, truth.basis[k].params, 0);

  std::vector<double> wk(nt, 0);
  std::vector<char> pure(nt, 0);
  for (int t = 0; t < nt; ++t) {
    double total = 0;
    for (size_t j = 0; j < truth.basis.size(); ++j) {
      const double w = MapAt(truth.weights[j], TexelUv(atlas.texels[t], atlas), 0);
      total += w;
      if (int(j) == k) wk[t] = w;
    }
    pure[t] = wk[t] > min_w && wk[t] > 0.999 * total;
  }
  // Texels of the reconstruction's material that overlaps TRUE_K most.
  std::vector<int> label(nt, -1);
  std::vector<long> overlap(rec.basis.size(), 0);
  for (int t = 0; t < nt; ++t) {
    const Vec2 uv = TexelUv(atlas.texels[t], atlas);
    if (rec.material_id.width) {
      const Vec2 p = UvToTexel(uv, rec.material_id.width, rec.material_id.height);
      label[t] = int(std::lround(rec.material_id.at(std::clamp(int(p.x()), 0, rec.material_id.width - 1),
                                                    std::clamp(int(p.y()), 0, rec.material_id.height - 1), 0)));
    }
    if (pure[t] && label[t] >= 0 && label[t] < int(overlap.size())) ++overlap[label[t]];
  }
  const int match = int(std::max_element(overlap.begin(), overlap.end()) - overlap.begin());
  long npure = 0;
  for (char p : pure) npure += p;
  std::printf("pure texels %ld; reconstruction's material m%d overlaps %ld of them\n", npure, match, overlap[match]);

  const std::vector<Vec2> mesh_ab(nt, Vec2::Zero()), true_ab = Tilts(atlas, truth), rec_ab = Tilts(atlas, rec);
  {
    // The reconstruction's tilts against the truth's on the pure texels:
    // gain = projection on the true tilt (1 = unbiased), and the residual.
    double dot = 0, tt = 0, rr = 0, perp = 0;
    for (int t = 0; t < nt; ++t) {
      if (!pure[t]) continue;
      dot += rec_ab[t].dot(true_ab[t]), tt += true_ab[t].squaredNorm(), rr += rec_ab[t].squaredNorm();
    }
    const double gain = dot / std::max(1e-30, tt);
    for (int t = 0; t < nt; ++t)
      if (pure[t]) perp += (rec_ab[t] - gain * true_ab[t]).squaredNorm();
    std::printf("reconstruction's tilts on the pure texels: gain %.4f of the true tilt (rms true %.3f deg), rms rest %.3f deg\n",
                gain, std::atan(std::sqrt(tt / npure)) * 180 / kPi, std::atan(std::sqrt(perp / npure)) * 180 / kPi);
  }
  struct Arm {
    const char* name;
    const std::vector<Vec2>* ab;
  };
  for (const Arm& arm : {Arm{"pure texels, mesh normals", &mesh_ab}, Arm{"pure texels, true normals", &true_ab},
                         Arm{"pure texels, reconstruction's normals", &rec_ab}}) {
    SampleSet s = ReorientSamples(g.samples, *arm.ab);
    std::vector<int64_t> ids;
    for (int t = 0; t < nt; ++t) {
      if (!pure[t]) continue;
      for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) {
        for (int c = 0; c < 3; ++c) s.y[c][i] /= float(wk[t]);
        ids.push_back(i);
      }
    }
    std::printf("%s: %zu samples\n", arm.name, ids.size());
    FitBoth(arm.name, spec, s, ids, truth.basis[k].params);
  }
  {
    const SampleSet s = ReorientSamples(g.samples, rec_ab);
    std::vector<int64_t> ids;
    for (int t = 0; t < nt; ++t)
      if (label[t] == match)
        for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) ids.push_back(i);
    std::printf("reconstruction's cluster m%d, its normals, unweighted: %zu samples\n", match, ids.size());
    FitBoth("cluster texels, reconstruction's normals", spec, s, ids, truth.basis[k].params);
    std::vector<int64_t> in;
    for (int t = 0; t < nt; ++t)
      if (label[t] == match && pure[t])
        for (int64_t i = s.texel_begin[t]; i < s.texel_begin[t + 1]; ++i) in.push_back(i);
    std::printf("... only its pure texels (not divided by the weight): %zu samples\n", in.size());
    FitBoth("cluster's pure texels, rec. normals", spec, s, in, truth.basis[k].params);
  }
  return 0;
}
