// High dynamic range from exposure brackets, with per-pixel saturation.
//
// Linear input (16-bit linear PNG/TIFF, RAW developed linearly, EXR): each
// pixel's radiance is the weighted mean of value/exposure over the shots in
// which it is neither saturated nor in the noise floor (hat weights times
// the exposure, so longer exposures, with less relative noise, count more);
// a pixel saturated in every shot is flagged. Non-linear 8-bit input (JPEG):
// the camera response is recovered first (Debevec-Malik over all pixels,
// then a degree-6 polynomial after Mitsunaga-Nayar), then the shots merged
// in the log domain. On synthetic bracket sets this comes closer to linear
// than OpenCV's CalibrateDebevec + MergeRobertson (tests/calib_test.cc;
// bench_results/front_half.md).
#pragma once
#include <array>
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
// Non-linear 8-bit shots (values 0..1 as read, not decoded).
//
// Parameters (name, meaning, range):
//   smoothness         weight of the response's second differences relative to
//                      the data, >= 0 (Debevec-Malik's lambda, normalised)
//   low_code, high_code  usable codes are strictly between them (noise floor,
//                      clipping); 0 <= low_code < high_code <= 255
//   sample_stride      every n-th pixel in x and y feeds the response, >= 1
//   polynomial_degree  > 0: the response is a polynomial of this degree in the
//                      code (Mitsunaga-Nayar), fitted after Debevec-Malik;
//                      0: Debevec-Malik's free response, in [0, 10]
struct ResponseOptions {
  double smoothness = 1.0;
  int low_code = 2, high_code = 253;
  int sample_stride = 1;
  int polynomial_degree = 6;
  void Check() const;
};
// Inverse camera response per channel: the linear value (up to one common
// scale) of each 8-bit code.
struct CameraResponse {
  std::array<std::vector<double>, 3> linear;
  int channels = 0;
};
// Debevec-Malik response recovery over all pixels (pairwise form: the
// radiance drops out, 256 unknowns per channel).
CameraResponse RecoverResponse(const std::vector<Image>& shots, const std::vector<double>& exposure_seconds,
                               const ResponseOptions& options);
// Log-domain weighted merge with a known response; weights: the hat over
// the usable codes divided by the code's quantisation variance.
HdrResult MergeWithResponse(const std::vector<Image>& shots, const std::vector<double>& exposure_seconds,
                            const CameraResponse& response, const ResponseOptions& options);
// Both of the above with default options.
HdrResult MergeDebevec(const std::vector<Image>& shots, const std::vector<double>& exposure_seconds);
// OpenCV's CalibrateDebevec response with OpenCV's MergeRobertson (for comparison).
HdrResult MergeDebevecOpenCv(const std::vector<Image>& shots, const std::vector<double>& exposure_seconds);

}  // namespace svbrdf
