#include "calib/segment.h"

#include <algorithm>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/board.h"
#include "calib/cv_bridge.h"
#include "core/error.h"

namespace svbrdf {

namespace {
cv::Mat Binary(const Image& mask, bool inside) {
  cv::Mat m(mask.height, mask.width, CV_8U);
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) m.at<uint8_t>(y, x) = ((mask.at(x, y, 0) > 0.5f) == inside) ? 255 : 0;
  return m;
}
}  // namespace

Image SignedDistance(const Image& mask) {
  cv::Mat din, dout;
  // distanceTransform: distance of every non-zero pixel to the nearest zero pixel.
  cv::distanceTransform(Binary(mask, true), din, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::distanceTransform(Binary(mask, false), dout, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  Image sdf(mask.width, mask.height, 1);
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x)
      sdf.at(x, y, 0) = mask.at(x, y, 0) > 0.5f ? din.at<float>(y, x) - 0.5f : -(dout.at<float>(y, x) - 0.5f);
  return sdf;
}

Image GrabCutMask(const Image& photo, const Image& prior, int margin_px, int iterations) {
  if (photo.width != prior.width || photo.height != prior.height)
    throw Error("GrabCut: photo and prior differ in size");
  const Image sdf = SignedDistance(prior);
  cv::Mat labels(prior.height, prior.width, CV_8U);
  for (int y = 0; y < prior.height; ++y)
    for (int x = 0; x < prior.width; ++x) {
      const float d = sdf.at(x, y, 0);
      labels.at<uint8_t>(y, x) = d > margin_px ? cv::GC_FGD : d > 0 ? cv::GC_PR_FGD : d > -margin_px ? cv::GC_PR_BGD : cv::GC_BGD;
    }
  // 8-bit colour for GrabCut's Gaussian mixtures, tone-mapped like detection.
  Image grey_scale = ToDisplayGrey(photo, true);
  cv::Mat bgr(photo.height, photo.width, CV_8UC3);
  for (int y = 0; y < photo.height; ++y)
    for (int x = 0; x < photo.width; ++x) {
      double lum = 0;
      for (int c = 0; c < std::min(3, photo.channels); ++c) lum += photo.at(x, y, c);
      lum /= std::min(3, photo.channels);
      const double s = lum > 0 ? grey_scale.at(x, y, 0) / lum : 0;
      for (int c = 0; c < 3; ++c)
        bgr.at<cv::Vec3b>(y, x)[2 - c] =
            uint8_t(std::clamp(photo.at(x, y, std::min(c, photo.channels - 1)) * s * 255.0, 0.0, 255.0));
    }
  cv::Mat bgd, fgd;
  // GrabCut seeds its colour mixtures by k-means, which draws from the
  // calling thread's RNG; that state depends on what the thread ran before
  // (views are segmented in parallel), so it is reset: each mask is then a
  // function of its photo and prior alone, whatever the thread count.
  cv::theRNG().state = 0x5eedULL;
  cv::grabCut(bgr, labels, cv::Rect(), bgd, fgd, iterations, cv::GC_INIT_WITH_MASK);
  Image out(prior.width, prior.height, 1);
  for (int y = 0; y < prior.height; ++y)
    for (int x = 0; x < prior.width; ++x) {
      const int l = labels.at<uint8_t>(y, x);
      out.at(x, y, 0) = (l == cv::GC_FGD || l == cv::GC_PR_FGD) ? 1.0f : 0.0f;
    }
  return out;
}

double MaskIoU(const Image& a, const Image& b) {
  long inter = 0, uni = 0;
  for (size_t i = 0; i < std::min(a.pixels.size(), b.pixels.size()); ++i) {
    const bool x = a.pixels[i] > 0.5f, y = b.pixels[i] > 0.5f;
    inter += x && y;
    uni += x || y;
  }
  return uni ? double(inter) / uni : 1.0;
}

}  // namespace svbrdf
