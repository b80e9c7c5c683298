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

HdrResult MergeDebevec(const std::vector<Image>& shots, const std::vector<double>& seconds) {
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
  // Response by Debevec-Malik (200 grid samples: 70, OpenCV's default, left
  // 1.8 % RMS non-linearity on 6 brackets); the merge by Robertson's weighting
  // with that response: OpenCV's MergeDebevec on the same response was 13-24 %
  // off linear in tests/calib_test.cc (see also opencv/opencv#26613).
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
