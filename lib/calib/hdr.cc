#include "calib/hdr.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>

#include "calib/cv_bridge.h"
#include "core/error.h"

namespace svbrdf {

void HdrOptions::Check() const {
  if (!(low >= 0 && low < high && high <= 1)) throw Error("hdr: need 0 <= low < high <= 1");
}

namespace {
void CheckShots(const std::vector<Image>& shots, const std::vector<double>& exposures) {
  if (shots.empty() || shots.size() != exposures.size()) throw Error("hdr: one exposure per shot needed");
  for (size_t i = 0; i < shots.size(); ++i) {
    if (shots[i].width != shots[0].width || shots[i].height != shots[0].height || shots[i].channels != shots[0].channels)
      throw Error(Msg("hdr: bracket ", i, " differs in size or channels from bracket 0"));
    if (!(exposures[i] > 0)) throw Error(Msg("hdr: bracket ", i, ": exposure must be > 0"));
  }
}
}  // namespace

HdrResult MergeLinear(const std::vector<Image>& shots, const std::vector<double>& exposures, const HdrOptions& o) {
  o.Check();
  CheckShots(shots, exposures);
  const Image& s0 = shots[0];
  HdrResult r{Image(s0.width, s0.height, s0.channels), Image(s0.width, s0.height, 1)};
  r.radiance.saturation_level = INFINITY;
  const size_t shortest = std::min_element(exposures.begin(), exposures.end()) - exposures.begin();
  for (int y = 0; y < s0.height; ++y)
    for (int x = 0; x < s0.width; ++x) {
      // A pixel is unusable in a shot when any channel is saturated (colour would shift).
      bool any_usable = false;
      for (int c = 0; c < s0.channels; ++c) {
        double num = 0, den = 0;
        for (size_t k = 0; k < shots.size(); ++k) {
          const float level = std::isfinite(shots[k].saturation_level) ? shots[k].saturation_level : INFINITY;
          bool sat = false;
          for (int cc = 0; cc < s0.channels; ++cc) sat |= shots[k].at(x, y, cc) >= o.high * level;
          if (sat) continue;
          const double v = shots[k].at(x, y, c);
          const double rel = std::isfinite(level) ? v / level : 0.5;
          // Hat weight, but keep a floor so that dark pixels still average.
          const double hat = rel < o.low ? 0.05 : std::min(1.0, 1.0 - 2.0 * std::abs(rel - 0.5) + 0.05);
          const double w = hat * exposures[k];
          num += w * v / exposures[k];
          den += w;
        }
        if (den > 0) {
          r.radiance.at(x, y, c) = float(num / den);
          any_usable = true;
        } else {
          r.radiance.at(x, y, c) = float(shots[shortest].at(x, y, c) / exposures[shortest]);
        }
      }
      r.saturated.at(x, y, 0) = any_usable ? 0.0f : 1.0f;
    }
  return r;
}

void ResponseOptions::Check() const {
  if (!(smoothness >= 0)) throw Error("hdr response: smoothness must be >= 0");
  if (!(0 <= low_code && low_code < high_code && high_code <= 255)) throw Error("hdr response: need 0 <= low_code < high_code <= 255");
  if (sample_stride < 1) throw Error("hdr response: sample_stride must be >= 1");
  if (polynomial_degree < 0 || polynomial_degree > 10) throw Error("hdr response: polynomial_degree must be in [0, 10]");
}

namespace {
int Code(float v) { return std::clamp(int(std::lround(v * 255.0f)), 0, 255); }
// Debevec-Malik's hat weight over the usable codes: zero outside them.
double Hat(int z, const ResponseOptions& o) {
  if (z <= o.low_code || z >= o.high_code) return 0;
  return std::min(z - o.low_code, o.high_code - z);
}
}  // namespace

namespace {
// Mitsunaga-Nayar: the inverse response as a polynomial in the code,
// f(z) = sum_n c_n (z/255)^n with f(255) = 1, from the ratio constraints
// f(z_j) = (t_j / t_k) f(z_k) of every pixel's shot pairs (linear in c),
// weighted to relative error and re-weighted twice with the current f.
// A low-order polynomial cannot follow the wiggles that a free response
// (Debevec-Malik) picks up with brackets a constant ratio apart: any
// response perturbed periodically in log radiance with that ratio as period
// satisfies every constraint.
void FitPolynomialResponse(const std::vector<Image>& shots, const std::vector<double>& seconds,
                           const ResponseOptions& o, CameraResponse* r) {
  const Image& s0 = shots[0];
  const int n = o.polynomial_degree;
  for (int c = 0; c < s0.channels; ++c) {
    Eigen::VectorXd coef;
    for (int pass = 0; pass < 3; ++pass) {
      Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n + 1, n + 1);
      std::vector<int> z(shots.size());
      auto basis = [&](int code) {
        Eigen::VectorXd b(n + 1);
        const double u = code / 255.0;
        double p = 1;
        for (int k = 0; k <= n; ++k) b(k) = p, p *= u;
        return b;
      };
      std::vector<Eigen::VectorXd> B(256);
      std::vector<double> f(256);
      for (int code = 0; code < 256; ++code) {
        B[code] = basis(code);
        f[code] = pass == 0 ? r->linear[c][code] / r->linear[c][255] : B[code].dot(coef);
      }
      for (int y = 0; y < s0.height; y += o.sample_stride)
        for (int x = 0; x < s0.width; x += o.sample_stride) {
          for (size_t k = 0; k < shots.size(); ++k) z[k] = Code(shots[k].at(x, y, c));
          for (size_t j = 0; j < shots.size(); ++j)
            for (size_t k = j + 1; k < shots.size(); ++k) {
              const double w = Hat(z[j], o) * Hat(z[k], o);
              if (w <= 0) continue;
              const double ratio = seconds[j] / seconds[k];
              const Eigen::VectorXd row = B[z[j]] - ratio * B[z[k]];
              const double scale = std::max(f[z[j]], 1e-6);  // relative residual
              A += (w / (scale * scale)) * row * row.transpose();
            }
        }
      // Minimise c' A c subject to f(255) = sum c = 1 (Lagrange).
      Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n + 2, n + 2);
      Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n + 2);
      K.topLeftCorner(n + 1, n + 1) = A / std::max(A.trace(), 1e-300);
      K.block(0, n + 1, n + 1, 1) = B[255];
      K.block(n + 1, 0, 1, n + 1) = B[255].transpose();
      rhs(n + 1) = 1;
      coef = K.fullPivLu().solve(rhs).head(n + 1);
    }
    std::vector<double>& lin = r->linear[c];
    double p_min = 1e-6;  // f must stay positive and increasing for the log-domain merge
    for (int code = 0; code < 256; ++code) {
      double v = 0, p = 1;
      for (int k = 0; k <= n; ++k) v += coef(k) * p, p *= code / 255.0;
      lin[code] = std::max(v, code ? lin[code - 1] * (1 + 1e-9) : p_min);
    }
  }
}
}  // namespace

CameraResponse RecoverResponse(const std::vector<Image>& shots, const std::vector<double>& seconds,
                               const ResponseOptions& o) {
  o.Check();
  CheckShots(shots, seconds);
  const Image& s0 = shots[0];
  CameraResponse r;
  r.channels = s0.channels;
  for (int c = 0; c < s0.channels; ++c) {
    // g(z) = ln(linear value of code z). Every pair of shots of a pixel with
    // both codes usable says g(z_j) - g(z_k) = ln t_j - ln t_k; the radiance
    // drops out, so every pixel can be used (Debevec-Malik solve for a
    // sample's radiance; with all pixels that is 256 unknowns, normal
    // equations accumulated here).
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(256, 256);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(256);
    double total = 0;
    std::vector<int> z(shots.size());
    for (int y = 0; y < s0.height; y += o.sample_stride)
      for (int x = 0; x < s0.width; x += o.sample_stride) {
        for (size_t k = 0; k < shots.size(); ++k) z[k] = Code(shots[k].at(x, y, c));
        for (size_t j = 0; j < shots.size(); ++j)
          for (size_t k = j + 1; k < shots.size(); ++k) {
            const double w = Hat(z[j], o) * Hat(z[k], o);
            if (w <= 0 || z[j] == z[k]) continue;
            const double rhs = std::log(seconds[j]) - std::log(seconds[k]);
            A(z[j], z[j]) += w, A(z[k], z[k]) += w, A(z[j], z[k]) -= w, A(z[k], z[j]) -= w;
            b(z[j]) += w * rhs, b(z[k]) -= w * rhs;
            total += w;
          }
      }
    if (total <= 0) throw Error("hdr response: no pixel is usable in two brackets; brackets too far apart?");
    // Smoothness (second differences, hat-weighted as in Debevec-Malik) keeps
    // codes with few observations in line; scaled to the data's weight.
    const double lambda = o.smoothness * total / 256;
    for (int zz = 1; zz < 255; ++zz) {
      const double w = lambda * (1.0 + Hat(zz, o)) / 128;
      const int idx[3] = {zz - 1, zz, zz + 1};
      const double coef[3] = {1, -2, 1};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) A(idx[i], idx[j]) += w * coef[i] * coef[j];
    }
    A(128, 128) += total;  // gauge: g(128) = 0
    const Eigen::VectorXd g = A.ldlt().solve(b);
    r.linear[c].resize(256);
    for (int zz = 0; zz < 256; ++zz) r.linear[c][zz] = std::exp(g(zz));
  }
  if (o.polynomial_degree > 0) FitPolynomialResponse(shots, seconds, o, &r);
  return r;
}

HdrResult MergeWithResponse(const std::vector<Image>& shots, const std::vector<double>& seconds,
                            const CameraResponse& response, const ResponseOptions& o) {
  o.Check();
  CheckShots(shots, seconds);
  const Image& s0 = shots[0];
  if (response.channels != s0.channels) throw Error("hdr: response and shots differ in channels");
  HdrResult r{Image(s0.width, s0.height, s0.channels), Image(s0.width, s0.height, 1)};
  r.radiance.saturation_level = INFINITY;
  const size_t shortest = std::min_element(seconds.begin(), seconds.end()) - seconds.begin();
  for (int y = 0; y < s0.height; ++y)
    for (int x = 0; x < s0.width; ++x) {
      bool clipped = false;
      for (int c = 0; c < s0.channels; ++c) {
        const std::vector<double>& lin = response.linear[c];
        double num = 0, den = 0;
        for (size_t k = 0; k < shots.size(); ++k) {
          const int z = Code(shots[k].at(x, y, c));
          // Weight: the hat (away from clipping and the noise floor) over
          // the code's quantisation variance in log radiance, (ln f(z+1) -
          // ln f(z-1))^2 / 4: a code where the response is steep is coarse.
          const double step = 0.5 * std::log(lin[std::min(z + 1, 255)] / lin[std::max(z - 1, 0)]);
          const double w = Hat(z, o) / std::max(step * step, 1e-12);
          if (w <= 0) continue;
          num += w * std::log(lin[z] / seconds[k]);
          den += w;
        }
        const int zs = Code(shots[shortest].at(x, y, c));
        clipped |= zs >= 255;
        r.radiance.at(x, y, c) = float(den > 0 ? std::exp(num / den) : lin[zs] / seconds[shortest]);
      }
      r.saturated.at(x, y, 0) = clipped ? 1.0f : 0.0f;
    }
  return r;
}

HdrResult MergeDebevecOpenCv(const std::vector<Image>& shots, const std::vector<double>& seconds) {
  CheckShots(shots, seconds);
  std::vector<cv::Mat> mats;
  std::vector<float> times;
  for (size_t k = 0; k < shots.size(); ++k) {
    cv::Mat f = ToCvFloat(shots[k]), m8, bgr;
    f.convertTo(m8, CV_8U, 255.0);
    if (m8.channels() == 3) cv::cvtColor(m8, bgr, cv::COLOR_RGB2BGR);
    else cv::cvtColor(m8, bgr, cv::COLOR_GRAY2BGR);
    mats.push_back(bgr);
    times.push_back(float(seconds[k]));
  }
  cv::Mat response, hdr;
  // Response by Debevec-Malik (200 grid samples: OpenCV's default of 70
  // leaves a clear non-linearity); the merge by Robertson's weighting with
  // that response: OpenCV's MergeDebevec on the same response is far off
  // linear in tests/calib_test.cc (see also opencv/opencv#26613).
  cv::createCalibrateDebevec(200)->process(mats, response, times);
  cv::createMergeRobertson()->process(mats, hdr, times, response);
  cv::Mat rgb;
  cv::cvtColor(hdr, rgb, cv::COLOR_BGR2RGB);
  HdrResult r{FromCv(rgb), Image(shots[0].width, shots[0].height, 1)};
  r.radiance.saturation_level = INFINITY;
  const size_t shortest = std::min_element(seconds.begin(), seconds.end()) - seconds.begin();
  for (int y = 0; y < r.saturated.height; ++y)
    for (int x = 0; x < r.saturated.width; ++x)
      for (int c = 0; c < shots[shortest].channels; ++c)
        if (shots[shortest].at(x, y, c) >= 254.5f / 255.0f) r.saturated.at(x, y, 0) = 1.0f;
  return r;
}

}  // namespace svbrdf

namespace svbrdf {
HdrResult MergeDebevec(const std::vector<Image>& shots, const std::vector<double>& seconds) {
  const ResponseOptions o;
  return MergeWithResponse(shots, seconds, RecoverResponse(shots, seconds, o), o);
}
}  // namespace svbrdf
