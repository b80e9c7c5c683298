#include "cluster/confidence.h"

#include <algorithm>
#include <cmath>

#include "atlas/surface_neighbours.h"
#include "cluster/weights.h"
#include "core/error.h"
#include "core/types.h"

namespace svbrdf {

namespace {

// Weights of texels that no photo saw: repeated averaging of the surface
// neighbours (8-neighbours in the atlas and across chart borders and seams,
// SurfaceNeighbours) that have weights, front by front (a discrete harmonic
// fill). Returns how many texels were filled.
int FillFromNeighbours(const std::vector<std::vector<int>>& nb, int K, std::vector<float>* w, std::vector<char>* known) {
  const int nt = static_cast<int>(nb.size());
  const size_t stride = size_t(K) * 3;
  int filled = 0;
  for (;;) {
    std::vector<int> newly;
    std::vector<float> acc(stride);
    for (int t = 0; t < nt; ++t) {
      if ((*known)[t]) continue;
      std::fill(acc.begin(), acc.end(), 0.0f);
      int n = 0;
      for (int u : nb[t]) {
        if (!(*known)[u]) continue;
        for (size_t j = 0; j < stride; ++j) acc[j] += (*w)[size_t(u) * stride + j];
        ++n;
      }
      if (n == 0) continue;
      for (size_t j = 0; j < stride; ++j) (*w)[size_t(t) * stride + j] = acc[j] / n;
      newly.push_back(t);
    }
    if (newly.empty()) break;
    for (int t : newly) (*known)[t] = 1;
    filled += int(newly.size());
  }
  return filled;
}

}  // namespace

void ConfidenceAndFill(const SampleSet& samples, const Atlas& atlas, const ReconstructOptions& o, int num_basis,
                       const std::vector<std::vector<int>>& neighbours, SvbrdfEstimate* est_out) {
  if (int(neighbours.size()) != samples.num_texels)
    throw Error(Msg("ConfidenceAndFill: ", neighbours.size(), " neighbour lists for ", samples.num_texels, " texels"));
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
    // Texels with few or poorly spread samples keep the weights of their
    // own samples (the final weights' priors towards their cluster's
    // material and their neighbours' weights keep them from overfitting;
    // seen with 8 photos: replacing them by their neighbours' averages
    // filled most of the surface from the few texels seen 3 times), at a
    // low confidence.
    const bool confident = (e - b) >= o.min_samples && spread > 0.02;
    known[t] = e > b;
    est.confidence[t] *= confident ? 1.0f : 0.25f;
  }
  for (int t = 0; t < nt; ++t)
    if (!known[t]) std::fill(est.weights.begin() + size_t(t) * K * 3, est.weights.begin() + size_t(t + 1) * K * 3, 0.0f);
  est.texels_without_samples = int(std::count(known.begin(), known.end(), char(0)));
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
  // another material (on the tiny no-UV sphere: weights far off at chart
  // tips, a streak in one held-out highlight).
  std::vector<char> border(nt);
  for (int t = 0; t < nt; ++t) border[t] = !known[t] && !atlas.texels[t].interior;
  if (std::count(border.begin(), border.end(), 1) > 0) copy_from(NearestKnownTexels(atlas, known, border, 2.0));
  FillFromNeighbours(neighbours, K, &est.weights, &known);
  // Texels the fill never reached lie in charts without a single known
  // texel (generated atlases: a sliver or folded triangle alone in its
  // chart, with no known texel within two texels either): they take the
  // weights of the texel nearest on the surface, however far, instead of
  // none (zero weights relight black, as such texels of the small
  // synthetic bunny scan did).
  std::vector<char> unreached(nt);
  for (int t = 0; t < nt; ++t) unreached[t] = !known[t];
  if (std::count(unreached.begin(), unreached.end(), 1) > 0) copy_from(NearestKnownTexels(atlas, known, unreached));
  est.texels_filled = est.texels_without_samples - int(std::count(known.begin(), known.end(), char(0)));
  est.label = K > 0 ? FilledWeightLabels(est.weights, K) : std::vector<int>(nt, -1);
}

std::vector<int> FilledWeightLabels(const std::vector<float>& weights, int K) {
  std::vector<int> label = LargestWeightLabels(weights, K);
  for (int& l : label) l = std::max(l, 0);
  return label;
}

}  // namespace svbrdf
