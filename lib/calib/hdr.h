// High dynamic range from exposure brackets, with per-pixel saturation.
//
// Linear input (16-bit linear PNG/TIFF, RAW developed linearly, EXR): each
// pixel's radiance is the weighted mean of value/exposure over the shots in
// which it is neither saturated nor in the noise floor (hat weights times
// the exposure, so longer exposures, with less relative noise, count more);
// a pixel saturated in every shot is flagged. Non-linear 8-bit input (JPEG):
// the camera response is recovered first with OpenCV's Debevec-Malik method
// and the shots merged with OpenCV's Robertson weighting (MergeRobertson).
#pragma once
#include <vector>

#include "io/image.h"

namespace svbrdf {

// Parameters (name, meaning, range):
//   low, high  usable band of the normalised pixel value: below low is noise,
//              at or above high is (near) saturation; 0 <= low < high <= 1
struct HdrOptions {
  double low = 0.002, high = 0.98;
  void Check() const;
};

struct HdrResult {
  Image radiance;   // value / exposure, linear, 3 channels as the input
  Image saturated;  // 1 channel: 1 where no shot had an unsaturated value
};

// `shots` share size and channels; values normalised to [0, 1] (integer
// files) with `saturation_level` 1, or float.
HdrResult MergeLinear(const std::vector<Image>& shots, const std::vector<double>& exposures, const HdrOptions& options);
// 8-bit sRGB-encoded shots (values 0..1 as read, not decoded): Debevec.
HdrResult MergeDebevec(const std::vector<Image>& shots, const std::vector<double>& exposure_seconds);

}  // namespace svbrdf
