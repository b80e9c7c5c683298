#include "calib/cv_bridge.h"

#include <algorithm>

#include "core/error.h"

namespace svbrdf {

cv::Mat ToCvFloat(const Image& image) {
  cv::Mat m(image.height, image.width, CV_32FC(image.channels));
  std::copy(image.pixels.begin(), image.pixels.end(), m.ptr<float>());
  return m;
}

Image FromCv(const cv::Mat& m) {
  cv::Mat f;
  if (m.depth() == CV_8U) m.convertTo(f, CV_32F, 1.0 / 255.0);
  else if (m.depth() == CV_16U) m.convertTo(f, CV_32F, 1.0 / 65535.0);
  else if (m.depth() == CV_32F) f = m;
  else m.convertTo(f, CV_32F);
  if (!f.isContinuous()) f = f.clone();
  Image out(f.cols, f.rows, f.channels());
  std::copy(f.ptr<float>(), f.ptr<float>() + out.pixels.size(), out.pixels.begin());
  return out;
}

cv::Mat ToCv8(const Image& grey01) {
  if (grey01.channels != 1) throw Error("ToCv8: expected a one-channel image");
  cv::Mat m(grey01.height, grey01.width, CV_8U);
  for (int y = 0; y < grey01.height; ++y)
    for (int x = 0; x < grey01.width; ++x)
      m.at<uint8_t>(y, x) = uint8_t(std::clamp(grey01.at(x, y, 0), 0.0f, 1.0f) * 255.0f + 0.5f);
  return m;
}

}  // namespace svbrdf
