// Conversions between the project's float Image and OpenCV matrices; only
// lib/calib sees OpenCV.
#pragma once
#include <opencv2/core.hpp>

#include "core/types.h"
#include "io/image.h"

namespace svbrdf {

// Float image -> CV_32FC(channels) (copy; channel order unchanged).
cv::Mat ToCvFloat(const Image& image);
// CV_8U / CV_32F, 1 or 3 channels -> Image (8-bit values scaled to [0, 1]).
Image FromCv(const cv::Mat& m);
// 8-bit single channel from an Image already in [0, 1] (clamped).
cv::Mat ToCv8(const Image& grey01);

}  // namespace svbrdf
