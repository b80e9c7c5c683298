// Accuracy measures used by the regression tests, the benchmark and the
// reconstruction report: PSNR on sRGB-encoded images (as shared/tools/
// check_capture.py computes it), linear relative RMSE, adjusted Rand index of
// two labellings, and false-colour pictures (error maps, label maps).
#pragma once
#include <string>
#include <vector>

#include "io/image.h"
#include "io/scene.h"

namespace svbrdf {

struct ImageMetrics {
  double psnr_srgb = 0;        // dB, radiance clipped to [0,1] and sRGB-encoded, over mask pixels
  double rel_rmse_linear = 0;  // sqrt(sum (a-b)^2 / sum a^2), linear radiance, over mask pixels
  long pixels = 0;
};

// Both images hold exposure * radiance; `exposure` is divided out first.
ImageMetrics CompareImages(const Image& reference, const Image& test, const Image* mask, double exposure = 1.0);

struct SceneComparison {
  std::vector<std::string> files;
  std::vector<ImageMetrics> per_image;
  double mean_psnr_srgb = 0, min_psnr_srgb = 0, mean_rel_rmse = 0;
};

// Compares every image of `scene` with the file of the same name under
// `rendered_dir` (as written by relight), inside the scene's masks.
SceneComparison CompareToScene(const Scene& scene, const std::string& rendered_dir);

double AdjustedRandIndex(const std::vector<int>& a, const std::vector<int>& b);

// |a - b| summed over channels, mapped through a perceptual colour ramp with
// `max_error` at the top; 8-bit-ready RGB in [0,1].
Image ErrorMap(const Image& a, const Image& b, double max_error);
// Distinct colours per integer label (negative = black).
Image LabelMap(const Image& labels);
// Scalar map to a colour ramp, values in [lo, hi].
Image ColorRamp(const Image& scalar, double lo, double hi);

}  // namespace svbrdf
