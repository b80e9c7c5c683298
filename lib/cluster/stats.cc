#include "cluster/stats.h"

#include <algorithm>
#include <cmath>

#include "fit/fit.h"
#include "io/image.h"

namespace svbrdf {

namespace {
inline double Sq(double x) { return x * x; }
}  // namespace

double Shown(double v, const DisplayScale& display, const SampleSet& s, int64_t i, int c) {
  if (display.empty()) return v;
  return LinearToSrgb(float(std::clamp(v * display[size_t(s.image[i])][c], 0.0, 1.0)));
}

std::vector<double> SampleErrors(const ModelSpec& spec, const std::vector<double>& params, const SampleSet& s,
                                 const std::vector<int64_t>& ids, const DisplayScale& display) {
  std::vector<double> e(ids.size());
  std::vector<Rgb> p(ids.size());
  PredictSamples(spec, params.data(), s, ids.data(), 0, int64_t(ids.size()), p.data());
  for (size_t j = 0; j < ids.size(); ++j) {
    const int64_t i = ids[j];
    e[j] = 0;
    for (int c = 0; c < 3; ++c) e[j] += Sq(Shown(p[j][c], display, s, i, c) - Shown(s.y[c][i], display, s, i, c));
  }
  return e;
}

double TrimmedRmse(std::vector<double> e) {
  if (e.empty()) return 0.0;
  const size_t keep = std::max<size_t>(1, e.size() - e.size() / 50);
  std::nth_element(e.begin(), e.begin() + (keep - 1), e.end());
  double sum = 0;
  for (size_t j = 0; j < keep; ++j) sum += e[j];
  return std::sqrt(sum / (3.0 * keep));
}

double ClippedShare(const SampleSet& s, const std::vector<int64_t>& ids, const DisplayScale& display) {
  if (display.empty() || ids.empty()) return 0.0;
  int64_t clipped = 0;
  for (int64_t i : ids) {
    bool white = false;
    for (int c = 0; c < 3; ++c) white |= s.y[c][i] * display[size_t(s.image[i])][c] >= 1.0;
    clipped += white;
  }
  return double(clipped) / double(ids.size());
}

double SignalRms(const SampleSet& samples, const std::vector<int64_t>& ids, const DisplayScale& display) {
  double signal = 0;
  for (int64_t i : ids)
    for (int c = 0; c < 3; ++c) signal += Sq(Shown(samples.y[c][i], display, samples, i, c));
  return std::sqrt(signal / std::max<double>(1.0, 3.0 * ids.size()));
}

double PairedZ(const std::vector<double>& a, const std::vector<double>& b) {
  double sum = 0, sum2 = 0;
  for (size_t t = 0; t < a.size(); ++t) sum += a[t] - b[t], sum2 += (a[t] - b[t]) * (a[t] - b[t]);
  const double n = double(a.size()), var = std::max(0.0, sum2 / n - (sum / n) * (sum / n));
  return sum / std::max(1e-300, std::sqrt(var * n));
}

double BoundedPairedZ(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> d, zero;
  for (size_t t = 0; t < a.size(); ++t)
    if (a[t] + b[t] > 0) d.push_back((a[t] - b[t]) / (a[t] + b[t]));
  zero.assign(d.size(), 0.0);
  return PairedZ(d, zero);
}

double ImprovementZ(const std::vector<double>& a, const std::vector<double>& b) {
  return std::max(PairedZ(a, b), BoundedPairedZ(a, b));
}

namespace {

// Marks the largest `trim` share of v's first n entries in *worst.
void MarkWorst(const std::vector<double>& v, size_t n, double trim, std::vector<char>* worst) {
  const size_t cut = size_t(trim * double(n));
  if (cut == 0) return;
  std::vector<size_t> order(n);
  for (size_t t = 0; t < n; ++t) order[t] = t;
  std::nth_element(order.begin(), order.begin() + (cut - 1), order.end(),
                   [&v](size_t x, size_t y) { return v[x] > v[y]; });
  for (size_t j = 0; j < cut; ++j) (*worst)[order[j]] = 1;
}

double DropWithout(const std::vector<double>& a, const std::vector<double>& b, const std::vector<char>& worst) {
  double sa = 0, sb = 0;
  for (size_t t = 0; t < worst.size(); ++t)
    if (!worst[t]) sa += a[t], sb += b[t];
  return 1.0 - sb / std::max(1e-300, sa);
}

}  // namespace

std::vector<char> WorstOfEither(const std::vector<double>& a, const std::vector<double>& b, double trim) {
  const size_t n = std::min(a.size(), b.size());
  std::vector<char> worst(n, 0);
  MarkWorst(a, n, trim, &worst);
  MarkWorst(b, n, trim, &worst);
  return worst;
}

double TrimmedDrop(const std::vector<double>& a, const std::vector<double>& b, double trim) {
  return DropWithout(a, b, WorstOfEither(a, b, trim));
}

double RemovalDrop(const std::vector<double>& without, const std::vector<double>& with, double trim) {
  const size_t n = std::min(without.size(), with.size());
  std::vector<char> worst(n, 0);
  MarkWorst(with, n, trim, &worst);
  return DropWithout(without, with, worst);
}

}  // namespace svbrdf
