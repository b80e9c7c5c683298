#include "evaluate/metrics.h"

#include <cmath>
#include <map>

#include "core/error.h"

namespace svbrdf {

ImageMetrics CompareImages(const Image& ref, const Image& test, const Image* mask, double exposure) {
  if (ref.width != test.width || ref.height != test.height)
    throw Error(Msg("compare: size ", test.width, "x", test.height, " differs from reference ", ref.width, "x", ref.height));
  double se = 0, se_lin = 0, ref_lin = 0;
  long n = 0;
  for (int y = 0; y < ref.height; ++y)
    for (int x = 0; x < ref.width; ++x) {
      if (mask && mask->at(x, y, 0) <= 0) continue;
      ++n;
      for (int c = 0; c < 3; ++c) {
        const double a = ref.at(x, y, std::min(c, ref.channels - 1)) / exposure;
        const double b = test.at(x, y, std::min(c, test.channels - 1)) / exposure;
        const double ea = LinearToSrgb(float(std::clamp(a, 0.0, 1.0)));
        const double eb = LinearToSrgb(float(std::clamp(b, 0.0, 1.0)));
        se += (ea - eb) * (ea - eb);
        se_lin += (a - b) * (a - b);
        ref_lin += a * a;
      }
    }
  ImageMetrics m;
  m.pixels = n;
  const double mse = n ? se / (3.0 * n) : 0.0;
  m.psnr_srgb = 10.0 * std::log10(1.0 / std::max(mse, 1e-12));
  m.rel_rmse_linear = ref_lin > 0 ? std::sqrt(se_lin / ref_lin) : 0.0;
  return m;
}

namespace {

// Sizes agree and every value that takes part (inside the mask) is finite:
// a metric over NaN would print "nan dB" instead of naming the broken file.
void CheckComparable(const Image& img, const std::string& file, const Image& ref, const std::string& ref_file,
                     const Image* mask) {
  if (img.width != ref.width || img.height != ref.height)
    throw Error(Msg(file, ": image is ", img.width, "x", img.height, " but ", ref_file, " is ", ref.width, "x",
                    ref.height));
  if (img.channels < 1) throw Error(Msg(file, ": image has no channels"));
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      if (mask && !(mask->at(x, y, 0) > 0)) continue;
      for (int c = 0; c < img.channels; ++c)
        if (!std::isfinite(img.at(x, y, c)))
          throw Error(Msg(file, ": pixel (", x, ", ", y, ") is not finite (", img.at(x, y, c), ")"));
    }
}

}  // namespace

SceneComparison CompareToScene(const Scene& scene, const std::string& rendered_dir) {
  SceneComparison out;
  double psnr = 0, rmse = 0;
  out.min_psnr_srgb = 1e9;
  for (const ImageEntry& e : scene.images) {
    const std::string ref_file = scene.Resolve(e.file), test_file = rendered_dir + "/" + e.file;
    const Image ref = ReadImage(ref_file, scene.images_color_space);
    const Image test = ReadImage(test_file, scene.images_color_space);
    Image mask;
    if (!e.mask.empty()) {
      mask = ReadImage(scene.Resolve(e.mask));
      CheckComparable(mask, scene.Resolve(e.mask), ref, ref_file, nullptr);
    }
    CheckComparable(ref, ref_file, ref, ref_file, e.mask.empty() ? nullptr : &mask);
    CheckComparable(test, test_file, ref, ref_file, e.mask.empty() ? nullptr : &mask);
    const ImageMetrics m = CompareImages(ref, test, e.mask.empty() ? nullptr : &mask, e.exposure);
    out.files.push_back(e.file);
    out.per_image.push_back(m);
    psnr += m.psnr_srgb;
    rmse += m.rel_rmse_linear;
    out.min_psnr_srgb = std::min(out.min_psnr_srgb, m.psnr_srgb);
  }
  if (!scene.images.empty()) {
    out.mean_psnr_srgb = psnr / scene.images.size();
    out.mean_rel_rmse = rmse / scene.images.size();
  }
  return out;
}

double AdjustedRandIndex(const std::vector<int>& a, const std::vector<int>& b) {
  if (a.size() != b.size()) throw Error("adjusted Rand index: labellings differ in length");
  std::map<std::pair<int, int>, double> nij;
  std::map<int, double> ai, bj;
  for (size_t k = 0; k < a.size(); ++k) {
    nij[{a[k], b[k]}] += 1;
    ai[a[k]] += 1;
    bj[b[k]] += 1;
  }
  auto c2 = [](double x) { return x * (x - 1) / 2; };
  double sum_ij = 0, sum_a = 0, sum_b = 0;
  for (auto& kv : nij) sum_ij += c2(kv.second);
  for (auto& kv : ai) sum_a += c2(kv.second);
  for (auto& kv : bj) sum_b += c2(kv.second);
  const double expected = sum_a * sum_b / std::max(1.0, c2(double(a.size())));
  const double max_index = 0.5 * (sum_a + sum_b);
  if (max_index - expected == 0) return 1.0;  // both labellings trivial and identical in structure
  return (sum_ij - expected) / (max_index - expected);
}

namespace {

// A perceptually ordered ramp (approximation of viridis by 5 control points).
Rgb Ramp(double t) {
  static const Rgb k[5] = {{0.267, 0.005, 0.329}, {0.229, 0.322, 0.546}, {0.128, 0.567, 0.551},
                           {0.369, 0.789, 0.383}, {0.993, 0.906, 0.144}};
  t = std::clamp(t, 0.0, 1.0) * 4.0;
  const int i = std::min(3, int(t));
  const double f = t - i;
  return k[i] * (1 - f) + k[i + 1] * f;
}

}  // namespace

Image ColorRamp(const Image& scalar, double lo, double hi) {
  Image out(scalar.width, scalar.height, 3);
  for (int y = 0; y < scalar.height; ++y)
    for (int x = 0; x < scalar.width; ++x) {
      const Rgb c = Ramp((scalar.at(x, y, 0) - lo) / std::max(1e-12, hi - lo));
      for (int k = 0; k < 3; ++k) out.at(x, y, k) = float(c[k]);
    }
  return out;
}

Image ErrorMap(const Image& a, const Image& b, double max_error) {
  Image err(a.width, a.height, 1);
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      double e = 0;
      for (int c = 0; c < 3; ++c) e += std::abs(a.at(x, y, std::min(c, a.channels - 1)) - b.at(x, y, std::min(c, b.channels - 1)));
      err.at(x, y, 0) = float(e / 3);
    }
  return ColorRamp(err, 0, max_error);
}

Image LabelMap(const Image& labels) {
  static const Rgb kColors[10] = {{0.90, 0.30, 0.24}, {0.20, 0.50, 0.85}, {0.30, 0.75, 0.35}, {0.95, 0.75, 0.20},
                                  {0.60, 0.35, 0.75}, {0.20, 0.80, 0.80}, {0.95, 0.50, 0.70}, {0.55, 0.55, 0.55},
                                  {0.60, 0.40, 0.20}, {0.10, 0.30, 0.20}};
  Image out(labels.width, labels.height, 3);
  for (int y = 0; y < labels.height; ++y)
    for (int x = 0; x < labels.width; ++x) {
      const int l = static_cast<int>(std::lround(labels.at(x, y, 0)));
      const Rgb c = l < 0 ? Rgb::Zero() : kColors[l % 10];
      for (int k = 0; k < 3; ++k) out.at(x, y, k) = float(c[k]);
    }
  return out;
}

}  // namespace svbrdf
