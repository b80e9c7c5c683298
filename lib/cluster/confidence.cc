#include "cluster/confidence.h"

#include <algorithm>
#include <cmath>

#include "atlas/surface_neighbours.h"
#include "core/types.h"

namespace svbrdf {

namespace {

// Neighbour fill for texels without confident weights: repeated averaging of
// the 4-neighbours that have weights (a discrete harmonic fill).
void FillFromNeighbours(const Atlas& atlas, int K, std::vector<float>* w, std::vector<char>* known) {
  const int nt = static_cast<int>(atlas.texels.size());
  for (int pass = 0; pass < atlas.width + atlas.height; ++pass) {
    std::vector<int> newly;
    std::vector<float> acc(size_t(nt) * K * 3, 0.0f);
    for (int t = 0; t < nt; ++t) {
      if ((*known)[t]) continue;
      const Texel& tx = atlas.texels[t];
      int n = 0;
      const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
      for (auto& d : nb) {
        const int x = tx.x + d[0], y = tx.y + d[1];
        if (x < 0 || y < 0 || x >= atlas.width || y >= atlas.height) continue;
        const int u = atlas.At(x, y);
        if (u < 0 || !(*known)[u]) continue;
        for (int j = 0; j < K * 3; ++j) acc[size_t(t) * K * 3 + j] += (*w)[size_t(u) * K * 3 + j];
        ++n;
      }
      if (n == 0) continue;
      for (int j = 0; j < K * 3; ++j) (*w)[size_t(t) * K * 3 + j] = acc[size_t(t) * K * 3 + j] / n;
      newly.push_back(t);
    }
    if (newly.empty()) break;
    for (int t : newly) (*known)[t] = 1;
  }
}

}  // namespace

void ConfidenceAndFill(const SampleSet& samples, const Atlas& atlas, const ReconstructOptions& o, int num_basis,
                       SvbrdfEstimate* est_out) {
  SvbrdfEstimate& est = *est_out;
  const int K = num_basis;
  const int nt = samples.num_texels;
  est.num_texels = nt;
  est.confidence.assign(nt, 0.0f);
  std::vector<char> known(nt, 0);
  for (int t = 0; t < nt; ++t) {
    const int64_t b = samples.texel_begin[t], e = samples.texel_begin[t + 1];
    // Spread: RMS distance of the half vectors from their mean (0 = one direction only).
    Vec3 mean = Vec3::Zero();
    std::vector<Vec3> hs;
    for (int64_t i = b; i < e; ++i) {
      const Vec3 h = Vec3(samples.wi[0][i] + samples.wo[0][i], samples.wi[1][i] + samples.wo[1][i],
                          samples.wi[2][i] + samples.wo[2][i]).normalized();
      hs.push_back(h);
      mean += h;
    }
    double spread = 0;
    if (!hs.empty()) {
      mean /= double(hs.size());
      for (const Vec3& h : hs) spread += (h - mean).squaredNorm();
      spread = std::sqrt(spread / hs.size());
    }
    const double count_term = std::min(1.0, double(e - b) / (2.0 * o.min_samples));
    const double spread_term = std::min(1.0, spread / 0.1);
    est.confidence[t] = float(count_term * spread_term);
    known[t] = (e - b) >= o.min_samples && spread > 0.02;
    est.confidence[t] *= known[t] ? 1.0f : 0.25f;
  }
  for (int t = 0; t < nt; ++t)
    if (!known[t]) std::fill(est.weights.begin() + size_t(t) * K * 3, est.weights.begin() + size_t(t + 1) * K * 3, 0.0f);
  const auto copy_from = [&](const std::vector<int>& from) {
    for (int t = 0; t < nt; ++t)
      if (from[t] >= 0) {
        std::copy(est.weights.begin() + size_t(from[t]) * K * 3, est.weights.begin() + size_t(from[t] + 1) * K * 3,
                  est.weights.begin() + size_t(t) * K * 3);
        known[t] = 1;
      }
  };
  // Border texels (outside every UV triangle: the dilation ring, texels of
  // sub-texel triangles at chart tips) stand for the surface at the chart
  // border, which continues in the next chart: without weights of their own
  // they take those of the known texel nearest on the surface (its own
  // chart's or across the seam), when one is within two texels. The
  // texture neighbours of a tip texel can be several texels away in
  // another material (measured on the tiny no-UV sphere: weights off by up
  // to 0.66 at chart tips, a streak in one held-out highlight).
  std::vector<char> border(nt);
  for (int t = 0; t < nt; ++t) border[t] = !known[t] && !atlas.texels[t].interior;
  if (std::count(border.begin(), border.end(), 1) > 0) copy_from(NearestKnownTexels(atlas, known, border, 2.0));
  FillFromNeighbours(atlas, K, &est.weights, &known);
  // Texels the fill never reached lie in charts without a single known
  // texel (generated atlases: a sliver or folded triangle alone in its
  // chart, with no known texel within two texels either): they take the
  // weights of the texel nearest on the surface, however far, instead of
  // none (zero weights relight black: 1379 texels of the small synthetic
  // bunny scan did, 32.7 instead of 36.1 dB held-out).
  std::vector<char> unreached(nt);
  for (int t = 0; t < nt; ++t) unreached[t] = !known[t];
  if (std::count(unreached.begin(), unreached.end(), 1) > 0) copy_from(NearestKnownTexels(atlas, known, unreached));
  est.label.assign(nt, -1);
  for (int t = 0; t < nt; ++t) {
    double best = -1;
    for (int k = 0; k < K; ++k) {
      const double w = est.weights[(size_t(t) * K + k) * 3] + est.weights[(size_t(t) * K + k) * 3 + 1] +
                       est.weights[(size_t(t) * K + k) * 3 + 2];
      if (w > best) best = w, est.label[t] = k;
    }
  }
}

}  // namespace svbrdf
